"""The state of a closed, well-mixed volume of refrigerant from its mass and internal energy, on the property table
through the two-phase dome (docs/model.md §16.1), evaluated in numba.

A volume V holding the mass M and the internal energy U has rho = M/V and u = U/M. Its temperature solves

    u(T, rho) = h(T, rho) - p(T, rho)/rho = U/M          (Newton in T at fixed rho: du/dT|_rho = c_v)

on the table's interpolant (thermo.property_table): a gas state, or inside the dome the homogeneous equilibrium
mixture of vapour quality x with p = p_sat(T) (thermo.saturation). The saturated phases at T, which the loop's
outlet laws draw from (docs/model.md §16.2), are v_l, h_l from the saturation line and v_v = 1/rho_v, h_v from the
table's gas branch at the dew point (T, rho_v), where the table anchors its mixture: so h = h_l + x (h_v - h_l)
holds exactly between the phases and the mixture.

Status: STATUS_OK (0), or the property table's code of the state that stopped the solve (thermo.property_table),
or STATUS_NOT_CONVERGED.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from ..kernels.kernel import kernel
from .boundary_states import STATUS_NOT_CONVERGED
from .property_table import STATUS_OK, table_quality, table_state
from .saturation import LIQUID_ENTHALPY, LIQUID_VOLUME, VAPOUR_VOLUME, saturation_quantity

NEWTON_ITERATIONS = 100
TEMPERATURE_TOLERANCE = 1e-11         # relative step in T that ends the Newton solve


class VolumeState(NamedTuple):
    """A volume's state (module docstring); the saturated-phase fields are those at T and are NaN for a gas above
    the saturation line's end."""
    temperature: float          # K
    pressure: float             # Pa
    density: float              # kg/m^3
    enthalpy: float             # J/kg, of the contents
    heat_capacity: float        # c_v = du/dT at constant volume, J/(kg K)
    quality: float              # vapour mass fraction, 1 for a gas
    liquid_volume: float        # v_l, m^3/kg
    vapour_volume: float        # v_v, m^3/kg
    liquid_enthalpy: float      # h_l, J/kg
    vapour_enthalpy: float      # h_v, J/kg
    status: int


@kernel
def volume_temperature(density, energy, guess, table):
    """(T, status): u(T, rho) = energy [J/kg] at rho = density from T = guess (module docstring). u rises with T
    (c_v > 0), so each residual's sign tightens a bracket; Newton steps (held to 10 % of T) that leave the bracket
    are replaced by its midpoint: c_v jumps at the dew line, where plain Newton can cycle across the kink."""
    temperature = guess
    low, high = 0.0, math.inf
    for _ in range(NEWTON_ITERATIONS):
        state = table_state(temperature, density, table)
        if state.status != STATUS_OK:
            return math.nan, state.status
        residual = state.enthalpy - state.pressure / density - energy
        if residual > 0.0:
            high = min(high, temperature)
        else:
            low = max(low, temperature)
        step = residual / state.heat_capacity_v
        step = max(-0.1 * temperature, min(0.1 * temperature, step))
        target = temperature - step
        if not low < target < high and high < math.inf and low > 0.0:
            target = 0.5 * (low + high)
        if abs(target - temperature) <= TEMPERATURE_TOLERANCE * temperature:
            return target, STATUS_OK
        temperature = target
    return math.nan, STATUS_NOT_CONVERGED


@kernel
def volume_state(mass, energy, volume, guess, table):
    """The VolumeState of `mass` [kg] with internal energy `energy` [J] in `volume` [m^3], from the temperature
    guess [K]; the fields are NaN if status != 0."""
    density = mass / volume
    temperature, status = volume_temperature(density, energy / mass, guess, table)
    nan = math.nan
    if status != STATUS_OK:
        return VolumeState(nan, nan, density, nan, nan, nan, nan, nan, nan, nan, status)
    state = table_state(temperature, density, table)
    quality = table_quality(temperature, density, table)
    liquid_volume = vapour_volume = liquid_enthalpy = vapour_enthalpy = nan
    if (table.saturation_temperature_min <= temperature < table.saturation_temperature_max
            and temperature < table.critical_temperature):
        lo, step, nodes = table.saturation_temperature_min, table.inverse_saturation_step, table.saturation_nodes
        liquid_volume = saturation_quantity(LIQUID_VOLUME, temperature, lo, step, nodes)[0]
        vapour_volume = saturation_quantity(VAPOUR_VOLUME, temperature, lo, step, nodes)[0]
        liquid_enthalpy = saturation_quantity(LIQUID_ENTHALPY, temperature, lo, step, nodes)[0]
        vapour_enthalpy = table_state(temperature, 1.0 / vapour_volume, table).enthalpy
    return VolumeState(temperature, state.pressure, density, state.enthalpy, state.heat_capacity_v, quality,
                       liquid_volume, vapour_volume,
                       liquid_enthalpy, vapour_enthalpy, STATUS_OK)
