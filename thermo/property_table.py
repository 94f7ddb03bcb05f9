"""Real-gas property table in (T, ln rho) for the chamber equations of docs/model.md §7.3, evaluated inside numba.

The chamber equations need p, h, c_v and (dp/dT)_rho at the chamber state (T, rho) several times per step; CoolProp
costs about 1.5 us per state from Python and cannot be called from nopython code (benchmarks/bench_properties.py). This module
tabulates the four properties once per fluid and operating envelope (`envelope_for`) and interpolates them in numba
(`table_properties`, `table_status`, `table_ideal_gas_exponent`).

Interpolation: bicubic Hermite on a uniform grid in T and x = ln rho. Each node stores, for each property f, the
value f, T_step * df/dT|_rho and x_step * df/dx|_T = x_step * rho * df/drho|_T (exact: CoolProp's analytic partial
derivatives of the Helmholtz equation of state), and T_step * x_step * d2f/(dT dx) (for c_v and (dp/dT)_rho a third
derivative of the Helmholtz energy, which CoolProp does not give: for all four a central difference of the exact
df/dT over x +- 1e-4, truncation error ~1e-9 relative). Inside a cell with local coordinates (t, s) in [0, 1]^2:

    f(t, s) = sum_{a,b in {0,1}} [ H_a(t) H_b(s) f + G_a(t) H_b(s) (dT f_T) + H_a(t) G_b(s) (dx f_x)
                                   + G_a(t) G_b(s) (dT dx f_Tx) ]_{node (i+a, j+b)}
    H_0 = (1 + 2t)(1 - t)^2,  H_1 = t^2 (3 - 2t),  G_0 = t (1 - t)^2,  G_1 = t^2 (t - 1).

The interpolant is C^1 with an O(step^4) error and needs only the four corner nodes (16 numbers per property), so an
evaluation is one logarithm and about 100 multiply-adds. ln rho: the gas pressure is nearly proportional to rho, so
a uniform grid in ln rho has the same relative resolution in the re-expanded and in the over-compressed chamber.
Grid: 160 x 160 by default (3.4 MB with the saturation line, under 1 s to build). Measured against HEOS beyond the 1 K margin
(benchmarks/bench_properties.py): R134a, Air, R410A, R1234yf, R290 p and h within 1e-8, c_v and (dp/dT)_rho
within 2e-7; CO2 (3.5 -> 10 MPa) p and h within 1e-7, c_v about 1e-5 and (dp/dT)_rho 4e-6 next to the critical
point. At 96 x 96 R134a is still at 3e-8; the finer default is for the near-critical cells of fluids such as CO2
(the error falls as step^4).

Check at build: every cell's centre, where the Hermite error peaks, is compared with HEOS; a cell whose relative
error exceeds CELL_TOLERANCE (p, h 2e-6; c_v, (dp/dT)_rho 1e-5) is refused (STATUS_INACCURATE_CELL). Elsewhere in
a cell the p and h errors were measured at most 1.4 times the centre's, so accepted states are within 1e-5.

Saturation: the nodes come from the gas branch of the equation of state with the phase imposed (no phase test,
`Fluid.gas_branch_state`), a smooth function across the dew line, so cells next to the dome are as accurate as any
other. A state is accepted only if its superheat T - T_dew(p) is at least the envelope's margin (1 K by default,
docs/model.md §7.3); for p >= p_crit, T >= T_crit + margin. At fixed T this is ln rho <= x_lim(T) with
x_lim(T) = ln rho_gas(T, p_dew(T - margin)) (p rises with rho on the gas branch, T_dew rises with p);
x_lim is tabulated on a T grid 8 times finer than the table's, each cell holding the smaller of its two end
values (x_lim increases with T), so an accepted state is never closer to the dome than the margin; the price is
that states up to about one dome cell (the T range / 1272, 0.17 K for R134a) beyond the margin may be refused too.

Two-phase dome (docs/model.md §7.3.1; off by default, on in the fluid-wide tables a real-gas run uses): a table with
`two_phase` set (`with_two_phase`, `property_table_for(..., two_phase=True)`) takes a state beyond the dew line, rho
> rho_v(T) with T on the accepted part of its saturation line (thermo.saturation, built with every table), as a
homogeneous equilibrium mixture: p = p_sat(T), h = h_l + x (h_v - h_l), the mixture's c_v at constant volume,
(dp/dT)_rho = dp_sat/dT and (dp/drho)_T = 0, with p_sat and h_v taken from the gas branch at the dew point (T,
rho_v(T)) so that p and h are continuous across the dew line while their derivatives jump (the kink is not
interpolated over: the gas table serves rho <= rho_v(T), the 1-D saturation table the rest). The superheat margin
does not apply there; above the saturation line's end (a few kelvin below T_crit) the margin rule does.
`table_quality` gives the vapour quality.

Status codes (the four values are NaN whenever status != 0; `describe_status` turns a code into a sentence):
    STATUS_OK = 0                       a gas state, or an equilibrium mixture of a two-phase table (quality < 1)
    STATUS_INVALID_STATE = 1            T or rho is not a positive number (NaN, 0, negative)
    STATUS_TEMPERATURE_BELOW_TABLE = 2, STATUS_TEMPERATURE_ABOVE_TABLE = 3
    STATUS_DENSITY_BELOW_TABLE = 4, STATUS_DENSITY_ABOVE_TABLE = 5   (also: a mixture whose dew point is below the
                                        table's density range)
    STATUS_NEAR_SATURATION = 6          inside the two-phase dome or within the superheat margin of it (without
                                        two_phase, or above the end of the saturation line)
    STATUS_INACCURATE_CELL = 7          in a cell that failed the build check (near the critical point); for a
                                        mixture, the cell of its dew point
    STATUS_LIQUID = 9                   two_phase: denser than the saturated liquid (8 is the nozzle table's)
The checks run in this order; the first failing one is reported.

Tables are cached on disk per fluid, envelope, grid and CoolProp version (`property_table_for`, thermo.disk_cache);
the two-phase flag is not part of the file. One table per fluid over its whole input range: thermo.fluid_envelope.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .disk_cache import cache_path, load_or_build
from .fluid import SUPERHEAT_MARGIN, Fluid, check_operating_point, coolprop, coolprop_version
from ..kernels.kernel import kernel
from .saturation import (DEFAULT_SATURATION_STEP, SATURATION_QUANTITIES, SATURATION_TOLERANCE, VAPOUR_VOLUME,
                         build_saturation_line, mixture_state, saturation_quantity)

FORMAT_VERSION = 3                 # 3: the saturation line and the two-phase flag
DEFAULT_TEMPERATURE_NODES = 160
DEFAULT_LOG_DENSITY_NODES = 160
DOME_REFINEMENT = 8                # dome-limit cells per table cell in T
CROSS_DERIVATIVE_STEP = 1e-4       # in x = ln rho, for the central difference of df/dT
CELL_TOLERANCE = (2e-6, 2e-6, 1e-5, 1e-5)   # relative, p, h, c_v, (dp/dT)_rho at each cell centre (build check)

# operating envelope around a compressor between p_s and p_d (see `envelope_for`)
ENVELOPE_LOW_PRESSURE_FACTOR = 0.25      # p_min = 0.25 p_s   (suction throttling, re-expansion)
ENVELOPE_HIGH_PRESSURE_FACTOR = 3.0      # p_max = 3 p_d      (over-compression behind the discharge port)
ENVELOPE_DENSE_PRESSURE_FACTOR = 4.0     # per point: rho_max >= rho(4 p_d, s_s), an over-compressed chamber
ENVELOPE_COLD_MARGIN = 20.0              # K below the isentropic expansion of the suction gas to p_min
ENVELOPE_HOT_MARGIN = 150.0              # K above the isentropic compression of the suction gas to p_max

PROPERTY_NAMES = ("pressure", "enthalpy", "isochoric_heat_capacity", "pressure_temperature_derivative")

STATUS_OK = 0
STATUS_INVALID_STATE = 1
STATUS_TEMPERATURE_BELOW_TABLE = 2
STATUS_TEMPERATURE_ABOVE_TABLE = 3
STATUS_DENSITY_BELOW_TABLE = 4
STATUS_DENSITY_ABOVE_TABLE = 5
STATUS_NEAR_SATURATION = 6
STATUS_INACCURATE_CELL = 7
STATUS_LIQUID = 9                  # 8 is the nozzle table's STATUS_THROAT_NEAR_SATURATION


class Envelope(NamedTuple):
    """The (T, rho) rectangle a table covers and the accepted distance from the dome."""
    temperature_min: float        # K
    temperature_max: float        # K
    density_min: float            # kg/m^3
    density_max: float            # kg/m^3
    superheat_margin: float       # K


class PropertyTable(NamedTuple):
    """The numeric content of a table, as numba takes it (see the module docstring for the node layout)."""
    temperature_min: float                 # K, first node
    temperature_max: float                 # K, last node
    inverse_temperature_step: float        # 1/K, nodes are uniform in T
    log_density_min: float                 # ln(kg/m^3), first node
    log_density_max: float                 # ln(kg/m^3), last node
    inverse_log_density_step: float        # nodes are uniform in ln rho
    nodes: np.ndarray                      # (n_T, n_x, 4 properties, 4 node data), float64
    inverse_dome_step: float               # 1/K, dome-limit cells start at temperature_min
    dome_log_density_limit: np.ndarray     # (n_dome,): largest accepted ln rho in each dome cell
    accurate_cell: np.ndarray              # (n_T - 1, n_x - 1) bool: the cell passed its check against HEOS
    ideal_gas_exponent: np.ndarray         # (n_T,): k = c_p0/(c_p0 - R) at the T nodes (docs/model.md §7.4)
    superheat_margin: float                # K
    critical_temperature: float            # K
    # the dome (docs/model.md §7.3.1, thermo.saturation); defaults: a table without a saturation line
    two_phase: float = 0.0                 # 1.0: states inside the dome are equilibrium mixtures (module docstring)
    saturation_temperature_min: float = 0.0      # K, first saturation node
    saturation_temperature_max: float = 0.0      # K, end of the accepted saturation line
    inverse_saturation_step: float = 1.0   # 1/K
    saturation_nodes: np.ndarray = np.zeros((2, len(SATURATION_QUANTITIES), 2))   # thermo.saturation.SaturationLine


# ----------------------------------------------------------------------------------------------------------
# numba kernels
#
# table_state and what locates its cell are compiled into their callers (`@kernel(inline=True)`): a call passes the
# table by value, field by field, and with the saturation line added it no longer fits LLVM's own inlining, so each
# call copied the table (thermo.real_gas_nozzle's kernel notes; one state 60 -> 49 ns per call, 50 before the dome).

TABLE_SCALARS = ("temperature_min", "temperature_max", "inverse_temperature_step", "log_density_min",
                 "log_density_max", "inverse_log_density_step", "inverse_dome_step", "superheat_margin",
                 "critical_temperature", "two_phase", "saturation_temperature_min", "saturation_temperature_max",
                 "inverse_saturation_step")


def table_arrays(table: PropertyTable) -> tuple:
    """The table as plain arrays (scalars, nodes, dome limit, accurate cells, ideal-gas exponent, saturation
    nodes): what the time loop takes across the Python -> numba boundary, where a named tuple costs microseconds
    per call to unbox."""
    return (np.array([getattr(table, name) for name in TABLE_SCALARS]), table.nodes, table.dome_log_density_limit,
            table.accurate_cell, table.ideal_gas_exponent, table.saturation_nodes)


@kernel(allocates=True)
def table_from_arrays(scalars, nodes, dome_log_density_limit, accurate_cell, ideal_gas_exponent, saturation_nodes):
    """The PropertyTable of `table_arrays`' output, inside compiled code."""
    return PropertyTable(scalars[0], scalars[1], scalars[2], scalars[3], scalars[4], scalars[5], nodes, scalars[6],
                         dome_log_density_limit, accurate_cell, ideal_gas_exponent, scalars[7], scalars[8],
                         scalars[9], scalars[10], scalars[11], scalars[12], saturation_nodes)


@kernel(inline=True)
def _dew_volume(temperature, table):
    """v_v(T) [m^3/kg] where the dome branch applies (two-phase table, T on the accepted saturation line), else 0."""
    if not (table.two_phase != 0.0 and table.saturation_temperature_min <= temperature
            and temperature < table.saturation_temperature_max):
        return 0.0
    return saturation_quantity(VAPOUR_VOLUME, temperature, table.saturation_temperature_min,
                               table.inverse_saturation_step, table.saturation_nodes)[0]


@kernel(inline=True)
def _locate(temperature, density, table):
    """(status, i, j, t, s, dew volume): the cell (i, j) holding (T, ln rho) and the local coordinates t, s in
    [0, 1]. For a state beyond the dew line that the dome branch takes (dew volume v_v > 0), the cell and
    coordinates are those of the dew point (T, 1/v_v), where the mixture is anchored on the gas branch."""
    nodes = table.nodes
    if not (temperature > 0.0 and density > 0.0):
        return STATUS_INVALID_STATE, 0, 0, 0.0, 0.0, 0.0
    if temperature < table.temperature_min:
        return STATUS_TEMPERATURE_BELOW_TABLE, 0, 0, 0.0, 0.0, 0.0
    if temperature > table.temperature_max:
        return STATUS_TEMPERATURE_ABOVE_TABLE, 0, 0, 0.0, 0.0, 0.0
    log_density = math.log(density)
    if log_density < table.log_density_min:
        return STATUS_DENSITY_BELOW_TABLE, 0, 0, 0.0, 0.0, 0.0
    if log_density > table.log_density_max:
        return STATUS_DENSITY_ABOVE_TABLE, 0, 0, 0.0, 0.0, 0.0
    dew_volume = _dew_volume(temperature, table)
    if dew_volume > 0.0:
        if density * dew_volume > 1.0:
            log_density = -math.log(dew_volume)          # inside the dome: the dew point's cell
            if log_density < table.log_density_min:      # the envelope misses the dew point at this T
                return STATUS_DENSITY_BELOW_TABLE, 0, 0, 0.0, 0.0, 0.0
        else:
            dew_volume = 0.0                             # on the gas side of the dew line: the gas branch
    else:
        limits = table.dome_log_density_limit
        if log_density > limits[min(int((temperature - table.temperature_min) * table.inverse_dome_step),
                                    limits.size - 1)]:
            return STATUS_NEAR_SATURATION, 0, 0, 0.0, 0.0, 0.0
    u = (temperature - table.temperature_min) * table.inverse_temperature_step
    v = (log_density - table.log_density_min) * table.inverse_log_density_step
    i = min(int(u), nodes.shape[0] - 2)
    j = min(max(int(v), 0), nodes.shape[1] - 2)
    if not table.accurate_cell[i, j]:
        return STATUS_INACCURATE_CELL, 0, 0, 0.0, 0.0, 0.0
    return STATUS_OK, i, j, u - i, v - j, dew_volume


@kernel
def _interpolate(nodes, i, j, t, s):
    """Bicubic Hermite value of the four properties in cell (i, j) at local coordinates (t, s), and the pressure's
    derivative with respect to s (the local ln rho coordinate)."""
    ht0 = (1.0 + 2.0 * t) * (1.0 - t) * (1.0 - t)    # value weights H0, H1 and slope weights G0, G1 in t, s
    ht1 = t * t * (3.0 - 2.0 * t)
    gt0 = t * (1.0 - t) * (1.0 - t)
    gt1 = t * t * (t - 1.0)
    hs0 = (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s)
    hs1 = s * s * (3.0 - 2.0 * s)
    gs0 = s * (1.0 - s) * (1.0 - s)
    gs1 = s * s * (s - 1.0)
    dhs1 = 6.0 * s * (1.0 - s)                        # d/ds of H1 (and -d/ds of H0), G0, G1
    dgs0 = (1.0 - s) * (1.0 - 3.0 * s)
    dgs1 = s * (3.0 * s - 2.0)
    pressure = enthalpy = heat_capacity = pressure_derivative = pressure_slope = 0.0
    for corner in range(4):
        a = corner >> 1
        b = corner & 1
        weight_t = ht1 if a else ht0
        slope_t = gt1 if a else gt0
        weight_s = hs1 if b else hs0
        slope_s = gs1 if b else gs0
        d_weight_s = dhs1 if b else -dhs1
        d_slope_s = dgs1 if b else dgs0
        w0 = weight_t * weight_s
        w1 = slope_t * weight_s
        w2 = weight_t * slope_s
        w3 = slope_t * slope_s
        k, m = i + a, j + b
        pressure += (w0 * nodes[k, m, 0, 0] + w1 * nodes[k, m, 0, 1] + w2 * nodes[k, m, 0, 2]
                     + w3 * nodes[k, m, 0, 3])
        enthalpy += (w0 * nodes[k, m, 1, 0] + w1 * nodes[k, m, 1, 1] + w2 * nodes[k, m, 1, 2]
                     + w3 * nodes[k, m, 1, 3])
        heat_capacity += (w0 * nodes[k, m, 2, 0] + w1 * nodes[k, m, 2, 1] + w2 * nodes[k, m, 2, 2]
                          + w3 * nodes[k, m, 2, 3])
        pressure_derivative += (w0 * nodes[k, m, 3, 0] + w1 * nodes[k, m, 3, 1] + w2 * nodes[k, m, 3, 2]
                                + w3 * nodes[k, m, 3, 3])
        pressure_slope += (weight_t * d_weight_s * nodes[k, m, 0, 0] + slope_t * d_weight_s * nodes[k, m, 0, 1]
                           + weight_t * d_slope_s * nodes[k, m, 0, 2] + slope_t * d_slope_s * nodes[k, m, 0, 3])
    return pressure, enthalpy, heat_capacity, pressure_derivative, pressure_slope


@kernel
def table_status(temperature, density, table):
    """Status code of (T [K], rho [kg/m^3]) in `table` (0: inside the envelope, outside the dome's margin or, for a
    two-phase table, an equilibrium mixture or gas; in a cell that passed its accuracy check)."""
    return table_state(temperature, density, table).status


@kernel
def table_properties(temperature, density, table):
    """(p [Pa], h [J/kg], c_v [J/(kg K)], (dp/dT)_rho [Pa/K], status) at (T [K], rho [kg/m^3]).

    Bicubic Hermite interpolation in (T, ln rho) (module docstring); all four values are NaN if status != 0.
    """
    state = table_state(temperature, density, table)
    return state.pressure, state.enthalpy, state.heat_capacity_v, state.pressure_temperature_derivative, state.status


class FluidState(NamedTuple):
    """What the chamber equations read at (T, rho) (docs/model.md §7.3); NaN values if status != 0."""
    pressure: float                          # Pa
    enthalpy: float                          # J/kg
    heat_capacity_v: float                   # J/(kg K)
    pressure_temperature_derivative: float   # (dp/dT)_rho, Pa/K
    pressure_density_derivative: float       # (dp/drho)_T, Pa m^3/kg (derivative of the interpolant)
    status: int


@kernel(inline=True)
def _state_and_quality(temperature, density, table):
    """(FluidState, vapour quality) at (T, rho): the gas branch (quality 1) or, beyond the dew line of a two-phase
    table, the equilibrium mixture anchored at the dew point (module docstring, thermo.saturation)."""
    status, i, j, t, s, dew_volume = _locate(temperature, density, table)
    pressure, enthalpy, heat_capacity, pressure_derivative, slope = _interpolate(table.nodes, i, j, t, s)
    density_derivative = slope * table.inverse_log_density_step / density
    quality = 1.0
    if dew_volume > 0.0:          # pressure, enthalpy: the gas branch's p_sat and h_v at the dew point
        quality, liquid_enthalpy, _, heat_capacity, pressure_derivative = mixture_state(
            temperature, 1.0 / density, table.saturation_temperature_min, table.inverse_saturation_step,
            table.saturation_nodes)
        enthalpy = liquid_enthalpy + quality * (enthalpy - liquid_enthalpy)
        density_derivative = 0.0
        if not quality >= 0.0:
            status = STATUS_LIQUID
    if status != STATUS_OK:       # one exit: an early return costs about twice the whole evaluation in numba
        pressure = enthalpy = heat_capacity = pressure_derivative = density_derivative = quality = np.nan
    return FluidState(pressure, enthalpy, heat_capacity, pressure_derivative, density_derivative, status), quality


@kernel(inline=True)
def table_state(temperature, density, table):
    """The FluidState at (T [K], rho [kg/m^3]) by bicubic Hermite interpolation in (T, ln rho), or the equilibrium
    mixture inside the dome of a two-phase table (module docstring)."""
    return _state_and_quality(temperature, density, table)[0]


@kernel
def table_quality(temperature, density, table):
    """Vapour mass fraction x at (T [K], rho [kg/m^3]): in [0, 1) inside the dome of a two-phase table, 1 for any
    single-phase gas state (superheated or supercritical), NaN if the status is not 0."""
    return _state_and_quality(temperature, density, table)[1]


@kernel
def table_ideal_gas_exponent(temperature, table):
    """k = c_p0/(c_p0 - R) at T (docs/model.md §7.4), linear in T between the table's nodes; NaN outside its T range."""
    if not (table.temperature_min <= temperature <= table.temperature_max):
        return np.nan
    exponents = table.ideal_gas_exponent
    u = (temperature - table.temperature_min) * table.inverse_temperature_step
    i = min(int(u), exponents.size - 2)
    return exponents[i] + (u - i) * (exponents[i + 1] - exponents[i])


@kernel(allocates=True)
def _cell_centre_values(nodes):
    """The interpolated properties at the centre of every cell, (n_T - 1, n_x - 1, 4)."""
    values = np.empty((nodes.shape[0] - 1, nodes.shape[1] - 1, 4))
    for i in range(nodes.shape[0] - 1):
        for j in range(nodes.shape[1] - 1):
            values[i, j] = _interpolate(nodes, i, j, 0.5, 0.5)[:4]
    return values


# ----------------------------------------------------------------------------------------------------------
# building

def _check_count(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 4:
        raise ValueError(f"{name}={value!r} is out of range; allowed: an integer >= 4")
    return int(value)


def _checked_envelope(envelope) -> Envelope:
    """Envelope with finite floats > 0 and density_min < density_max: the checks that need no fluid."""
    if not isinstance(envelope, Envelope):
        raise ValueError(f"envelope={envelope!r} is out of range; allowed: a thermo.Envelope")
    values = [float(v) for v in envelope]
    for name, value in zip(Envelope._fields, values):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"envelope.{name}={value!r} is out of range; allowed: a finite number > 0")
    checked = Envelope(*values)
    if not checked.density_min < checked.density_max:
        raise ValueError(f"envelope.density_max={checked.density_max!r} is out of range; allowed: > "
                         f"envelope.density_min = {checked.density_min!r} kg/m^3")
    return checked


def _check_envelope(fluid: Fluid, envelope) -> Envelope:
    """`_checked_envelope`, and temperature_min < temperature_max inside the equation of state's range."""
    checked = _checked_envelope(envelope)
    if not fluid.minimum_temperature <= checked.temperature_min < checked.temperature_max <= fluid.maximum_temperature:
        raise ValueError(
            f"envelope temperature range [{checked.temperature_min!r}, {checked.temperature_max!r}] K is out of range; "
            f"allowed: min < max inside [{fluid.minimum_temperature!r}, {fluid.maximum_temperature!r}] K "
            f"(validity range of the {fluid.name} equation of state)")
    return checked


def _temperature_derivatives(state):
    """d/dT at constant rho of p, h, c_v and (dp/dT)_rho."""
    CP = coolprop()
    return (state.first_partial_deriv(CP.iP, CP.iT, CP.iDmass),
            state.first_partial_deriv(CP.iHmass, CP.iT, CP.iDmass),
            state.first_partial_deriv(CP.iCvmass, CP.iT, CP.iDmass),
            state.second_partial_deriv(CP.iP, CP.iT, CP.iDmass, CP.iT, CP.iDmass))


def _node_data(fluid: Fluid, temperature, log_density, temperature_step, log_density_step):
    """(4 properties, 4 data) of one node: f, dT f_T, dx f_x, dT dx f_Tx (module docstring); NaN where CoolProp
    cannot evaluate the gas branch (such nodes only occur deep inside the dome; their cells fail the check)."""
    CP = coolprop()
    density = math.exp(log_density)
    step = CROSS_DERIVATIVE_STEP
    try:
        state = fluid.gas_branch_state(temperature, density)
        values = _values(state)
        by_temperature = _temperature_derivatives(state)
        by_density = (state.first_partial_deriv(CP.iP, CP.iDmass, CP.iT),
                      state.first_partial_deriv(CP.iHmass, CP.iDmass, CP.iT),
                      state.first_partial_deriv(CP.iCvmass, CP.iDmass, CP.iT),
                      state.second_partial_deriv(CP.iP, CP.iT, CP.iDmass, CP.iDmass, CP.iT))
        above = _temperature_derivatives(fluid.gas_branch_state(temperature, math.exp(log_density + step)))
        below = _temperature_derivatives(fluid.gas_branch_state(temperature, math.exp(log_density - step)))
    except ValueError:
        return np.full((4, 4), np.nan)
    data = np.empty((4, 4))
    data[:, 0] = values
    data[:, 1] = temperature_step * np.array(by_temperature)
    data[:, 2] = log_density_step * density * np.array(by_density)
    data[:, 3] = temperature_step * log_density_step * (np.array(above) - np.array(below)) / (2.0 * step)
    return data


def _values(state):
    """p, h, c_v, (dp/dT)_rho of an updated AbstractState."""
    CP = coolprop()
    return (state.p(), state.hmass(), state.cvmass(), state.first_partial_deriv(CP.iP, CP.iT, CP.iDmass))


def _accurate_cells(fluid: Fluid, nodes, temperatures, log_densities):
    """True where the interpolated p, h, c_v, (dp/dT)_rho at the cell centre agree with the gas branch of HEOS to
    CELL_TOLERANCE (relative). The centre is where the Hermite error peaks: elsewhere in a cell the error of p and
    h was measured at most 1.4 times the centre's (c_v, (dp/dT)_rho: up to 10 times near the critical point)."""
    interpolated = _cell_centre_values(nodes)
    exact = np.full(interpolated.shape, np.nan)
    centre_temperatures = 0.5 * (temperatures[1:] + temperatures[:-1])
    centre_densities = np.exp(0.5 * (log_densities[1:] + log_densities[:-1]))
    for i, temperature in enumerate(centre_temperatures):
        for j, density in enumerate(centre_densities):
            try:
                exact[i, j] = _values(fluid.gas_branch_state(temperature, density))
            except ValueError:
                pass                                   # stays NaN: the cell fails
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.abs(interpolated / exact - 1.0)
    return np.all(error <= np.array(CELL_TOLERANCE), axis=2)


def dome_log_density_limit(fluid: Fluid, temperature, superheat_margin):
    """x_lim(T) = ln rho_gas(T, p_dew(T - margin)): the largest ln rho whose superheat at T is >= the margin.

    +inf if T - margin >= T_crit (no dome); -inf (refuse every density) if T - margin is below the triple point or
    CoolProp cannot evaluate the limit.
    """
    dew_temperature = temperature - superheat_margin
    if dew_temperature >= fluid.critical_temperature:
        return math.inf
    if dew_temperature < fluid.triple_temperature:
        return -math.inf
    try:
        return math.log(fluid.gas_density(temperature, fluid.dew_pressure(dew_temperature)))
    except ValueError:
        return -math.inf


def build_property_table(fluid: Fluid, envelope: Envelope, temperature_nodes=DEFAULT_TEMPERATURE_NODES,
                         log_density_nodes=DEFAULT_LOG_DENSITY_NODES) -> PropertyTable:
    """Evaluate the table's nodes from CoolProp HEOS (no disk cache; `property_table_for` caches)."""
    envelope = _check_envelope(fluid, envelope)
    temperature_nodes = _check_count("temperature_nodes", temperature_nodes)
    log_density_nodes = _check_count("log_density_nodes", log_density_nodes)
    temperatures = np.linspace(envelope.temperature_min, envelope.temperature_max, temperature_nodes)
    log_densities = np.linspace(math.log(envelope.density_min), math.log(envelope.density_max), log_density_nodes)
    temperature_step = temperatures[1] - temperatures[0]
    log_density_step = log_densities[1] - log_densities[0]
    nodes = np.empty((temperature_nodes, log_density_nodes, 4, 4))
    for i, temperature in enumerate(temperatures):
        for j, log_density in enumerate(log_densities):
            nodes[i, j] = _node_data(fluid, temperature, log_density, temperature_step, log_density_step)
    accurate_cell = _accurate_cells(fluid, nodes, temperatures, log_densities)
    dome_cells = DOME_REFINEMENT * (temperature_nodes - 1)
    dome_temperatures = np.linspace(envelope.temperature_min, envelope.temperature_max, dome_cells + 1)
    limits = np.array([dome_log_density_limit(fluid, t, envelope.superheat_margin) for t in dome_temperatures])
    saturation = build_saturation_line(fluid, envelope.temperature_min, envelope.temperature_max)
    return PropertyTable(
        temperature_min=float(temperatures[0]), temperature_max=float(temperatures[-1]),
        inverse_temperature_step=float(1.0 / temperature_step),
        log_density_min=float(log_densities[0]), log_density_max=float(log_densities[-1]),
        inverse_log_density_step=float(1.0 / log_density_step),
        nodes=nodes,
        inverse_dome_step=float(dome_cells / (envelope.temperature_max - envelope.temperature_min)),
        dome_log_density_limit=np.minimum(limits[:-1], limits[1:]),
        accurate_cell=accurate_cell,
        ideal_gas_exponent=np.array([fluid.ideal_gas_exponent(t) for t in temperatures]),
        superheat_margin=envelope.superheat_margin,
        critical_temperature=fluid.critical_temperature,
        two_phase=0.0, saturation_temperature_min=saturation.temperature_min,
        saturation_temperature_max=saturation.temperature_max,
        inverse_saturation_step=saturation.inverse_temperature_step, saturation_nodes=saturation.nodes)


def with_two_phase(table: PropertyTable, two_phase: bool) -> PropertyTable:
    """The same table with the dome branch on (states beyond the dew line are equilibrium mixtures, STATUS_OK) or
    off (STATUS_NEAR_SATURATION within the superheat margin of the dome, as before: the default)."""
    return table._replace(two_phase=1.0 if two_phase else 0.0)


def table_envelope(table: PropertyTable) -> Envelope:
    """The (T, rho) rectangle and margin a table covers."""
    return Envelope(table.temperature_min, table.temperature_max, math.exp(table.log_density_min),
                    math.exp(table.log_density_max), table.superheat_margin)


def envelope_for(fluid: Fluid, suction_pressure, suction_temperature, discharge_pressure,
                 superheat_margin=SUPERHEAT_MARGIN) -> Envelope:
    """A generous (T, rho) envelope for a compressor between p_s and p_d.

    Pressures from p_min = 0.25 p_s (suction throttling, re-expansion of the dead volume; at least the triple-point
    pressure) to p_max = 3 p_d (over-compression behind a throttling discharge port: the default machine reaches
    2.8 p_d at 6000 rpm; at most the equation of state's p_max). Temperatures from T_min = max(T_dew(p_min), T(p_min, s_s) - 20 K) -- no gas at
    p >= p_min is colder than its dew point, and suction gas expanded isentropically to p_min is the coldest gas an
    adiabatic machine makes -- to T_max = T(p_max, s_s) + 150 K (leak and re-compression heating well above the
    isentropic discharge temperature), both clipped to the equation of state's range. Densities from
    rho(T_max, p_min) to rho(T_cold, p_max) with T_cold = max(T_min, T(p_max, s_s) - 20 K, T_dew(p_max) + margin),
    T_crit + margin in place of the dew term for p_max >= p_crit: the densest gas an adiabatic machine makes, with
    the same 20 K allowance as at p_min (at p_d, below p_max, the rectangle admits much colder gas); or, if
    larger, rho(P, s_s) on the suction isentrope at P = 4 p_d (ENVELOPE_DENSE_PRESSURE_FACTOR; at most the EOS
    p_max and the pressure where the isentrope reaches the EOS T_max): no chamber state at p <= P is denser, its
    entropy being at least s_s, and a chamber behind a port that cannot pass its gas is over-compressed and hot and
    leaves the rectangle through its density bound (docs/model.md §7.3). T_max stays on the isentrope to 3 p_d: the
    isentrope to 4 p_d would leave the EOS's temperature range for more points. Keeping the
    compressed-liquid-like states near the critical point out (CO2 at 20 MPa and 305 K) keeps the table accurate
    there. s_s is the suction entropy; the operating point is checked first (`check_operating_point`).
    """
    check_operating_point(fluid, suction_pressure, suction_temperature, discharge_pressure, superheat_margin)
    suction_density = fluid.density(suction_temperature, suction_pressure)
    suction_entropy = fluid.properties(suction_temperature, suction_density).entropy
    low_pressure = max(ENVELOPE_LOW_PRESSURE_FACTOR * suction_pressure, fluid.dew_pressure(fluid.triple_temperature))
    high_pressure = min(ENVELOPE_HIGH_PRESSURE_FACTOR * discharge_pressure, fluid.maximum_pressure)
    expanded = fluid.state_at_pressure_entropy(low_pressure, suction_entropy).temperature
    compressed = fluid.state_at_pressure_entropy(high_pressure, suction_entropy).temperature
    low_dew = fluid.saturation_temperature(low_pressure)
    temperature_min = max(fluid.minimum_temperature, expanded - ENVELOPE_COLD_MARGIN,
                          -math.inf if low_dew is None else low_dew)
    temperature_max = min(fluid.maximum_temperature, compressed + ENVELOPE_HOT_MARGIN)
    coldest_at_high_pressure = max(temperature_min, compressed - ENVELOPE_COLD_MARGIN,
                                   fluid.dome_temperature(high_pressure) + superheat_margin)
    dense = fluid.state_at_pressure_entropy(min(ENVELOPE_DENSE_PRESSURE_FACTOR * discharge_pressure,
                                                fluid.maximum_pressure), suction_entropy)
    if dense.temperature > fluid.maximum_temperature:      # the isentrope leaves the EOS first: stop it at T_max
        dense = fluid.state_at_pressure_entropy(
            fluid.pressure_at_temperature_entropy(fluid.maximum_temperature, suction_entropy), suction_entropy)
    return Envelope(temperature_min, temperature_max, fluid.density(temperature_max, low_pressure),
                    max(fluid.density(coldest_at_high_pressure, high_pressure), dense.density),
                    float(superheat_margin))


# ----------------------------------------------------------------------------------------------------------
# disk cache (thermo.disk_cache)

def _cache_key(coolprop_name: str, envelope: Envelope, temperature_nodes, log_density_nodes) -> str:
    """Everything the table's content depends on, as text (floats by repr: exact); no CoolProp import."""
    return "|".join([f"format {FORMAT_VERSION}", f"fluid {coolprop_name}",
                     "envelope " + " ".join(repr(float(v)) for v in envelope),
                     f"nodes {temperature_nodes}x{log_density_nodes}", f"coolprop {coolprop_version()}",
                     f"dome refinement {DOME_REFINEMENT}", f"cross step {CROSS_DERIVATIVE_STEP!r}",
                     f"cell tolerance {CELL_TOLERANCE!r}", f"saturation step {DEFAULT_SATURATION_STEP!r}",
                     f"saturation tolerance {SATURATION_TOLERANCE!r}"])


def property_table_path(fluid, envelope: Envelope, temperature_nodes=DEFAULT_TEMPERATURE_NODES,
                        log_density_nodes=DEFAULT_LOG_DENSITY_NODES, cache_dir=None) -> Path:
    """The cache file of this fluid, envelope and grid: <cache dir>/<fluid>-<hash of the key>.npz. `fluid`: a
    Fluid, or anything naming one by its canonical `coolprop_name` (a thermo.operating_point.OperatingPoint)."""
    key = _cache_key(fluid.coolprop_name, _checked_envelope(envelope), temperature_nodes, log_density_nodes)
    return cache_path(fluid.coolprop_name, key, ".npz", cache_dir)


def _load(path: Path, key: str, temperature_nodes, log_density_nodes) -> PropertyTable:
    """Read a cached table; ValueError unless it is complete and carries `key`."""
    with np.load(path, allow_pickle=False) as data:
        if str(data["key"]) != key:
            raise ValueError("the file belongs to another key")
        fields = {name: data[name] for name in PropertyTable._fields}
    table = PropertyTable(**{name: float(value) if value.ndim == 0 else value for name, value in fields.items()})
    if (table.nodes.shape != (temperature_nodes, log_density_nodes, 4, 4)
            or table.accurate_cell.shape != (temperature_nodes - 1, log_density_nodes - 1)
            or table.ideal_gas_exponent.shape != (temperature_nodes,)
            or table.dome_log_density_limit.shape != (DOME_REFINEMENT * (temperature_nodes - 1),)
            or table.saturation_nodes.ndim != 3 or table.saturation_nodes.shape[0] < 2
            or table.saturation_nodes.shape[1:] != (len(SATURATION_QUANTITIES), 2)):
        raise ValueError("array shapes do not match the key")
    return table


def property_table_for(fluid, envelope: Envelope, temperature_nodes=DEFAULT_TEMPERATURE_NODES,
                       log_density_nodes=DEFAULT_LOG_DENSITY_NODES, cache_dir=None,
                       two_phase=False) -> PropertyTable:
    """The table of `fluid` over `envelope`, loaded from the disk cache or built from HEOS and cached; with
    `two_phase`, states beyond the dew line are equilibrium mixtures (`with_two_phase`; the cached file is the same).

    `fluid`: a Fluid, or anything naming one by its canonical `coolprop_name` (an OperatingPoint): the Fluid, and
    with it CoolProp, is then made only if the table must be built. Cache folder: `cache_dir`, else
    `thermo.disk_cache.property_cache_dir()`. The file name hashes the fluid, envelope, grid, CoolProp version and FORMAT_VERSION; an
    unreadable or mismatching file is rebuilt (with a warning), never trusted (thermo.disk_cache).
    """
    envelope = _checked_envelope(envelope)
    temperature_nodes = _check_count("temperature_nodes", temperature_nodes)
    log_density_nodes = _check_count("log_density_nodes", log_density_nodes)
    path = property_table_path(fluid, envelope, temperature_nodes, log_density_nodes, cache_dir)
    key = _cache_key(fluid.coolprop_name, envelope, temperature_nodes, log_density_nodes)
    table = load_or_build(
        path, lambda stored: _load(stored, key, temperature_nodes, log_density_nodes),
        lambda: build_property_table(fluid if isinstance(fluid, Fluid) else Fluid(fluid.coolprop_name), envelope,
                                     temperature_nodes, log_density_nodes),
        lambda stream, table: np.savez(stream, key=np.array(key), **table._asdict()), "property table")
    return with_two_phase(table, two_phase)


# ----------------------------------------------------------------------------------------------------------
# messages

def envelope_status_text(status, where, envelope, table_name, user, fluid, temperature, density) -> str | None:
    """The sentence for a state outside a table's envelope (temperature or density range, near the dome), shared
    by the property table and the nozzle table (thermo.real_gas_nozzle); None for any other status."""
    if status in (STATUS_TEMPERATURE_BELOW_TABLE, STATUS_TEMPERATURE_ABOVE_TABLE):
        side = "below" if status == STATUS_TEMPERATURE_BELOW_TABLE else "above"
        return (f"{where}: the temperature is {side} the {table_name}'s range [{envelope.temperature_min:.6g}, "
                f"{envelope.temperature_max:.6g}] K; build the table over a wider Envelope")
    if status in (STATUS_DENSITY_BELOW_TABLE, STATUS_DENSITY_ABOVE_TABLE):
        side = "below" if status == STATUS_DENSITY_BELOW_TABLE else "above"
        return (f"{where}: the density is {side} the {table_name}'s range [{envelope.density_min:.6g}, "
                f"{envelope.density_max:.6g}] kg/m^3; build the table over a wider Envelope")
    if status == STATUS_LIQUID:
        return (f"{where} is a liquid: denser than the saturated liquid at its temperature; {user} takes gas and "
                "liquid-vapour mixtures only (docs/model.md §7.3.1)")
    if status == STATUS_NEAR_SATURATION:
        detail = _saturation_detail(fluid, float(temperature), float(density)) if fluid is not None else ""
        return (f"{where} is inside the two-phase dome or less than {envelope.superheat_margin:g} K of superheat "
                f"away from it{detail}; {user} needs a single-phase gas (docs/model.md §7.3)")
    return None


def describe_status(status, temperature, density, table: PropertyTable, fluid: Fluid | None = None,
                    state="state") -> str:
    """A readable sentence for a status code of `table_properties`: which state, why, and what to do.

    `state` names the state (e.g. "leading chamber of lobe 2"); with `fluid`, a state near or inside the dome is
    described by its exact pressure, dew temperature and superheat from HEOS.
    """
    envelope = table_envelope(table)
    where = f"{state} (T = {float(temperature):.6g} K, rho = {float(density):.6g} kg/m^3)"
    if status == STATUS_OK:
        return f"{where} is inside the property table"
    if status == STATUS_INVALID_STATE:
        return f"{where} is not a physical state: temperature and density must be positive numbers"
    shared = envelope_status_text(status, where, envelope, "property table", "the model", fluid, temperature,
                                  density)
    if shared is not None:
        return shared
    if status == STATUS_INACCURATE_CELL:
        return (f"{where} lies in a table cell that missed its accuracy check against HEOS (relative tolerances "
                f"p, h, c_v, (dp/dT)_rho = {', '.join(f'{t:g}' for t in CELL_TOLERANCE)}), typically near the "
                f"critical point (T_crit = {table.critical_temperature:.6g} K); use exact HEOS there or a finer grid")
    return f"{where}: unknown property-table status {status!r}"


def _saturation_detail(fluid: Fluid, temperature, density) -> str:
    """' (p = ..., dew temperature ..., superheat ...)', or the vapour quality inside the dome, from HEOS."""
    try:
        quality = fluid.vapour_quality(temperature, density)
        if quality is not None:
            return f" (vapour quality {quality:.4g} from HEOS)"
        pressure = fluid.properties(temperature, density).pressure
        dew = fluid.saturation_temperature(pressure)
    except ValueError as error:
        return f" ({error})"
    if dew is None:
        return (f" (p = {pressure:.6g} Pa is supercritical; "
                f"T - T_crit = {temperature - fluid.critical_temperature:.3g} K)")
    return f" (p = {pressure:.6g} Pa, dew temperature {dew:.6g} K, superheat {temperature - dew:.3g} K)"
