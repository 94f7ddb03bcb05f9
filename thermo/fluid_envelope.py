"""One (T, rho) envelope per fluid that holds every state of every operating point in its declared input range, so
that one property table and one nozzle table serve a whole sweep or a run whose boundary conditions move
(docs/model.md §7.3.2).

Declared input range of a condensable working fluid (T_crit above 20 °C), from its saturation line:

    suction pressure     p_s in [p_sat(-40 °C), p_sat(+20 °C)]        (evaporating at -40 ... +20 °C)
    discharge pressure   p_d up to p_sat(70 °C); 1.5 p_crit if T_crit < 80 °C (a transcritical cycle, e.g. CO2)
    suction state        wet down to vapour quality 0.5, or superheated up to T_s = T_sat(p_s,max) + 30 K

(-40 °C is replaced by the triple point if that is warmer.) The envelope extends the range as
`property_table.envelope_for` extends one operating point, taking the extreme of each rule over the range:

    p_min = 0.25 p_s,min (at least the triple-point pressure),   p_max = 3 p_d,max (at most the EOS p_max)
    T_min = T_sat(p_min): no vapour nor equilibrium mixture at p >= p_min is colder (the dome is the coldest
            place an adiabatic machine with a wet suction reaches; superheated gas expanded to p_min stays warmer)
    T_max = T(p_max, s_max) + 150 K with s_max = s(p_s,min, T_s,max), the largest suction entropy: the hottest
            isentropic compression plus the per-point hot margin (clipped to the EOS T_max)
    rho_min = rho(T_max, p_min)
    rho_max = the larger of the densest superheated gas of the per-point rule at p_max (coldest compression of
              the lowest-entropy dry suction, s(p_s,max, T_sat(p_s,max) + margin), minus 20 K, not below the dome
              margin) and the equilibrium mixture of quality 0.5 at T_sat(p_d,max) (the densest wet suction state
              compressed to the discharge pressure; at 20 °C for a transcritical p_d,max)

R134a: p_s 51-572 kPa, p_d up to 2.12 MPa; envelope 210-455 K, 0.345-660 kg/m^3 (the default operating point's:
240-455 K, 1.98-314 kg/m^3); 183 x 238 property nodes (5.7 MB), 74 x 96 nozzle nodes (2.4 MB). The dense end is
the supercritical gas at p_max = 6.35 MPa > p_crit; there the cell check refuses the near-critical cells as it does
for CO2 per operating point. Build times, accuracy and the sweep over operating points:
benchmarks/bench_fluid_tables.py.
"""
from __future__ import annotations

import json
import math
from typing import NamedTuple

from .disk_cache import cache_path, load_or_build
from .fluid import SUPERHEAT_MARGIN, Fluid, coolprop_version
from .property_table import (DEFAULT_LOG_DENSITY_NODES, DEFAULT_TEMPERATURE_NODES, ENVELOPE_COLD_MARGIN,
                             ENVELOPE_HIGH_PRESSURE_FACTOR, ENVELOPE_HOT_MARGIN, ENVELOPE_LOW_PRESSURE_FACTOR, Envelope,
                             property_table_for)
from .real_gas_nozzle import (DEFAULT_LOG_DENSITY_NODES as NOZZLE_LOG_DENSITY_NODES,
                              DEFAULT_TEMPERATURE_NODES as NOZZLE_TEMPERATURE_NODES, nozzle_table_for)

CELSIUS = 273.15
EVAPORATING_TEMPERATURE_RANGE = (-40.0 + CELSIUS, 20.0 + CELSIUS)   # K: p_s range on the saturation line
CONDENSING_TEMPERATURE_MAX = 70.0 + CELSIUS                         # K: p_d,max on the saturation line
TRANSCRITICAL_MARGIN = 10.0              # K: T_crit below 70 °C + this -> p_d,max = 1.5 p_crit
TRANSCRITICAL_DISCHARGE_FACTOR = 1.5
SUCTION_SUPERHEAT_MAX = 30.0             # K above T_sat(p_s,max)
SUCTION_QUALITY_MIN = 0.5
GRID_STEPS = (1.35, 0.032)    # K and ln(kg/m^3) between nodes: those of the default R134a operating point's
                              # 160 x 160 table (215 K and 5.06 over 159 steps), so the accuracy stays as per point
NOZZLE_GRID_STEPS = (3.4, 0.08)   # the same for the nozzle table's 64 x 64 (215 K and 5.06 over 63 steps)


class InputRange(NamedTuple):
    """The boundary conditions one fluid's tables accept (module docstring), SI units."""
    suction_pressure_min: float        # Pa
    suction_pressure_max: float        # Pa
    discharge_pressure_max: float      # Pa
    suction_temperature_max: float     # K
    suction_quality_min: float         # vapour mass fraction of the wettest suction state


def input_range(fluid: Fluid) -> InputRange:
    """The declared input range of `fluid` (module docstring); ValueError for a fluid without a dome above 20 °C."""
    low, high = EVAPORATING_TEMPERATURE_RANGE
    if not fluid.critical_temperature > high:
        raise ValueError(f"fluid={fluid.name!r} is out of range; allowed: a condensable working fluid with a critical "
                         f"temperature above {high:g} K (its is {fluid.critical_temperature:.6g} K); build per "
                         "operating point with thermo.property_table.envelope_for instead")
    suction_max = fluid.dew_pressure(high)
    if fluid.critical_temperature > CONDENSING_TEMPERATURE_MAX + TRANSCRITICAL_MARGIN:
        discharge_max = fluid.dew_pressure(CONDENSING_TEMPERATURE_MAX)
    else:
        discharge_max = TRANSCRITICAL_DISCHARGE_FACTOR * fluid.critical_pressure
    return InputRange(fluid.dew_pressure(max(low, fluid.triple_temperature)), suction_max, discharge_max,
                      fluid.saturation_temperature(suction_max) + SUCTION_SUPERHEAT_MAX, SUCTION_QUALITY_MIN)


def _mixture_density(fluid: Fluid, temperature, quality):
    liquid = fluid.saturated_state(temperature, 0.0).rhomass()
    vapour = fluid.saturated_state(temperature, 1.0).rhomass()
    return 1.0 / (1.0 / liquid + quality * (1.0 / vapour - 1.0 / liquid))


def fluid_envelope(fluid: Fluid, superheat_margin=SUPERHEAT_MARGIN) -> Envelope:
    """The (T, rho) envelope of every operating point in `input_range(fluid)` (module docstring)."""
    inputs = input_range(fluid)
    low_pressure = max(ENVELOPE_LOW_PRESSURE_FACTOR * inputs.suction_pressure_min,
                       fluid.dew_pressure(fluid.triple_temperature))
    high_pressure = min(ENVELOPE_HIGH_PRESSURE_FACTOR * inputs.discharge_pressure_max, fluid.maximum_pressure)
    temperature_min = max(fluid.minimum_temperature, fluid.saturation_temperature(low_pressure))
    largest_entropy = fluid.properties(inputs.suction_temperature_max,
                                       fluid.density(inputs.suction_temperature_max,
                                                     inputs.suction_pressure_min)).entropy
    hottest = fluid.state_at_pressure_entropy(high_pressure, largest_entropy).temperature
    temperature_max = min(fluid.maximum_temperature, hottest + ENVELOPE_HOT_MARGIN)
    driest_cold_suction = fluid.saturation_temperature(inputs.suction_pressure_max) + superheat_margin
    smallest_dry_entropy = fluid.properties(driest_cold_suction,
                                            fluid.density(driest_cold_suction, inputs.suction_pressure_max)).entropy
    coldest_compression = fluid.state_at_pressure_entropy(high_pressure, smallest_dry_entropy).temperature
    coldest_at_high_pressure = max(temperature_min, coldest_compression - ENVELOPE_COLD_MARGIN,
                                   fluid.dome_temperature(high_pressure) + superheat_margin)
    dense_gas = fluid.density(coldest_at_high_pressure, high_pressure)
    wet_temperature = fluid.saturation_temperature(inputs.discharge_pressure_max)   # None if transcritical
    if wet_temperature is None:
        wet_temperature = EVAPORATING_TEMPERATURE_RANGE[1]
    wet = _mixture_density(fluid, wet_temperature, inputs.suction_quality_min)
    return Envelope(temperature_min, temperature_max, fluid.density(temperature_max, low_pressure),
                    max(dense_gas, wet), float(superheat_margin))


def _grid(envelope: Envelope, steps, minimum) -> tuple[int, int]:
    temperature_step, log_density_step = steps
    temperature_nodes = math.ceil((envelope.temperature_max - envelope.temperature_min) / temperature_step) + 1
    log_density_nodes = math.ceil(math.log(envelope.density_max / envelope.density_min) / log_density_step) + 1
    return max(temperature_nodes, minimum[0]), max(log_density_nodes, minimum[1])


def fluid_grid(envelope: Envelope) -> tuple[int, int]:
    """(T nodes, ln rho nodes) of a property table over `envelope` with steps no larger than those of the default
    R134a operating point's table (GRID_STEPS), and no fewer nodes than the default grid."""
    return _grid(envelope, GRID_STEPS, (DEFAULT_TEMPERATURE_NODES, DEFAULT_LOG_DENSITY_NODES))


def fluid_nozzle_grid(envelope: Envelope) -> tuple[int, int]:
    """(T nodes, ln rho nodes) of a nozzle table over `envelope` (NOZZLE_GRID_STEPS, as `fluid_grid`)."""
    return _grid(envelope, NOZZLE_GRID_STEPS, (NOZZLE_TEMPERATURE_NODES, NOZZLE_LOG_DENSITY_NODES))


class FluidRange(NamedTuple):
    """What a run needs to find a fluid's fluid-wide tables without CoolProp: its canonical name, its declared input
    range and the tables' envelope (both None for a fluid without one, e.g. air)."""
    coolprop_name: str
    inputs: InputRange | None
    envelope: Envelope | None


RANGE_FORMAT_VERSION = 1


def _range_key(name: str) -> str:
    """Everything a FluidRange depends on, as text (floats by repr); no CoolProp import."""
    return "|".join([f"format {RANGE_FORMAT_VERSION}", f"fluid {name}", f"coolprop {coolprop_version()}",
                     "rules " + " ".join(repr(v) for v in (*EVAPORATING_TEMPERATURE_RANGE, CONDENSING_TEMPERATURE_MAX,
                                                           TRANSCRITICAL_MARGIN, TRANSCRITICAL_DISCHARGE_FACTOR,
                                                           SUCTION_SUPERHEAT_MAX, SUCTION_QUALITY_MIN,
                                                           SUPERHEAT_MARGIN, ENVELOPE_LOW_PRESSURE_FACTOR,
                                                           ENVELOPE_HIGH_PRESSURE_FACTOR, ENVELOPE_HOT_MARGIN,
                                                           ENVELOPE_COLD_MARGIN))])


def _build_range(name: str) -> FluidRange:
    fluid = Fluid(name)
    try:
        return FluidRange(fluid.coolprop_name, input_range(fluid), fluid_envelope(fluid))
    except ValueError:                                   # no dome above 20 °C
        return FluidRange(fluid.coolprop_name, None, None)


def _floats(values, size) -> list[float]:
    if not (isinstance(values, list) and len(values) == size and all(type(v) is float and math.isfinite(v)
                                                                      for v in values)):
        raise ValueError(f"{values!r:.80} is not {size} finite floats")
    return values


def _load_range(path, key: str) -> FluidRange:
    """A cached FluidRange (JSON, floats by repr); ValueError unless complete and carrying `key`."""
    stored = json.loads(path.read_bytes())
    if not isinstance(stored, dict) or stored.get("key") != key or not isinstance(stored.get("coolprop_name"), str):
        raise ValueError("the file belongs to another key")
    inputs, envelope = stored.get("inputs"), stored.get("envelope")
    if (inputs is None) != (envelope is None):
        raise ValueError("the input range and the envelope must both be given or both be null")
    if inputs is None:
        return FluidRange(stored["coolprop_name"], None, None)
    return FluidRange(stored["coolprop_name"], InputRange(*_floats(inputs, len(InputRange._fields))),
                      Envelope(*_floats(envelope, len(Envelope._fields))))


def fluid_range_for(name: str, cache_dir=None) -> FluidRange:
    """The FluidRange of the fluid `name` (as a user gives it), from the disk cache (thermo.disk_cache, shipped in
    an FMU for its default fluid) or computed with CoolProp and cached."""
    key = _range_key(name)
    return load_or_build(
        cache_path(name, key, ".range.json", cache_dir), lambda stored: _load_range(stored, key),
        lambda: _build_range(name),
        lambda stream, found: stream.write(json.dumps({"key": key, "coolprop_name": found.coolprop_name,
                                                       "inputs": found.inputs and list(found.inputs),
                                                       "envelope": found.envelope and list(found.envelope)}).encode()),
        "fluid range")


class _Named(NamedTuple):
    coolprop_name: str              # what property_table_for and nozzle_table_for need to find a cached table


def _named_envelope(fluid, cache_dir):
    """(envelope, what the table builders need to find a cached table) of `fluid` (a Fluid or a name)."""
    if isinstance(fluid, Fluid):
        return fluid_envelope(fluid), fluid
    found = fluid_range_for(fluid, cache_dir)
    if found.envelope is None:
        input_range(Fluid(fluid))                    # raises the ValueError that says why
    return found.envelope, _Named(found.coolprop_name)


def fluid_property_table_for(fluid, cache_dir=None):
    """The property table of `fluid` (a Fluid or a name) over its fluid-wide envelope with the dome on, as
    `fluid_tables_for` gives it, without the nozzle table (the refrigeration loop needs no nozzle)."""
    envelope, named = _named_envelope(fluid, cache_dir)
    return property_table_for(named, envelope, *fluid_grid(envelope), cache_dir=cache_dir, two_phase=True)


def fluid_tables_for(fluid, cache_dir=None):
    """(property table, nozzle table) of `fluid` (a Fluid or a name) over its fluid-wide envelope, with the dome
    on (two_phase), from the disk cache or built and cached (thermo.disk_cache); with every file cached, CoolProp
    is not imported. ValueError for a fluid without a declared input range."""
    envelope, named = _named_envelope(fluid, cache_dir)
    return (fluid_property_table_for(fluid, cache_dir),
            nozzle_table_for(named, envelope, *fluid_nozzle_grid(envelope), cache_dir=cache_dir, two_phase=True))
