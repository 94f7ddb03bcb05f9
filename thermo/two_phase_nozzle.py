"""Isentropic nozzle flow from an upstream state inside the two-phase dome: the homogeneous equilibrium model (HEM),
tabulated from CoolProp HEOS for thermo.real_gas_nozzle (docs/model.md §7.4.1).

Model: liquid and vapour move together (no slip) and stay in phase equilibrium along the expansion, so the mixture
follows the equilibrium isentrope s = s0 of the upstream state (T0, x0) and

    G(p) = rho(p, s0) sqrt(2 (h0 - h(p, s0))),     G = G(max(p_down, p*)),   p* = argmax_p G(p)

with rho, h from CoolProp's (p, s) flash with its own phase determination (the expansion may leave the dome for
a dry fluid). This is the choice consistent with the chamber's equilibrium mixture (thermo.saturation); the
homogeneous frozen model (liquid fraction fixed, vapour expanding alone) would be simpler but would let a chamber
and its outflow disagree about the phases. p* is found by maximising G (the equilibrium speed of sound jumps at
the phase boundary, so the sonic condition u = c is not a smooth root).

Table: the same parametrisation as the gas nozzle (pr*, psi*^2 = G*^2/(p0 rho0), shape factor m(sigma)) at nodes
uniform in T0 over the property table's saturation line and in x0 on [0, 1]; interpolated bilinearly in (T0, x0)
and linearly in sigma. Build check: at every cell centre, the flux at sigma = 0.5 and choked is compared with the
direct HEM value; a cell worse than CELL_TOLERANCE is refused (STATUS_INACCURATE_CELL).

At the dew line (x0 = 1) the gas side of the nozzle table expands the saturated vapour on the gas branch (a
metastable throat, status 8) while this side condenses it in equilibrium: measured for R134a the choked flux of
HEM is 0.08-0.42 % below the metastable one between 250 and 350 K (0.02-0.17 % at pr = 0.9), up to 2 % near the
end of the saturation line (CO2: 13 %): the step in the flow across the dew line (benchmarks/bench_fluid_tables.py).
"""
from __future__ import annotations

import math

import numpy as np

from .fluid import Fluid, coolprop

DEFAULT_DOME_TEMPERATURE_NODES = 48
DEFAULT_QUALITY_NODES = 21                  # x0 on [0, 1]
LOWEST_CRITICAL_RATIO = 0.06                # the search interval of p*/p0, as the gas nozzle's SEARCH_RATIOS
CRITICAL_RATIO_TOLERANCE = 1e-10            # on pr* (G is flat there: its error ~ (dpr)^2)


class EquilibriumIsentrope:
    """The equilibrium isentrope through an upstream (T0, x0) inside the dome, from CoolProp HEOS (module docstring)."""

    def __init__(self, fluid: Fluid, temperature, quality):
        state = fluid.saturated_state(temperature, quality)
        self.fluid = fluid
        self.pressure = state.p()
        self.density = state.rhomass()
        self.enthalpy = state.hmass()
        self.entropy = state.smass()
        CP = coolprop()
        self._state = CP.AbstractState("HEOS", fluid.coolprop_name)
        # the expansion cannot go below the triple point (CO2 near its triple point would reach solid states)
        self.lowest_ratio = max(LOWEST_CRITICAL_RATIO,
                                fluid.dew_pressure(fluid.triple_temperature) / self.pressure + 1e-6)

    def flux_squared(self, ratio):
        """G^2 = rho^2 2 (h0 - h) at p = ratio p0 on the equilibrium isentrope; ValueError if HEOS fails."""
        CP = coolprop()
        try:
            self._state.update(CP.PSmass_INPUTS, ratio * self.pressure, self.entropy)
        except ValueError as error:
            raise ValueError(f"no equilibrium isentrope point at pr = {ratio!r}: {error}") from None
        density = self._state.rhomass()
        return density * density * 2.0 * (self.enthalpy - self._state.hmass())

    def critical_ratio(self):
        """pr* = p*/p0, the maximum of G on (LOWEST_CRITICAL_RATIO or the triple-point pressure's ratio, 1)."""
        from scipy.optimize import minimize_scalar
        result = minimize_scalar(lambda ratio: -self.flux_squared(ratio), bounds=(self.lowest_ratio, 1.0 - 1e-6),
                                 method="bounded", options=dict(xatol=CRITICAL_RATIO_TOLERANCE))
        if not (result.success and self.lowest_ratio + 1e-6 < result.x):
            raise ValueError(f"no choked flow above pr = {self.lowest_ratio:.3g}")
        return float(result.x)


def direct_two_phase_mass_flux(fluid: Fluid, temperature, quality, pressure_down):
    """G [kg/(s m^2)] of the HEM expansion from (T0, x0) to p_down, from HEOS directly (no table): the reference of
    the build check and the tests. p_down >= p0 gives 0."""
    isentrope = EquilibriumIsentrope(fluid, temperature, quality)
    ratio = pressure_down / isentrope.pressure
    if ratio >= 1.0:
        return 0.0
    return math.sqrt(isentrope.flux_squared(max(ratio, isentrope.critical_ratio())))


def _node(fluid: Fluid, temperature, quality, sigmas, last_sigma_offset):
    """(pr*, psi*^2, m[sigma]) of one upstream node; NaN where HEOS fails."""
    try:
        isentrope = EquilibriumIsentrope(fluid, temperature, quality)
        critical = isentrope.critical_ratio()
        choked = isentrope.flux_squared(critical)
        shape = np.ones(sigmas.size)
        for k, sigma in enumerate(sigmas):
            if sigma > 0.0:
                evaluated = min(sigma, 1.0 - last_sigma_offset)
                fraction = isentrope.flux_squared(1.0 - evaluated * (1.0 - critical)) / choked
                shape[k] = (1.0 - fraction) / (1.0 - evaluated) ** 2
        return critical, choked / (isentrope.pressure * isentrope.density), shape
    except ValueError:
        return math.nan, math.nan, np.full(sigmas.size, np.nan)


def build_dome_nozzle(fluid: Fluid, temperature_min, temperature_max, sigmas, last_sigma_offset,
                      temperature_nodes=DEFAULT_DOME_TEMPERATURE_NODES, quality_nodes=DEFAULT_QUALITY_NODES):
    """(critical ratio (n_T, n_x), choked flux factor (n_T, n_x), shape factor (n_T, n_x, n_sigma)) at nodes uniform
    in T on [T_min, T_max] and in x on [0, 1] (the cell check is thermo.real_gas_nozzle's, which owns the kernel)."""
    temperatures = np.linspace(temperature_min, temperature_max, temperature_nodes)
    qualities = np.linspace(0.0, 1.0, quality_nodes)
    critical = np.empty((temperature_nodes, quality_nodes))
    choked = np.empty_like(critical)
    shape = np.empty((temperature_nodes, quality_nodes, sigmas.size))
    for i, temperature in enumerate(temperatures):
        for j, quality in enumerate(qualities):
            critical[i, j], choked[i, j], shape[i, j] = _node(fluid, temperature, quality, sigmas, last_sigma_offset)
    return critical, choked, shape
