"""Real-fluid isentropic nozzle flow, tabulated from CoolProp HEOS and evaluated in numba (docs/model.md §7.4).

The mass flux of an isentropic expansion from an upstream stagnation state 0 (the chamber, held at (T0, rho0), its
pressure p0 given) to a downstream static pressure p_down is

    G = rho(p_t, s0) sqrt(2 (h0 - h(p_t, s0))),      p_t = max(p_down, p*)

where p* maximises G along the isentrope: there the velocity equals the speed of sound (d(rho u)/dp = 0 on an
isentrope gives u = c), so the flow is choked for p_down <= p* and G stays at G*.

Parametrisation (chosen so that one evaluation is one logarithm, a square root and about 60 multiply-adds):

    pr = p_down/p0,  pr* = p*/p0,  sigma = min(1, (1 - pr)/(1 - pr*))                 in [0, 1]
    G^2 = p0 rho0 psi*^2 [1 - (1 - sigma)^2 m(T0, rho0, sigma)]

psi*^2 = G*^2/(p0 rho0) is the choked flux factor (for an ideal gas k (2/(k+1))^((k+1)/(k-1))), and the shape factor
m is defined by the equation above. It is close to 1 for every gas (an ideal gas with k = 1.4: 0.996 at sigma = 0.5)
and m(sigma = 0) = 1 exactly, so that G^2 -> 2 rho0 (p0 - p_down) as pr -> 1 (Bernoulli, for any fluid). The form
makes the flow continuous with a zero slope at the critical ratio (sigma = 1) and monotone in p_down for any
smooth m. The table holds pr*, psi*^2 and m at nodes uniform in T0, ln rho0 and sigma, all computed from the gas
branch of HEOS (`Fluid.gas_branch_state`), and interpolates them (bi)linearly: pr*, psi*^2 bilinearly in
(T0, ln rho0), m trilinearly in (T0, ln rho0, sigma). The table's upstream envelope is that of the property table
(`property_table.envelope_for`); a state is accepted under the same rules (in range, at least the envelope's margin
of superheat outside the dome, in a cell that passed the build check).

Two-phase dome. For a wet fluid (R134a, CO2, R410A near saturation) the expansion from a superheated chamber state
can reach the dew line before the throat. The table then continues along the gas branch of the equation of state
(a metastable, supersaturated vapour: the "frozen" expansion; a gap or a port is passed in microseconds, far too
fast for equilibrium condensation at a few kelvin of supersaturation). The flux is finite and smooth across the
dew line, and the evaluation reports STATUS_THROAT_NEAR_SATURATION whenever the throat state's superheat
T_t - T_dew(p_t) is below the envelope's margin (the superheat at the throat is tabulated like m and interpolated
at the throat's sigma), so the caller knows the number is the metastable continuation, not an equilibrium
(homogeneous two-phase) expansion. Above the critical pressure the margin is T_t >= T_crit + margin, as in the
property table.

Build check: at every cell centre the flux is computed directly (at sigma = 0.5 and choked) and compared with the
interpolated one; a cell worse than CELL_TOLERANCE (relative) is refused (STATUS_INACCURATE_CELL), as are cells
with a node that HEOS could not evaluate.

Wet upstream states (docs/model.md §7.4.1; off by default, like the property table's dome): a table built with
`two_phase` (`nozzle_table_for(..., two_phase=True)`; `with_two_phase` switches it off and on again) takes an
upstream state beyond the dew line as an equilibrium mixture expanding along its equilibrium isentrope (homogeneous
equilibrium model, thermo.two_phase_nozzle), tabulated with the same pr*, psi*^2, m(sigma) in (T0, x0) over the
saturation line of the property table (thermo.saturation), which gives x0. The viscosity there is the saturated
vapour's. At the dew line the flux steps by the difference between the metastable and the equilibrium expansion
(R134a: 0.1-0.4 % at 250-350 K, up to 2 % near the critical point).

Status codes: those of `property_table` for the upstream state (0-7, and STATUS_LIQUID = 9 with two_phase), plus
    STATUS_THROAT_NEAR_SATURATION = 8   upstream a gas state; the throat state is inside the dome or within the
                                        margin of it: the flux is the gas-branch (metastable) continuation.
For codes 1-7 and 9 the flux is NaN.

Tables are cached on disk per fluid, envelope, grid, format version and CoolProp version (`nozzle_table_for`), in
the property tables' cache folder.

Measured (benchmarks/bench_nozzle.py, default 64 x 64 x 17 grid, 1.23 MB, 3-7 s to build with its check): worst
relative error against CoolProp's equilibrium expansion where upstream and throat are gas beyond the margin
2.2e-4 (R134a), 4.8e-4 (R410A), 1.2e-4 (air), 2.4e-3 (CO2, next to its critical point); 26-45 ns per
`real_gas_mass_flux` and 36-52 ns per `signed_real_gas_nozzle_flow` inside numba (the ideal-gas nozzle: 31-46 ns).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .control_volume import LINEAR_FLOW_BAND
from ..kernels.kernel import kernel
from .fluid import Fluid, coolprop, coolprop_version
from .disk_cache import cache_path, load_or_build
from .property_table import (DEFAULT_TEMPERATURE_NODES as PROPERTY_TEMPERATURE_NODES, DOME_REFINEMENT,
                             STATUS_DENSITY_ABOVE_TABLE, STATUS_DENSITY_BELOW_TABLE, STATUS_INACCURATE_CELL,
                             STATUS_INVALID_STATE, STATUS_LIQUID, STATUS_NEAR_SATURATION, STATUS_OK,
                             STATUS_TEMPERATURE_ABOVE_TABLE, STATUS_TEMPERATURE_BELOW_TABLE, Envelope, _check_count,
                             _check_envelope, _checked_envelope, dome_log_density_limit, envelope_status_text)
from .saturation import (DEFAULT_SATURATION_STEP, LIQUID_VOLUME, SATURATION_QUANTITIES, SATURATION_TOLERANCE,
                         VAPOUR_VOLUME, build_saturation_line, saturation_quantity)
from .two_phase_nozzle import (DEFAULT_DOME_TEMPERATURE_NODES, DEFAULT_QUALITY_NODES, EquilibriumIsentrope,
                               build_dome_nozzle)

FORMAT_VERSION = 2                      # 2: the saturation line and the two-phase (HEM) upstream states
DEFAULT_TEMPERATURE_NODES = 64
DEFAULT_LOG_DENSITY_NODES = 64
DEFAULT_RATIO_NODES = 17                # sigma nodes on [0, 1]
CELL_TOLERANCE = 1e-3                   # relative flux error at each cell centre (build check)
ISENTROPE_TOLERANCE = 1e-13             # Newton convergence (relative T, absolute ln rho) of an isentrope point
CRITICAL_RATIO_TOLERANCE = 1e-11        # on pr* (the flux is flat there: G error ~ (dpr)^2)
LAST_SIGMA_OFFSET = 1e-3                # m(1) is evaluated at sigma = 1 - this (m(1) is a 0/0 limit)
DOME_CELLS = DOME_REFINEMENT * (PROPERTY_TEMPERATURE_NODES - 1)   # the property table's default: same verdicts
SEARCH_RATIOS = (0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2, 0.12, 0.06)   # bracket of the sonic condition

STATUS_THROAT_NEAR_SATURATION = 8


class NozzleTable(NamedTuple):
    """The numeric content of a real-gas nozzle table, as numba takes it (see the module docstring)."""
    temperature_min: float                 # K, first node
    temperature_max: float                 # K, last node
    inverse_temperature_step: float        # 1/K
    log_density_min: float                 # ln(kg/m^3), first node
    log_density_max: float                 # ln(kg/m^3), last node
    inverse_log_density_step: float
    inverse_sigma_step: float              # sigma nodes are uniform on [0, 1]
    inverse_dome_step: float               # 1/K, dome-limit cells start at temperature_min
    superheat_margin: float                # K
    critical_ratio: np.ndarray             # (n_T, n_x): pr* = p*/p0
    choked_flux_factor: np.ndarray         # (n_T, n_x): psi*^2 = G*^2/(p0 rho0)
    shape_factor: np.ndarray               # (n_T, n_x, n_sigma): m
    throat_superheat: np.ndarray           # (n_T, n_x, n_sigma): T_t - T_dew(p_t) [K] (T_t - T_crit above p_crit)
    viscosity: np.ndarray                  # (n_T, n_x): dynamic viscosity of the upstream state [Pa s]
    dome_log_density_limit: np.ndarray     # (n_dome,): largest accepted ln rho in each dome cell
    accurate_cell: np.ndarray              # (n_T - 1, n_x - 1) bool
    # upstream states inside the dome (thermo.two_phase_nozzle); defaults: a table without them
    two_phase: float = 0.0                 # 1.0: upstream states beyond the dew line take the HEM part
    saturation_temperature_min: float = 0.0      # K: the saturation line, as the property table's
    saturation_temperature_max: float = 0.0      # K, its accepted end; also the last dome node
    inverse_saturation_step: float = 1.0   # 1/K
    dome_inverse_temperature_step: float = 1.0   # 1/K, dome nodes from saturation_temperature_min
    dome_inverse_quality_step: float = 1.0       # quality nodes uniform on [0, 1]
    saturation_nodes: np.ndarray = np.zeros((2, len(SATURATION_QUANTITIES), 2))   # thermo.saturation
    dome_critical_ratio: np.ndarray = np.zeros((2, 2))            # (n_Td, n_q): pr* of the HEM expansion
    dome_choked_flux_factor: np.ndarray = np.zeros((2, 2))        # (n_Td, n_q): psi*^2
    dome_shape_factor: np.ndarray = np.zeros((2, 2, 2))           # (n_Td, n_q, n_sigma): m
    dome_accurate_cell: np.ndarray = np.zeros((1, 1), dtype=np.bool_)   # (n_Td - 1, n_q - 1)


SCALAR_FIELDS = NozzleTable._fields[:9] + NozzleTable._fields[16:22]
ARRAY_FIELDS = NozzleTable._fields[9:16] + NozzleTable._fields[22:]


# ----------------------------------------------------------------------------------------------------------
# numba kernels (kernels.kernel: numpy's error model, no exception can leave them)
#
# The evaluation kernels only read the table, so they are compiled without numba's reference counting
# (`@kernel`): passing the NamedTuple of seven arrays into a call otherwise costs an atomic incref/decref pair
# per array, which measured 50 ns per signed flow (3 times the evaluation itself). A kernel compiled so may not
# allocate (no arrays created, no lists); nozzle_table_from_arrays, which builds a NamedTuple of arrays, keeps it.
#
# The look-ups on the loop's path (nozzle_flux_between, real_gas_mass_flux, table_viscosity and what locates their
# cell, and thermo.leakage.real_gas_leakage_flow, which calls table_viscosity) are compiled into their callers
# (`@kernel(inline=True)`), so the table is passed by value once per right-hand side (into
# thermo.flow_paths.path_flows), not once per look-up. A call passes it flattened into its fields (seven words and
# more per array); since the dome's arrays were added (12 arrays, 15 floats) these functions grew past what LLVM
# inlines by itself, and copying the table cost more than the look-up: measured per call, flux 73 -> 36 ns,
# viscosity 50 -> 15 ns (54 and 8 ns before the dome); the real-gas right-hand side about 1.65 -> 1.30 us.
# Inlining only the look-ups and not real_gas_leakage_flow made that slower (2.5 us): it then no longer fit
# into path_flows and took the table on each of its calls.

@kernel(allocates=True)
def nozzle_table_from_arrays(header, critical_ratio, choked_flux_factor, shape_factor, throat_superheat, viscosity,
                             dome_log_density_limit, accurate_cell, saturation_nodes, dome_critical_ratio,
                             dome_choked_flux_factor, dome_shape_factor, dome_accurate_cell):
    """Rebuild a NozzleTable inside nopython code from the arrays of `nozzle_table_arrays(table)` (passing arrays
    across the Python -> numba boundary is cheaper than unboxing a NamedTuple). `header` holds the floats of
    SCALAR_FIELDS in that order."""
    return NozzleTable(header[0], header[1], header[2], header[3], header[4], header[5], header[6], header[7],
                       header[8], critical_ratio, choked_flux_factor, shape_factor, throat_superheat, viscosity,
                       dome_log_density_limit, accurate_cell, header[9], header[10], header[11], header[12],
                       header[13], header[14], saturation_nodes, dome_critical_ratio, dome_choked_flux_factor,
                       dome_shape_factor, dome_accurate_cell)


@kernel(inline=True)
def _dome_cell(temperature, density, table):
    """(in dome, status, i, j, t, s): for a two-phase table and T on its saturation line, whether rho is beyond the
    dew line, and then the (T, x) cell of the HEM part and the local coordinates (STATUS_LIQUID below x = 0)."""
    if not (table.two_phase != 0.0 and table.saturation_temperature_min <= temperature
            and temperature < table.saturation_temperature_max):
        return False, STATUS_OK, 0, 0, 0.0, 0.0
    nodes = table.saturation_nodes
    vapour_volume = saturation_quantity(VAPOUR_VOLUME, temperature, table.saturation_temperature_min,
                                        table.inverse_saturation_step, nodes)[0]
    if density * vapour_volume <= 1.0:
        return False, STATUS_OK, 0, 0, 0.0, 0.0
    liquid_volume = saturation_quantity(LIQUID_VOLUME, temperature, table.saturation_temperature_min,
                                        table.inverse_saturation_step, nodes)[0]
    quality = (1.0 / density - liquid_volume) / (vapour_volume - liquid_volume)
    if not quality >= 0.0:
        return True, STATUS_LIQUID, 0, 0, 0.0, 0.0
    u = (temperature - table.saturation_temperature_min) * table.dome_inverse_temperature_step
    w = quality * table.dome_inverse_quality_step
    i = min(int(u), table.dome_critical_ratio.shape[0] - 2)
    j = min(int(w), table.dome_critical_ratio.shape[1] - 2)
    if not table.dome_accurate_cell[i, j]:
        return True, STATUS_INACCURATE_CELL, 0, 0, 0.0, 0.0
    return True, STATUS_OK, i, j, u - i, w - j


@kernel(inline=True)
def _locate(temperature, density, table):
    """(status, i, j, t, s, dome): the cell of an upstream state and the local coordinates in [0, 1]: the
    (T, ln rho) cell of the gas part, or with dome True the (T, x) cell of the HEM part (two-phase table, beyond
    the dew line). One exit: an early return costs about as much as the whole evaluation in numba."""
    status = STATUS_OK
    i = j = 0
    t = s = 0.0
    dome = False
    if not (temperature > 0.0 and density > 0.0):
        status = STATUS_INVALID_STATE
    elif temperature < table.temperature_min:
        status = STATUS_TEMPERATURE_BELOW_TABLE
    elif temperature > table.temperature_max:
        status = STATUS_TEMPERATURE_ABOVE_TABLE
    else:
        log_density = math.log(density)
        limits = table.dome_log_density_limit
        if log_density < table.log_density_min:
            status = STATUS_DENSITY_BELOW_TABLE
        elif log_density > table.log_density_max:
            status = STATUS_DENSITY_ABOVE_TABLE
        else:
            dome, status, i, j, t, s = _dome_cell(temperature, density, table)
            if not dome:
                on_line = (table.two_phase != 0.0 and table.saturation_temperature_min <= temperature
                           and temperature < table.saturation_temperature_max)
                if not on_line and log_density > limits[min(int((temperature - table.temperature_min)
                                                                * table.inverse_dome_step), limits.size - 1)]:
                    status = STATUS_NEAR_SATURATION
                else:
                    status, i, j, t, s = _gas_cell(temperature, log_density, table)
    return status, i, j, t, s, dome


@kernel(inline=True)
def _gas_cell(temperature, log_density, table):
    """(status, i, j, t, s) of the (T, ln rho) cell of the gas part (inside the table's rectangle)."""
    u = (temperature - table.temperature_min) * table.inverse_temperature_step
    v = (log_density - table.log_density_min) * table.inverse_log_density_step
    i = min(max(int(u), 0), table.critical_ratio.shape[0] - 2)
    j = min(max(int(v), 0), table.critical_ratio.shape[1] - 2)
    if table.accurate_cell[i, j]:
        return STATUS_OK, i, j, u - i, v - j
    return STATUS_INACCURATE_CELL, 0, 0, 0.0, 0.0


@kernel
def _bilinear(values, i, j, t, s):
    return ((1.0 - t) * ((1.0 - s) * values[i, j] + s * values[i, j + 1])
            + t * ((1.0 - s) * values[i + 1, j] + s * values[i + 1, j + 1]))


@kernel
def _trilinear(values, i, j, k, t, s, r):
    return ((1.0 - t) * ((1.0 - s) * ((1.0 - r) * values[i, j, k] + r * values[i, j, k + 1])
                         + s * ((1.0 - r) * values[i, j + 1, k] + r * values[i, j + 1, k + 1]))
            + t * ((1.0 - s) * ((1.0 - r) * values[i + 1, j, k] + r * values[i + 1, j, k + 1])
                   + s * ((1.0 - r) * values[i + 1, j + 1, k] + r * values[i + 1, j + 1, k + 1])))


@kernel(inline=True)
def real_gas_mass_flux(temperature_up, density_up, pressure_up, pressure_down, table):
    """(G [kg/(s m^2)], status): mass flux of the isentropic expansion from the upstream stagnation state
    (T_up [K], rho_up [kg/m^3], p_up [Pa]) to p_down [Pa] (docs/model.md §7.4; module docstring):

        G = rho(p_t, s0) sqrt(2 (h0 - h(p_t, s0))),   p_t = max(p_down, p*)        (choked below p*)
          = sqrt(p_up rho_up psi*^2 [1 - (1 - sigma)^2 m]),  sigma = min(1, (1 - pr)/(1 - pr*)), pr = p_down/p_up

    p_up is the caller's upstream pressure (the property table's p(T_up, rho_up)). G = 0 for p_down >= p_up.
    status: 0, the upstream state's refusal (1-7; G is NaN), or STATUS_THROAT_NEAR_SATURATION (8; G is the
    gas-branch continuation through a throat within the superheat margin of the dome or inside it).
    """
    status, i, j, t, s, dome = _locate(temperature_up, density_up, table)
    upstream = pressure_up
    if not (pressure_up > 0.0 and pressure_up < np.inf and pressure_down == pressure_down):
        upstream = 1.0                   # keeps the arithmetic below finite; the flux is NaN
        if status == STATUS_OK:
            status = STATUS_INVALID_STATE
    critical_ratio = table.dome_critical_ratio if dome else table.critical_ratio
    choked_flux_factor = table.dome_choked_flux_factor if dome else table.choked_flux_factor
    shape_factor = table.dome_shape_factor if dome else table.shape_factor
    critical = _bilinear(critical_ratio, i, j, t, s)         # in (0.06, 1) by construction, or NaN
    sigma = (1.0 - pressure_down / upstream) / (1.0 - critical)
    # selects, not an if/elif (which cost about 50 ns here in numba); NaN and p_down >= p_up give 0: no flow
    sigma = sigma if sigma > 0.0 else 0.0
    sigma = sigma if sigma < 1.0 else 1.0
    position = sigma * table.inverse_sigma_step
    k = min(int(position), shape_factor.shape[2] - 2)
    r = position - k
    shape = _trilinear(shape_factor, i, j, k, t, s, r)
    gap = 1.0 - sigma
    flux = math.sqrt(max(0.0, upstream * density_up * _bilinear(choked_flux_factor, i, j, t, s)
                         * (1.0 - gap * gap * shape))) if sigma > 0.0 else 0.0
    if status != STATUS_OK:
        flux = np.nan
    # branch-free, as above; an equilibrium (HEM) expansion has no metastable throat
    near = (not dome) and _trilinear(table.throat_superheat, i, j, k, t, s, r) < table.superheat_margin
    status += STATUS_THROAT_NEAR_SATURATION * (status == STATUS_OK) * near
    return flux, status


@kernel(inline=True)
def nozzle_flux_between(temperature_a, density_a, pressure_a, temperature_b, density_b, pressure_b, table):
    """(G [kg/(s m^2)], factor, status): the real-gas isentropic flux of the upstream side towards the other side's
    pressure and the signed factor such that the flow from side a to side b through a nozzle of area A and
    discharge coefficient C_d is C_d A G factor (docs/model.md §7.4). With eps = LINEAR_FLOW_BAND:

        |p_up - p_down| >= eps p_up:  G = G(up, p_down),           factor = +-1
        |p_up - p_down| <  eps p_up:  G = G(up, (1 - eps) p_up),   factor = +-(p_up - p_down)/(eps p_up)

    the sign + from a to b. The same linear band as `control_volume.signed_nozzle_flow`: continuous at the band
    edge, and at the critical ratio G is continuous with a zero slope. status: the upstream side's
    `real_gas_mass_flux`. One flux serves every path between the same two sides (a port and a seal).
    """
    forward = pressure_a >= pressure_b           # selects throughout (branches cost tens of ns here in numba)
    temperature = temperature_a if forward else temperature_b
    density = density_a if forward else density_b
    upstream = pressure_a if forward else pressure_b
    downstream = pressure_b if forward else pressure_a
    band = LINEAR_FLOW_BAND * upstream
    difference = upstream - downstream           # >= 0, so inside the band band > 0
    inside = difference < band
    flux, status = real_gas_mass_flux(temperature, density, upstream, upstream - band if inside else downstream,
                                      table)
    factor = difference / band if inside else 1.0
    return flux, (factor if forward else -factor), status


@kernel
def signed_real_gas_nozzle_flow(discharge_coefficient, area, temperature_a, density_a, pressure_a, temperature_b,
                                density_b, pressure_b, table):
    """(m_dot [kg/s], status): mass flow from side a to side b through a real-gas isentropic nozzle of area A and
    discharge coefficient C_d (docs/model.md §7.4), negative when the gas flows from b to a: C_d A G factor of
    `nozzle_flux_between` (its linear band, the sign convention of `control_volume.signed_nozzle_flow`). A <= 0
    gives 0, whatever the upstream status."""
    flux, factor, status = nozzle_flux_between(temperature_a, density_a, pressure_a, temperature_b, density_b,
                                               pressure_b, table)
    return (discharge_coefficient * area * flux * factor if area > 0.0 else 0.0), status


@kernel(inline=True)
def table_viscosity(temperature, density, table):
    """(mu [Pa s], status): dynamic viscosity of the upstream state (bilinear in (T, ln rho); for the Reynolds
    number of the leakage laws, thermo.leakage); inside the dome of a two-phase table the saturated vapour's at
    T (no mixture rule). NaN unless status == 0."""
    status, i, j, t, s, dome = _locate(temperature, density, table)
    if dome and status == STATUS_OK:          # the saturated vapour's (docs/model.md §7.4.1)
        vapour_volume = saturation_quantity(VAPOUR_VOLUME, temperature, table.saturation_temperature_min,
                                            table.inverse_saturation_step, table.saturation_nodes)[0]
        status, i, j, t, s = _gas_cell(temperature, -math.log(vapour_volume), table)
    viscosity = _bilinear(table.viscosity, i, j, t, s)
    if status != STATUS_OK:
        viscosity = np.nan
    return viscosity, status


# ----------------------------------------------------------------------------------------------------------
# direct computation from HEOS (build, checks)

_GAS_BRANCH_STATES = {}


def _gas_branch(fluid: Fluid):
    """A HEOS AbstractState of the fluid with the gas phase imposed (as `Fluid.gas_branch_state`), without the
    equation of state's temperature-range check: a throat a few kelvin below the triple point (CO2 expanding from
    near its dome at low pressure) is evaluated on the smooth continuation of the gas branch, and flagged by its
    superheat, instead of failing the node."""
    if fluid.coolprop_name not in _GAS_BRANCH_STATES:
        CP = coolprop()
        state = CP.AbstractState("HEOS", fluid.coolprop_name)
        state.specify_phase(CP.iphase_gas)
        _GAS_BRANCH_STATES[fluid.coolprop_name] = state
    return _GAS_BRANCH_STATES[fluid.coolprop_name]


class _Isentrope:
    """Points of the isentrope s = s0 through an upstream (T0, rho0) on the gas branch of HEOS, by Newton's method in
    (T, ln rho) on p(T, rho) = p and s(T, rho) = s0, warm-started from the nearest point computed so far."""

    def __init__(self, fluid: Fluid, temperature, density):
        CP = coolprop()
        self.fluid = fluid
        state = fluid.gas_branch_state(temperature, density)
        self.pressure = state.p()
        self.enthalpy = state.hmass()
        self.entropy = state.smass()
        self.viscosity = _viscosity(state)
        self.sound_speed = math.sqrt(state.first_partial_deriv(CP.iP, CP.iDmass, CP.iSmass))
        self.known = [(1.0, temperature, density)]            # (pr, T, rho)

    def point(self, ratio):
        """(T, rho, h, c) at p = ratio p0 on the isentrope; ValueError if Newton fails."""
        CP = coolprop()
        _, temperature, density = min(self.known, key=lambda k: abs(k[0] - ratio))
        target = ratio * self.pressure
        log_density = math.log(density)
        state = _gas_branch(self.fluid)
        for _ in range(40):
            density = math.exp(log_density)
            state.update(CP.DmassT_INPUTS, density, temperature)
            dp_dt = state.first_partial_deriv(CP.iP, CP.iT, CP.iDmass)
            dp_dx = density * state.first_partial_deriv(CP.iP, CP.iDmass, CP.iT)
            heat_capacity = state.cvmass()
            r1 = state.p() / target - 1.0
            r2 = (state.smass() - self.entropy) / heat_capacity
            a11, a12 = dp_dt / target, dp_dx / target
            a21, a22 = 1.0 / temperature, -dp_dt / (density * heat_capacity)   # ds/dT = c_v/T, ds/dx = -(dp/dT)/rho
            determinant = a11 * a22 - a12 * a21
            step_t = (r1 * a22 - r2 * a12) / determinant
            step_x = (a11 * r2 - a21 * r1) / determinant
            step_t = max(-0.2 * temperature, min(0.2 * temperature, step_t))
            step_x = max(-0.5, min(0.5, step_x))
            temperature -= step_t
            log_density -= step_x
            if not (temperature > 0.0 and math.isfinite(log_density)):
                break
            if abs(step_t) < ISENTROPE_TOLERANCE * temperature and abs(step_x) < ISENTROPE_TOLERANCE:
                density = math.exp(log_density)
                state.update(CP.DmassT_INPUTS, density, temperature)
                sound = math.sqrt(state.first_partial_deriv(CP.iP, CP.iDmass, CP.iSmass))
                self.known.append((ratio, temperature, density))
                return temperature, density, state.hmass(), sound
        raise ValueError(f"no isentrope point at pr = {ratio!r}")

    def flux_squared(self, ratio):
        """G^2 = rho^2 2 (h0 - h) at p = ratio p0."""
        _, density, enthalpy, _ = self.point(ratio)
        return density * density * 2.0 * (self.enthalpy - enthalpy)

    def sonic_residual(self, ratio):
        """(h0 - h - c^2/2)/c0^2: zero at the throat of the choked flow (u = c); < 0 above it, > 0 below."""
        _, _, enthalpy, sound = self.point(ratio)
        return (self.enthalpy - enthalpy - 0.5 * sound * sound) / (self.sound_speed * self.sound_speed)

    def critical_ratio(self):
        """pr* = p*/p0 (brentq on the sonic condition, bracketed by SEARCH_RATIOS)."""
        from scipy.optimize import brentq
        upper = 1.0
        for ratio in SEARCH_RATIOS:
            if self.sonic_residual(ratio) > 0.0:
                return brentq(self.sonic_residual, ratio, upper, xtol=CRITICAL_RATIO_TOLERANCE, rtol=1e-14)
            upper = ratio
        raise ValueError("no sonic point above pr = 0.06")


def _viscosity(state):
    try:
        return state.viscosity()
    except ValueError:
        return math.nan


class _DewLine:
    """T_dew(p) of a fluid by interpolation in ln p on a dense table of QT flashes (PQ flashes fail just below the
    critical point for some fluids), for the throat-superheat status only (error well below 1 mK)."""

    POINTS = 4000

    def __init__(self, fluid: Fluid):
        self.fluid = fluid
        low = fluid.triple_temperature
        high = fluid.critical_temperature
        temperatures = []
        log_pressures = []
        for temperature in np.linspace(low, high, self.POINTS)[:-1]:
            try:
                pressure = fluid.dew_pressure(temperature)
            except ValueError:
                continue
            if log_pressures and not math.log(pressure) > log_pressures[-1]:
                continue
            temperatures.append(temperature)
            log_pressures.append(math.log(pressure))
        temperatures.append(high)
        log_pressures.append(math.log(fluid.critical_pressure))
        self.temperatures = np.array(temperatures)
        self.log_pressures = np.array(log_pressures)

    def superheat(self, temperature, pressure):
        """T - T_dew(p) below p_crit, T - T_crit at or above it (the property table's convention); below the
        lowest tabulated dew pressure (the triple point) T - T_triple."""
        log_pressure = math.log(pressure)
        if log_pressure >= self.log_pressures[-1]:
            return temperature - self.fluid.critical_temperature
        if log_pressure <= self.log_pressures[0]:
            return temperature - self.temperatures[0]
        return temperature - float(np.interp(log_pressure, self.log_pressures, self.temperatures))


def direct_mass_flux(fluid: Fluid, temperature_up, density_up, pressure_down):
    """G [kg/(s m^2)] from HEOS directly (gas branch, no table): the reference of the build check and of
    `nozzle_table_accuracy`. p_down >= p0 gives 0."""
    isentrope = _Isentrope(fluid, temperature_up, density_up)
    ratio = pressure_down / isentrope.pressure
    if ratio >= 1.0:
        return 0.0
    return math.sqrt(isentrope.flux_squared(max(ratio, isentrope.critical_ratio())))


def _node(fluid: Fluid, dew_line: _DewLine, temperature, density, sigmas):
    """(pr*, psi*^2, m[sigma], superheat[sigma], mu) of one upstream node; NaN where HEOS fails."""
    count = sigmas.size
    try:
        isentrope = _Isentrope(fluid, temperature, density)
        critical = isentrope.critical_ratio()
        choked = isentrope.flux_squared(critical)
        shape = np.empty(count)
        superheat = np.empty(count)
        for k, sigma in enumerate(sigmas):
            evaluated = min(sigma, 1.0 - LAST_SIGMA_OFFSET) if sigma > 0.0 else 0.0
            ratio = 1.0 - evaluated * (1.0 - critical)
            if evaluated == 0.0:
                shape[k] = 1.0
            else:
                fraction = isentrope.flux_squared(ratio) / choked
                shape[k] = (1.0 - fraction) / (1.0 - evaluated) ** 2
            throat_ratio = 1.0 - sigma * (1.0 - critical)
            throat_temperature = isentrope.point(throat_ratio)[0]
            superheat[k] = dew_line.superheat(throat_temperature, throat_ratio * isentrope.pressure)
        return (critical, choked / (isentrope.pressure * density), shape, superheat, isentrope.viscosity)
    except ValueError:
        return math.nan, math.nan, np.full(count, np.nan), np.full(count, np.nan), math.nan


def _python_flux(table: NozzleTable, temperature, density, pressure_up, pressure_down):
    """The table's flux from Python (the numba kernel)."""
    return real_gas_mass_flux(float(temperature), float(density), float(pressure_up), float(pressure_down), table)


def _accurate_cells(fluid: Fluid, table: NozzleTable, temperatures, log_densities):
    """True where the interpolated flux at the cell centre agrees with `direct_mass_flux` to CELL_TOLERANCE at
    sigma = 0.5 and in choked flow (pr = 0.1 pr* of the centre)."""
    accurate = np.zeros((temperatures.size - 1, log_densities.size - 1), dtype=np.bool_)
    check_table = table._replace(accurate_cell=np.ones_like(accurate),
                                 dome_log_density_limit=np.full_like(table.dome_log_density_limit, np.inf))
    for i in range(temperatures.size - 1):
        temperature = 0.5 * (temperatures[i] + temperatures[i + 1])
        for j in range(log_densities.size - 1):
            corners = table.critical_ratio[i:i + 2, j:j + 2]
            if not np.all(np.isfinite(corners)) or not np.all(np.isfinite(table.shape_factor[i:i + 2, j:j + 2])):
                continue
            density = math.exp(0.5 * (log_densities[j] + log_densities[j + 1]))
            try:
                isentrope = _Isentrope(fluid, temperature, density)
                critical = isentrope.critical_ratio()
                worst = 0.0
                for ratio in (1.0 - 0.5 * (1.0 - critical), 0.1 * critical):
                    exact = math.sqrt(isentrope.flux_squared(max(ratio, critical)))
                    flux, _ = _python_flux(check_table, temperature, density, isentrope.pressure,
                                           ratio * isentrope.pressure)
                    worst = max(worst, abs(flux / exact - 1.0))
            except ValueError:
                continue
            accurate[i, j] = worst <= CELL_TOLERANCE
    return accurate


def _check_ratio_nodes(value):
    value = _check_count("ratio_nodes", value)
    return value


def build_nozzle_table(fluid: Fluid, envelope: Envelope, temperature_nodes=DEFAULT_TEMPERATURE_NODES,
                       log_density_nodes=DEFAULT_LOG_DENSITY_NODES, ratio_nodes=DEFAULT_RATIO_NODES,
                       two_phase=False) -> NozzleTable:
    """Evaluate the table's nodes from CoolProp HEOS and check every cell (no disk cache; `nozzle_table_for`
    caches). `two_phase`: also build the HEM part for wet upstream states (about 1 s) and switch it on."""
    envelope = _check_envelope(fluid, envelope)
    temperature_nodes = _check_count("temperature_nodes", temperature_nodes)
    log_density_nodes = _check_count("log_density_nodes", log_density_nodes)
    ratio_nodes = _check_ratio_nodes(ratio_nodes)
    temperatures = np.linspace(envelope.temperature_min, envelope.temperature_max, temperature_nodes)
    log_densities = np.linspace(math.log(envelope.density_min), math.log(envelope.density_max), log_density_nodes)
    sigmas = np.linspace(0.0, 1.0, ratio_nodes)
    critical = np.empty((temperature_nodes, log_density_nodes))
    choked = np.empty_like(critical)
    viscosity = np.empty_like(critical)
    shape = np.empty((temperature_nodes, log_density_nodes, ratio_nodes))
    superheat = np.empty_like(shape)
    dew_line = _DewLine(fluid)
    for i, temperature in enumerate(temperatures):
        for j, log_density in enumerate(log_densities):
            (critical[i, j], choked[i, j], shape[i, j], superheat[i, j],
             viscosity[i, j]) = _node(fluid, dew_line, temperature, math.exp(log_density), sigmas)
    dome_cells = DOME_CELLS
    dome_temperatures = np.linspace(envelope.temperature_min, envelope.temperature_max, dome_cells + 1)
    limits = np.array([dome_log_density_limit(fluid, t, envelope.superheat_margin) for t in dome_temperatures])
    table = NozzleTable(
        temperature_min=float(temperatures[0]), temperature_max=float(temperatures[-1]),
        inverse_temperature_step=float(1.0 / (temperatures[1] - temperatures[0])),
        log_density_min=float(log_densities[0]), log_density_max=float(log_densities[-1]),
        inverse_log_density_step=float(1.0 / (log_densities[1] - log_densities[0])),
        inverse_sigma_step=float(ratio_nodes - 1),
        inverse_dome_step=float(dome_cells / (envelope.temperature_max - envelope.temperature_min)),
        superheat_margin=envelope.superheat_margin,
        critical_ratio=critical, choked_flux_factor=choked, shape_factor=shape, throat_superheat=superheat,
        viscosity=viscosity, dome_log_density_limit=np.minimum(limits[:-1], limits[1:]),
        accurate_cell=np.ones((temperature_nodes - 1, log_density_nodes - 1), dtype=np.bool_))
    table = table._replace(accurate_cell=_accurate_cells(fluid, table, temperatures, log_densities))
    return with_two_phase(_with_dome(fluid, table, envelope, sigmas), True) if two_phase else table


def _with_dome(fluid: Fluid, table: NozzleTable, envelope: Envelope, sigmas) -> NozzleTable:
    """`table` with its saturation line and the HEM part for upstream states inside the dome
    (thermo.two_phase_nozzle), each dome cell checked at its centre; unchanged if the envelope holds no dome."""
    line = build_saturation_line(fluid, envelope.temperature_min, envelope.temperature_max)
    if not line.temperature_max > line.temperature_min:
        return table
    critical, choked, shape = build_dome_nozzle(fluid, line.temperature_min, line.temperature_max, sigmas,
                                                LAST_SIGMA_OFFSET)
    table = table._replace(
        saturation_temperature_min=line.temperature_min, saturation_temperature_max=line.temperature_max,
        inverse_saturation_step=line.inverse_temperature_step,
        dome_inverse_temperature_step=(critical.shape[0] - 1) / (line.temperature_max - line.temperature_min),
        dome_inverse_quality_step=float(critical.shape[1] - 1), saturation_nodes=line.nodes,
        dome_critical_ratio=critical, dome_choked_flux_factor=choked, dome_shape_factor=shape,
        dome_accurate_cell=np.ones((critical.shape[0] - 1, critical.shape[1] - 1), dtype=np.bool_))
    return table._replace(dome_accurate_cell=_accurate_dome_cells(fluid, table))


def _accurate_dome_cells(fluid: Fluid, table: NozzleTable):
    """True where the interpolated HEM flux at the cell centre agrees with the direct one
    (thermo.two_phase_nozzle.EquilibriumIsentrope) to CELL_TOLERANCE at sigma = 0.5 and choked (pr = 0.1 pr*)."""
    rows, columns = table.dome_critical_ratio.shape
    accurate = np.zeros((rows - 1, columns - 1), dtype=np.bool_)
    check_table = with_two_phase(table._replace(dome_accurate_cell=np.ones_like(accurate)), True)
    for i in range(rows - 1):
        temperature = table.saturation_temperature_min + (i + 0.5) / table.dome_inverse_temperature_step
        for j in range(columns - 1):
            if not (np.all(np.isfinite(table.dome_critical_ratio[i:i + 2, j:j + 2]))
                    and np.all(np.isfinite(table.dome_shape_factor[i:i + 2, j:j + 2]))):
                continue
            try:
                isentrope = EquilibriumIsentrope(fluid, temperature, (j + 0.5) / table.dome_inverse_quality_step)
                critical = isentrope.critical_ratio()
                worst = 0.0
                for ratio in (1.0 - 0.5 * (1.0 - critical), 0.1 * critical):
                    exact = math.sqrt(isentrope.flux_squared(max(ratio, critical)))
                    flux, status = _python_flux(check_table, temperature, isentrope.density, isentrope.pressure,
                                                ratio * isentrope.pressure)
                    worst = max(worst, abs(flux / exact - 1.0)) if status == STATUS_OK else math.inf
            except ValueError:
                continue
            accurate[i, j] = worst <= CELL_TOLERANCE
    return accurate


def with_two_phase(table: NozzleTable, two_phase: bool) -> NozzleTable:
    """The same table with upstream states beyond the dew line taken by the HEM part (two_phase) or refused within
    the superheat margin of the dome (STATUS_NEAR_SATURATION, as before: the default)."""
    return table._replace(two_phase=1.0 if two_phase else 0.0)


def nozzle_table_arrays(table: NozzleTable):
    """(header, critical_ratio, choked_flux_factor, shape_factor, throat_superheat, viscosity,
    dome_log_density_limit, accurate_cell): the arguments of `nozzle_table_from_arrays`; header is a float64
    array of the nine scalar fields in NozzleTable's order."""
    header = np.array([getattr(table, name) for name in SCALAR_FIELDS], dtype=np.float64)
    return (header,) + tuple(getattr(table, name) for name in ARRAY_FIELDS)


def nozzle_table_envelope(table: NozzleTable) -> Envelope:
    """The upstream (T, rho) rectangle and margin a table covers."""
    return Envelope(table.temperature_min, table.temperature_max, math.exp(table.log_density_min),
                    math.exp(table.log_density_max), table.superheat_margin)


# ----------------------------------------------------------------------------------------------------------
# disk cache

def _cache_key(coolprop_name: str, envelope: Envelope, temperature_nodes, log_density_nodes, ratio_nodes,
               two_phase) -> str:
    """Everything the table's content depends on, as text (floats by repr: exact); no CoolProp import."""
    return "|".join([f"nozzle format {FORMAT_VERSION}", f"fluid {coolprop_name}", f"two-phase {bool(two_phase)}",
                     "envelope " + " ".join(repr(float(v)) for v in envelope),
                     f"nodes {temperature_nodes}x{log_density_nodes}x{ratio_nodes}", f"coolprop {coolprop_version()}",
                     f"dome cells {DOME_CELLS}", f"cell tolerance {CELL_TOLERANCE!r}",
                     f"isentrope tolerance {ISENTROPE_TOLERANCE!r}", f"last sigma {LAST_SIGMA_OFFSET!r}",
                     f"saturation step {DEFAULT_SATURATION_STEP!r}", f"saturation tolerance {SATURATION_TOLERANCE!r}",
                     f"HEM nodes {DEFAULT_DOME_TEMPERATURE_NODES}x{DEFAULT_QUALITY_NODES}"])


def _counts(temperature_nodes, log_density_nodes, ratio_nodes):
    return (_check_count("temperature_nodes", temperature_nodes), _check_count("log_density_nodes", log_density_nodes),
            _check_ratio_nodes(ratio_nodes))


def nozzle_table_path(fluid, envelope: Envelope, temperature_nodes=DEFAULT_TEMPERATURE_NODES,
                      log_density_nodes=DEFAULT_LOG_DENSITY_NODES, ratio_nodes=DEFAULT_RATIO_NODES,
                      cache_dir=None, two_phase=False) -> Path:
    """The cache file: <cache dir>/nozzle-<fluid>-<hash of the key>.npz (thermo.disk_cache). `fluid`: a Fluid, or
    anything naming one by its canonical `coolprop_name` (a thermo.operating_point.OperatingPoint)."""
    key = _cache_key(fluid.coolprop_name, _checked_envelope(envelope),
                     *_counts(temperature_nodes, log_density_nodes, ratio_nodes), two_phase)
    return cache_path(f"nozzle-{fluid.coolprop_name}", key, ".npz", cache_dir)


def _load(path: Path, key: str, temperature_nodes, log_density_nodes, ratio_nodes) -> NozzleTable:
    """Read a cached table; ValueError unless it is complete and carries `key`."""
    with np.load(path, allow_pickle=False) as data:
        if str(data["key"]) != key:
            raise ValueError("the file belongs to another key")
        fields = {name: data[name] for name in NozzleTable._fields}
    table = NozzleTable(**{name: float(value) if name in SCALAR_FIELDS else value for name, value in fields.items()})
    grid = (temperature_nodes, log_density_nodes)
    if (table.critical_ratio.shape != grid or table.choked_flux_factor.shape != grid
            or table.viscosity.shape != grid
            or table.shape_factor.shape != grid + (ratio_nodes,)
            or table.throat_superheat.shape != grid + (ratio_nodes,)
            or table.accurate_cell.shape != (temperature_nodes - 1, log_density_nodes - 1)
            or table.accurate_cell.dtype != np.bool_
            or table.dome_log_density_limit.shape != (DOME_CELLS,)
            or table.saturation_nodes.ndim != 3 or table.saturation_nodes.shape[1:] != (len(SATURATION_QUANTITIES), 2)
            or table.dome_critical_ratio.ndim != 2
            or table.dome_choked_flux_factor.shape != table.dome_critical_ratio.shape
            or table.dome_shape_factor.ndim != 3
            or table.dome_shape_factor.shape[:2] != table.dome_critical_ratio.shape
            or table.dome_accurate_cell.dtype != np.bool_
            or table.dome_accurate_cell.shape != tuple(n - 1 for n in table.dome_critical_ratio.shape)):
        raise ValueError("array shapes do not match the key")
    return table


def nozzle_table_for(fluid, envelope: Envelope, temperature_nodes=DEFAULT_TEMPERATURE_NODES,
                     log_density_nodes=DEFAULT_LOG_DENSITY_NODES, ratio_nodes=DEFAULT_RATIO_NODES,
                     cache_dir=None, two_phase=False) -> NozzleTable:
    """The real-gas nozzle table of `fluid` over `envelope` (e.g. the operating point's), loaded from the disk cache
    or built from HEOS and cached (thermo.disk_cache: atomic write; an unreadable or mismatching file is rebuilt
    with a warning, never trusted). `fluid`: a Fluid, or anything naming one by its canonical `coolprop_name` (an
    OperatingPoint): the Fluid, and with it CoolProp, is then made only if the table must be built. The file name
    hashes the fluid, envelope, grid, CoolProp version and FORMAT_VERSION. `two_phase`: a table with the HEM
    part for wet upstream states, switched on (its own file: the part costs about 1 s to build)."""
    envelope = _checked_envelope(envelope)
    counts = _counts(temperature_nodes, log_density_nodes, ratio_nodes)
    key = _cache_key(fluid.coolprop_name, envelope, *counts, two_phase)
    return load_or_build(
        nozzle_table_path(fluid, envelope, *counts, cache_dir=cache_dir, two_phase=two_phase),
        lambda stored: _load(stored, key, *counts),
        lambda: build_nozzle_table(fluid if isinstance(fluid, Fluid) else Fluid(fluid.coolprop_name), envelope,
                                   *counts, two_phase),
        lambda stream, table: np.savez(stream, key=np.array(key), **table._asdict()), "nozzle table")


# ----------------------------------------------------------------------------------------------------------
# messages

def describe_nozzle_status(status, temperature, density, table: NozzleTable, fluid: Fluid | None = None,
                           state="upstream state") -> str:
    """A readable sentence for a status code of `real_gas_mass_flux`: which state, why, and what to do."""
    envelope = nozzle_table_envelope(table)
    where = f"{state} (T = {float(temperature):.6g} K, rho = {float(density):.6g} kg/m^3)"
    if status == STATUS_THROAT_NEAR_SATURATION:
        return (f"{where}: the isentropic expansion to the throat comes within {envelope.superheat_margin:g} K of "
                "the two-phase dome or enters it; the flux is the gas-branch (metastable vapour) continuation, "
                "not an equilibrium two-phase expansion (docs/model.md §7.4)")
    if status == STATUS_INACCURATE_CELL:
        return (f"{where} lies in a nozzle-table cell that missed its accuracy check against HEOS (relative "
                f"flux tolerance {CELL_TOLERANCE:g}) or holds a node HEOS could not evaluate; use a finer grid")
    if status == STATUS_INVALID_STATE:
        return (f"{where}: not a valid nozzle inlet: temperature, density and pressure must be positive numbers "
                "and the downstream pressure a number")
    shared = envelope_status_text(status, where, envelope, "nozzle table", "the nozzle's inlet", fluid,
                                  temperature, density)
    if shared is not None:
        return shared
    if status == STATUS_OK:
        return f"{where} is inside the nozzle table"
    return f"{where}: unknown nozzle-table status {status!r}"
