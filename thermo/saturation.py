"""The saturation line of a fluid as a 1-D table in T, and the homogeneous equilibrium mixture (HEM) inside the
two-phase dome that it gives (docs/model.md §7.3.1), evaluated in numba.

Inside the dome at (T, rho), T < T_crit, with v = 1/rho between the saturated liquid and vapour volumes v_l(T) and
v_v(T), the equilibrium mixture has the vapour quality x, pressure, enthalpy and internal energy

    x = (v - v_l)/(v_v - v_l),    p = p_sat(T),    h = h_l + x (h_v - h_l),    u = u_l + x (u_v - u_l)

and, differentiating at constant v (' = d/dT along the saturation line):

    (dx/dT)_v = -(v_l' + x (v_v' - v_l'))/(v_v - v_l)
    c_v = (du/dT)_v = u_l' + x (u_v' - u_l') + (dx/dT)_v (u_v - u_l)
    (dp/dT)_rho = p_sat'(T)                            (Clapeyron: (s_v - s_l)/(v_v - v_l))
    (dp/drho)_T = 0

The table holds at nodes uniform in T the seven quantities p_sat, v_v, v_l, h_v, h_l, u_v, u_l and their exact
derivatives along the saturation line (CoolProp's `first_saturation_deriv`, the Clapeyron equation and the
single-phase Helmholtz derivatives of each saturated phase), and interpolates each by cubic Hermite in T; the
derivatives above are those of the interpolant, so c_v is the exact (dU/dT)_V of the interpolated u.

CoolProp HEOS gives p, h and Q of a two-phase DmassT_INPUTS state, but its `cvmass()` there is not the mixture's
(dU/dT)_V (R134a at 280 K, 30 kg/m^3: 863 J/(kg K) against 4392 from a central difference of u at fixed rho), nor is
its `first_partial_deriv(P, T, Dmass)` (3422 against dp_sat/dT = 12765 Pa/K): the tests check against differences
of u and p at fixed rho instead.

Build check: at the middle of every interval the interpolated p_sat, v_v, v_l, h_v, h_l and the mixture's c_v at
x = 0.5 are compared with HEOS (c_v from the exact saturation derivatives at that temperature); the tabulated range
ends before the first interval, counted from the cold end, that misses SATURATION_TOLERANCE: the derivatives along
the saturation line grow as (T_crit - T)^-1/2 towards the critical point, where no fixed T grid keeps up. Above
that temperature the property table falls back to refusing states near the dome (thermo.property_table).

Limits of the model (docs/model.md §7.3.1): equilibrium between the phases at every instant (no metastable vapour,
no delayed condensation or flashing), one temperature and no slip between liquid and vapour, no liquid-slugging
forces on the vanes, and no dome within the last kelvins below the critical point.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .fluid import Fluid, coolprop
from ..kernels.kernel import kernel

SATURATION_QUANTITIES = ("pressure", "vapour_volume", "liquid_volume", "vapour_enthalpy", "liquid_enthalpy",
                         "vapour_energy", "liquid_energy")
PRESSURE, VAPOUR_VOLUME, LIQUID_VOLUME, VAPOUR_ENTHALPY, LIQUID_ENTHALPY, VAPOUR_ENERGY, LIQUID_ENERGY = range(7)
DEFAULT_SATURATION_STEP = 0.2          # K between nodes
SATURATION_TOLERANCE = (1e-7, 1e-5)    # relative: (p_sat, v_v, v_l, h_v, h_l), c_v of the mixture at x = 0.5


class SaturationLine(NamedTuple):
    """The tabulated saturation line (module docstring): nodes (n, 7 quantities, 2) hold f and T_step * df/dT."""
    temperature_min: float          # K, first node
    temperature_max: float          # K, end of the last accepted interval (<= last node)
    inverse_temperature_step: float  # 1/K
    nodes: np.ndarray


# ----------------------------------------------------------------------------------------------------------
# numba kernels

@kernel
def saturation_quantity(quantity, temperature, temperature_min, inverse_step, nodes):
    """(f, df/dT) of one SATURATION_QUANTITIES index at T by cubic Hermite interpolation; T must lie in the table
    (the caller checks)."""
    u = (temperature - temperature_min) * inverse_step
    i = min(max(int(u), 0), nodes.shape[0] - 2)
    t = u - i
    h1 = t * t * (3.0 - 2.0 * t)
    g0 = t * (1.0 - t) * (1.0 - t)
    g1 = t * t * (t - 1.0)
    dh1 = 6.0 * t * (1.0 - t)
    dg0 = (1.0 - t) * (1.0 - 3.0 * t)
    dg1 = t * (3.0 * t - 2.0)
    f0 = nodes[i, quantity, 0]
    f1 = nodes[i + 1, quantity, 0]
    d0 = nodes[i, quantity, 1]
    d1 = nodes[i + 1, quantity, 1]
    value = f0 + h1 * (f1 - f0) + g0 * d0 + g1 * d1
    slope = (dh1 * (f1 - f0) + dg0 * d0 + dg1 * d1) * inverse_step
    return value, slope


@kernel
def mixture_state(temperature, volume, temperature_min, inverse_step, nodes):
    """(x, h_l, h_v, c_v, dp_sat/dT) of the equilibrium mixture at (T, v) (module docstring); v_l < v < v_v and T
    inside the table are the caller's to check. p_sat and h_v are returned separately by the caller's choice of
    source (thermo.property_table anchors them on its gas branch at the dew line)."""
    v_v, dv_v = saturation_quantity(VAPOUR_VOLUME, temperature, temperature_min, inverse_step, nodes)
    v_l, dv_l = saturation_quantity(LIQUID_VOLUME, temperature, temperature_min, inverse_step, nodes)
    h_v, _ = saturation_quantity(VAPOUR_ENTHALPY, temperature, temperature_min, inverse_step, nodes)
    h_l, _ = saturation_quantity(LIQUID_ENTHALPY, temperature, temperature_min, inverse_step, nodes)
    u_v, du_v = saturation_quantity(VAPOUR_ENERGY, temperature, temperature_min, inverse_step, nodes)
    u_l, du_l = saturation_quantity(LIQUID_ENERGY, temperature, temperature_min, inverse_step, nodes)
    _, dp = saturation_quantity(PRESSURE, temperature, temperature_min, inverse_step, nodes)
    width = v_v - v_l
    quality = (volume - v_l) / width
    quality_slope = -(dv_l + quality * (dv_v - dv_l)) / width
    heat_capacity = du_l + quality * (du_v - du_l) + quality_slope * (u_v - u_l)
    return quality, h_l, h_v, heat_capacity, dp


# ----------------------------------------------------------------------------------------------------------
# building

def saturation_node(fluid: Fluid, temperature):
    """(7, 2): the seven quantities and their exact d/dT along the saturation line at T (T_triple <= T < T_crit)."""
    CP = coolprop()
    state = fluid.saturated_state(temperature, 1.0)
    p = state.p()
    dp = state.first_saturation_deriv(CP.iP, CP.iT)
    vapour = _phase_row(state)
    liquid = _phase_row(fluid.saturated_state(temperature, 0.0))
    return np.array([[p, dp], vapour[0], liquid[0], vapour[1], liquid[1], vapour[2], liquid[2]])


def _phase_row(state):
    """((v, dv/dT), (h, dh/dT), (u, du/dT)) of a saturated phase (an AbstractState at Q = 0 or 1)."""
    CP = coolprop()
    density = state.rhomass()
    density_slope = state.first_saturation_deriv(CP.iDmass, CP.iT)
    return ((1.0 / density, -density_slope / density ** 2),
            (state.hmass(), state.first_saturation_deriv(CP.iHmass, CP.iT)),
            (state.umass(), state.first_saturation_deriv(CP.iUmass, CP.iT)))


def exact_mixture(fluid: Fluid, temperature, quality):
    """(p, v, h, c_v) of the equilibrium mixture at (T, x) from HEOS and its exact saturation derivatives (the
    formulas of the module docstring): the reference of the build check."""
    node = saturation_node(fluid, temperature)
    values, slopes = node[:, 0], node[:, 1]
    width = values[VAPOUR_VOLUME] - values[LIQUID_VOLUME]
    quality_slope = -(slopes[LIQUID_VOLUME] + quality * (slopes[VAPOUR_VOLUME] - slopes[LIQUID_VOLUME])) / width
    heat_capacity = (slopes[LIQUID_ENERGY] + quality * (slopes[VAPOUR_ENERGY] - slopes[LIQUID_ENERGY])
                     + quality_slope * (values[VAPOUR_ENERGY] - values[LIQUID_ENERGY]))
    return (values[PRESSURE], values[LIQUID_VOLUME] + quality * width,
            values[LIQUID_ENTHALPY] + quality * (values[VAPOUR_ENTHALPY] - values[LIQUID_ENTHALPY]), heat_capacity)


def build_saturation_line(fluid: Fluid, temperature_min, temperature_max,
                          temperature_step=DEFAULT_SATURATION_STEP) -> SaturationLine:
    """Tabulate the saturation line from max(T_min, T_triple) towards min(T_max, T_crit) and cut it before the
    first interval that misses SATURATION_TOLERANCE (module docstring). temperature_max of the result is the
    accepted end; with no accepted interval it equals temperature_min (the dome branch is then never used)."""
    low = max(float(temperature_min), fluid.triple_temperature)
    high = min(float(temperature_max), fluid.critical_temperature)
    if not high - low > 2.0 * temperature_step:          # no dome inside the range (e.g. air above 133 K)
        return SaturationLine(low, low, 1.0, np.zeros((2, len(SATURATION_QUANTITIES), 2)))
    count = max(2, int(math.ceil((high - low) / temperature_step)) + 1)
    temperatures = np.linspace(low, high, count)
    if temperatures[-1] >= fluid.critical_temperature:
        temperatures = temperatures[:-1]                       # no saturation state at T_crit itself
        count -= 1
    step = temperatures[1] - temperatures[0]
    nodes = np.full((count, len(SATURATION_QUANTITIES), 2), np.nan)
    for i, temperature in enumerate(temperatures):
        try:
            node = saturation_node(fluid, temperature)
        except ValueError:
            break
        nodes[i, :, 0] = node[:, 0]
        nodes[i, :, 1] = step * node[:, 1]
    accepted_end = _accepted_end(fluid, temperatures, nodes)
    return SaturationLine(float(temperatures[0]), float(temperatures[accepted_end]), float(1.0 / step), nodes)


def _accepted_end(fluid: Fluid, temperatures, nodes) -> int:
    """Index of the last node before the first interval whose middle misses SATURATION_TOLERANCE."""
    inverse_step = 1.0 / (temperatures[1] - temperatures[0])
    value_tolerance, heat_capacity_tolerance = SATURATION_TOLERANCE
    for i in range(temperatures.size - 1):
        middle = 0.5 * (temperatures[i] + temperatures[i + 1])
        if not np.all(np.isfinite(nodes[i:i + 2])):
            return i
        try:
            exact = saturation_node(fluid, middle)[:5, 0]
            p, v, _, heat_capacity = exact_mixture(fluid, middle, 0.5)
        except ValueError:
            return i
        interpolated = np.array([saturation_quantity(q, middle, temperatures[0], inverse_step, nodes)[0]
                                 for q in range(5)])
        mixture = mixture_state(middle, v, temperatures[0], inverse_step, nodes)
        if (np.max(np.abs(interpolated / exact - 1.0)) > value_tolerance
                or abs(mixture[3] / heat_capacity - 1.0) > heat_capacity_tolerance):
            return i
    return temperatures.size - 1
