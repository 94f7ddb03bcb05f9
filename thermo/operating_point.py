"""The operating point of a real-gas run: every figure the run takes from CoolProp for (fluid, p_s, T_s, p_d), computed
once and cached on disk, so that a run whose point and property table are cached never imports CoolProp (2.3 s of
CPU; docs/model.md §7.1).

`OperatingPoint` (SI) holds the canonical CoolProp name; the suction density rho_1 = rho(T_s, p_s), enthalpy h_1 and
entropy s_1; the isentropic discharge enthalpy h_2s = h(p_d, s_1) (docs/model.md §6.4); the suction gas's speed of
sound c_1 (the run-cost estimate's chamber relaxation, docs/model.md §8.3); the nozzle law's ideal-gas
R = 8314.462/M and k = c_p0/(c_p0 - R) at T_s (docs/model.md §7.4); the property table's Envelope
(thermo.property_table.envelope_for); T_crit; the suction superheat (thermo.fluid.check_operating_point); and a table
of the discharge temperature T(p_d, h).

Discharge temperature (docs/model.md §6.4): cubic Hermite interpolation in h between nodes (h_i, T_i) on the isobar
p_d with the exact slopes dT/dh|_p = 1/c_p,

    T(h) = H0(t) T_i + H1(t) T_i+1 + (h_i+1 - h_i) (G0(t)/c_p,i + G1(t)/c_p,i+1),   t = (h - h_i)/(h_i+1 - h_i),

with H, G the cubic Hermite basis of thermo.property_table. The nodes span T from max(envelope T_min, T_dome(p_d) +
margin) to the envelope's T_max (T_dome: the dew temperature, T_crit above p_crit); they start uniform in T
(DISCHARGE_INITIAL_NODES), and an interval is halved until the interpolant at the h of its T-midpoint is within
DISCHARGE_TEMPERATURE_TOLERANCE = 1e-8 K of that midpoint's T. A node's density is CoolProp's PT flash polished by a
Newton step on p(T, rho) = p_d (the flash alone leaves p off by up to 1e-8 relative, 2e-7 K in T(h)), then h and
c_p at (T, rho). Measured for the six fluids of benchmarks/bench_properties.py at their typical operating points
(tests/thermo/test_operating_point.py): 104-359 nodes, 10-150 ms to build; within 1e-8 K of exact (h, T) pairs of the
isobar, and within 4.2e-7 K of CoolProp's HmassP flash, whose own convergence error reaches that. Outside the
tabulated enthalpies the temperature is NaN. The run's discharge enthalpy itself comes from the property table
(h within 4e-10 relative for R134a, some 2e-7 K): the interpolation is not what limits the figure. (A Newton solve
of p(T, rho) = p_d, h(T, rho) = h on the property table itself was measured at 2e-7 K for R134a and 4e-7 K for
CO2, and it fails in the table's refused near-critical cells, 11 % of the isobar's temperatures for CO2 at 10 MPa:
not used.)

Cache (thermo.disk_cache): one JSON file per point next to the property tables, `<fluid>-operating-point-<hash>.json`,
holding {"key": <key>, "point": {field: value, ...}}; floats are written by repr and read back exactly, nothing is
unpickled. The key lists the fluid name as given, p_s, T_s, p_d and the margin (repr), the installed CoolProp version
(from its distribution's metadata, without importing it), FORMAT_VERSION and the constants of the computation. Only
a point that passed the checks is cached, so a cache hit is a valid point without asking CoolProp; a file that does
not parse, misses or mistypes a field, or carries another key is rebuilt with a warning.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .disk_cache import cache_path, load_or_build
from .fluid import (SUPERHEAT_MARGIN, UNIVERSAL_GAS_CONSTANT, Fluid, check_operating_numbers, check_operating_point,
                    coolprop, coolprop_version)
from .property_table import (ENVELOPE_COLD_MARGIN, ENVELOPE_DENSE_PRESSURE_FACTOR, ENVELOPE_HIGH_PRESSURE_FACTOR,
                             ENVELOPE_HOT_MARGIN, ENVELOPE_LOW_PRESSURE_FACTOR, Envelope, envelope_for)

FORMAT_VERSION = 3                           # 2: points below the triple-point pressure are refused; 3: c_1
DISCHARGE_INITIAL_NODES = 17                 # uniform in T before refinement
DISCHARGE_TEMPERATURE_TOLERANCE = 1e-8       # K, interpolant against the exact T at every interval's T-midpoint

TEXT_FIELDS = ("fluid", "coolprop_name")
TABLE_FIELDS = ("discharge_enthalpies", "discharge_temperatures", "discharge_temperature_slopes")


class OperatingPoint(NamedTuple):
    """What a real-gas run needs from CoolProp for one operating point (module docstring), SI units."""
    fluid: str                               # the name as given, e.g. "CO2"
    coolprop_name: str                       # CoolProp's canonical name, e.g. "CarbonDioxide"
    suction_pressure: float                  # p_s [Pa]
    suction_temperature: float               # T_s [K]
    discharge_pressure: float                # p_d [Pa]
    superheat_margin: float                  # K, smallest accepted distance from the dome (docs/model.md §7.3)
    superheat: float                         # T_s - T_dew(p_s), or T_s - T_crit above p_crit [K]
    critical_temperature: float              # K
    gas_constant: float                      # R = 8314.462/M [J/(kg K)]
    ideal_gas_exponent: float                # k = c_p0/(c_p0 - R) at T_s
    suction_density: float                   # rho(T_s, p_s) [kg/m^3]
    suction_enthalpy: float                  # h_1 [J/kg]
    suction_entropy: float                   # s_1 [J/(kg K)]
    isentropic_discharge_enthalpy: float     # h_2s = h(p_d, s_1) [J/kg]
    suction_sound_speed: float               # c_1 = sqrt((dp/drho)_s) at (T_s, rho_1) [m/s]
    envelope: Envelope                       # of the property table (thermo.property_table.envelope_for)
    discharge_enthalpies: np.ndarray         # h_i on the isobar p_d, increasing [J/kg]
    discharge_temperatures: np.ndarray       # T_i [K]
    discharge_temperature_slopes: np.ndarray  # dT/dh|_p = 1/c_p at the nodes [K kg/J]

    def discharge_temperature(self, enthalpy: float) -> float:
        """T(p_d, h) [K] by cubic Hermite interpolation (module docstring); NaN outside the tabulated enthalpies
        (gas at p_d within the superheat margin of the dome, or hotter than the envelope)."""
        nodes = self.discharge_enthalpies
        if not nodes[0] <= enthalpy <= nodes[-1]:
            return math.nan
        i = min(int(np.searchsorted(nodes, enthalpy, side="right")) - 1, nodes.size - 2)
        table = (nodes, self.discharge_temperatures, self.discharge_temperature_slopes)
        return _hermite([column[i] for column in table], [column[i + 1] for column in table], enthalpy)


def _hermite(left, right, enthalpy) -> float:
    """T at `enthalpy` between the nodes left = (h_i, T_i, 1/c_p,i) and right = (h_i+1, ...)."""
    (h0, t0, m0), (h1, t1, m1) = left, right
    step = h1 - h0
    t = (enthalpy - h0) / step
    return float((1.0 + 2.0 * t) * (1.0 - t) ** 2 * t0 + t * t * (3.0 - 2.0 * t) * t1
                 + step * (t * (1.0 - t) ** 2 * m0 + t * t * (t - 1.0) * m1))


# ----------------------------------------------------------------------------------------------------------
# computing a point (CoolProp)

def _isobar_node(fluid: Fluid, pressure, temperature) -> tuple[float, float, float]:
    """(h, T, 1/c_p) at (p, T) from HEOS: rho from the PT flash, which leaves p(T, rho) off by up to 1e-8 relative
    (2e-7 K in T(h)), polished by one Newton step rho -= (p(T, rho) - p)/(dp/drho)_T; then h and c_p at (T, rho)."""
    CP = coolprop()
    density = fluid.density(temperature, pressure)
    state = fluid.gas_branch_state(temperature, density)       # the gas itself: T >= T_dome(p) + margin
    density -= (state.p() - pressure) / state.first_partial_deriv(CP.iP, CP.iDmass, CP.iT)
    properties = fluid.properties(temperature, density)
    return properties.enthalpy, float(temperature), 1.0 / properties.isobaric_heat_capacity


def _discharge_nodes(fluid: Fluid, pressure, envelope: Envelope) -> list[tuple[float, float, float]]:
    """The refined (h, T, 1/c_p) nodes of T(p_d, h) over the envelope (module docstring)."""
    low = max(envelope.temperature_min, fluid.dome_temperature(pressure) + envelope.superheat_margin)
    nodes = [_isobar_node(fluid, pressure, t)
             for t in np.linspace(low, envelope.temperature_max, DISCHARGE_INITIAL_NODES)]
    while True:
        refined = [nodes[0]]
        for left, right in zip(nodes, nodes[1:]):
            middle = _isobar_node(fluid, pressure, 0.5 * (left[1] + right[1]))
            if abs(_hermite(left, right, middle[0]) - middle[1]) > DISCHARGE_TEMPERATURE_TOLERANCE:
                refined.append(middle)
            refined.append(right)
        if len(refined) == len(nodes):
            return nodes
        nodes = refined


def _frozen(values) -> np.ndarray:
    array = np.array(values, dtype=np.float64)
    array.flags.writeable = False
    return array


def _sound_speed(state, temperature, density) -> float:
    """c = sqrt((dp/drho)_s) from HEOS's c_p, c_v and (dp/dT)_rho: (dp/drho)_T = T (dp/dT)_rho^2/(rho^2 (c_p - c_v))
    and c^2 = (c_p/c_v) (dp/drho)_T."""
    isothermal = (temperature * state.pressure_temperature_derivative ** 2
                  / (density ** 2 * (state.isobaric_heat_capacity - state.isochoric_heat_capacity)))
    return math.sqrt(state.isobaric_heat_capacity / state.isochoric_heat_capacity * isothermal)


def _compute(fluid_name, suction_pressure, suction_temperature, discharge_pressure, superheat_margin):
    """The OperatingPoint from CoolProp HEOS, after Fluid's name check and check_operating_point."""
    fluid = Fluid(fluid_name)
    superheat = check_operating_point(fluid, suction_pressure, suction_temperature, discharge_pressure,
                                      superheat_margin)
    envelope = envelope_for(fluid, suction_pressure, suction_temperature, discharge_pressure, superheat_margin)
    density = fluid.density(suction_temperature, suction_pressure)
    suction = fluid.properties(suction_temperature, density)
    table = zip(*_discharge_nodes(fluid, discharge_pressure, envelope))
    return OperatingPoint(
        fluid_name, fluid.coolprop_name, suction_pressure, suction_temperature, discharge_pressure, superheat_margin,
        superheat=superheat, critical_temperature=fluid.critical_temperature, gas_constant=fluid.gas_constant,
        ideal_gas_exponent=fluid.ideal_gas_exponent(suction_temperature), suction_density=density,
        suction_enthalpy=suction.enthalpy, suction_entropy=suction.entropy,
        isentropic_discharge_enthalpy=fluid.isentropic_enthalpy(discharge_pressure, suction.entropy),
        suction_sound_speed=_sound_speed(suction, suction_temperature, density),
        envelope=envelope, **{name: _frozen(column) for name, column in zip(TABLE_FIELDS, table)})


# ----------------------------------------------------------------------------------------------------------
# disk cache

def _cache_key(fluid_name, suction_pressure, suction_temperature, discharge_pressure, superheat_margin) -> str:
    """Everything a point depends on, as text (floats by repr: exact); no CoolProp import."""
    return "|".join([
        f"format {FORMAT_VERSION}", f"fluid {fluid_name}",
        "operating point " + " ".join(repr(v) for v in (suction_pressure, suction_temperature, discharge_pressure,
                                                          superheat_margin)),
        f"coolprop {coolprop_version()}", f"gas constant {UNIVERSAL_GAS_CONSTANT!r}",
        "envelope rule " + " ".join(repr(v) for v in (ENVELOPE_LOW_PRESSURE_FACTOR, ENVELOPE_HIGH_PRESSURE_FACTOR,
                                                        ENVELOPE_DENSE_PRESSURE_FACTOR, ENVELOPE_COLD_MARGIN,
                                                        ENVELOPE_HOT_MARGIN)),
        f"discharge table {DISCHARGE_INITIAL_NODES} {DISCHARGE_TEMPERATURE_TOLERANCE!r}"])


def _as_json(key: str, point: OperatingPoint) -> bytes:
    fields = point._asdict()
    fields["envelope"] = point.envelope._asdict()
    fields.update({name: fields[name].tolist() for name in TABLE_FIELDS})
    return json.dumps({"key": key, "point": fields}).encode()


def _number(name, value) -> float:
    if type(value) is not float or not math.isfinite(value):
        raise ValueError(f"{name} is not a finite float")
    return value


def _exact_keys(name, mapping, keys) -> dict:
    if not isinstance(mapping, dict) or set(mapping) != set(keys):
        raise ValueError(f"{name} does not hold exactly the fields {', '.join(keys)}")
    return mapping


def _load(path: Path, key: str) -> OperatingPoint:
    """Read a cached point; ValueError unless it carries `key` and every field has its type (module docstring)."""
    stored = _exact_keys("the file", json.loads(path.read_bytes()), ("key", "point"))
    if stored["key"] != key:
        raise ValueError("the file belongs to another key")
    fields = _exact_keys("point", stored["point"], OperatingPoint._fields)
    values = {}
    for name, value in fields.items():
        if name in TEXT_FIELDS:
            if not isinstance(value, str):
                raise ValueError(f"{name} is not a string")
            values[name] = value
        elif name == "envelope":
            value = _exact_keys(name, value, Envelope._fields)
            values[name] = Envelope(**{field: _number(f"envelope.{field}", value[field]) for field in Envelope._fields})
        elif name in TABLE_FIELDS:
            if not isinstance(value, list) or len(value) < 2:
                raise ValueError(f"{name} is not a list of at least two numbers")
            values[name] = _frozen([_number(name, v) for v in value])
        else:
            values[name] = _number(name, value)
    point = OperatingPoint(**values)
    enthalpies, temperatures, slopes = (getattr(point, name) for name in TABLE_FIELDS)
    if not (enthalpies.size == temperatures.size == slopes.size and np.all(np.diff(enthalpies) > 0.0)
            and np.all(np.diff(temperatures) > 0.0) and np.all(slopes > 0.0)):
        raise ValueError("the discharge-temperature table is not increasing with positive slopes")
    return point


def operating_point_for(fluid_name, suction_pressure, suction_temperature, discharge_pressure,
                        superheat_margin=SUPERHEAT_MARGIN, cache_dir=None) -> OperatingPoint:
    """The OperatingPoint of `fluid_name` (a CoolProp fluid name) between p_s [Pa], T_s [K] and p_d [Pa], loaded
    from the disk cache or computed from CoolProp HEOS and cached (docs/model.md §7.1).

    Validation, with the messages of thermo.fluid: the checks that need no fluid first (`check_operating_numbers`:
    finite numbers > 0, p_d > p_s); then, unless the point is cached, Fluid's name check (UnknownFluidError) and
    `check_operating_point`. A bad input raises ValueError naming the variable, its value and the allowed range.
    Cache folder: `cache_dir`, else thermo.disk_cache.property_cache_dir().
    """
    numbers = check_operating_numbers(suction_pressure, suction_temperature, discharge_pressure, superheat_margin)
    key = _cache_key(fluid_name, *numbers)
    return load_or_build(cache_path(f"{fluid_name}-operating-point", key, ".json", cache_dir),
                         lambda path: _load(path, key), lambda: _compute(fluid_name, *numbers),
                         lambda stream, point: stream.write(_as_json(key, point)), "operating point")
