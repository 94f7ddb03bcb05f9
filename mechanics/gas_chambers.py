"""Level 1: the real-gas leading and trailing chambers of the active lobe, coupled to the vane (docs/model.md §7.2-§7.4).

The chamber states (T, rho) live in the state vector after the vane's (mechanics.layout). Idle lobes are taken
as the suction plenum: each is open to its own suction port all the time and has a constant volume, so its state
stays at suction conditions; the valley-seal leak of the leading chamber goes there, a trailing chamber that
becomes idle is vented there, and a new leading chamber is filled from there (the bookkeeping of docs/model.md §7.2).

Flow paths (docs/model.md §7.4), positive into the chamber named first:
  suction port (area A_s, lobe phases [0, phi_sc]): split between L (the part ahead of the vane) and T;
  discharge port with check valve (A_d): L -> discharge plenum only while p_L > p_d;
  valley-seal leak (c_S L): L <-> idle lobe at suction state;
  tip leak (max(0, -delta_S) L, tip lifted off the stator): L <-> T.
"""
import math

from numba import njit

from rotary_vane.thermo.control_volume import (chamber_derivatives, internal_energy_temperature, port_coverage,
                                   signed_nozzle_flow)
from rotary_vane.thermo.property_table import table_properties

from .layout import (ENERGY_DISCHARGE, ENERGY_SUCTION, LEADING_DENSITY, LEADING_TEMPERATURE, MASS_DISCHARGE,
                     MASS_SUCTION, TRAILING_DENSITY, TRAILING_TEMPERATURE, WORK_CHAMBERS)


@njit(cache=True)
def chamber_properties(y, gas):
    """(p, h, c_v, (dp/dT)_rho, status) of the leading and the trailing chamber from their (T, rho) states."""
    return (table_properties(y[LEADING_TEMPERATURE], y[LEADING_DENSITY], gas),
            table_properties(y[TRAILING_TEMPERATURE], y[TRAILING_DENSITY], gas))


@njit(cache=True)
def _energy_into(flow, upstream_enthalpy, own_enthalpy):
    """Enthalpy flow [W] into a chamber carried by a signed mass flow (positive = into the chamber)."""
    return flow * (upstream_enthalpy if flow > 0.0 else own_enthalpy)


@njit(cache=True)
def chamber_gas_derivatives(y, leading, trailing, volumes, volume_rates, vane_phase, tip_penetration, m, dydt):
    """Fill the Level 1 part of dy/dt (docs/model.md §7.3): chamber (T, rho) and the cumulative boundary flows.

    leading/trailing: (p, h, c_v, dp/dT, status) of each chamber; volumes and volume_rates: (V_L, V_T) with the
    dead volume included, (dV_L/dt, dV_T/dt). Returns (suction mass flow into both chambers, discharge mass flow,
    tip-leak flow L -> T, valley-leak flow L -> idle lobe) [kg/s].
    """
    k = m.nozzle_heat_capacity_ratio
    gas_constant = m.nozzle_gas_constant
    p_s = m.suction_pressure
    t_s = m.suction_temperature
    h_s = m.suction_enthalpy
    t_l = y[LEADING_TEMPERATURE]
    t_t = y[TRAILING_TEMPERATURE]
    p_l, h_l, cv_l, dpdt_l = leading[0], leading[1], leading[2], leading[3]
    p_t, h_t, cv_t, dpdt_t = trailing[0], trailing[1], trailing[2], trailing[3]

    ahead = port_coverage(vane_phase, 0.0, m.suction_close_angle)
    suction_leading = signed_nozzle_flow(m.suction_port_coefficient, m.suction_port_area * ahead, p_s, t_s, p_l,
                                         t_l, k, gas_constant)
    suction_trailing = signed_nozzle_flow(m.suction_port_coefficient, m.suction_port_area * (1.0 - ahead), p_s,
                                          t_s, p_t, t_t, k, gas_constant)
    discharge = max(0.0, signed_nozzle_flow(m.discharge_port_coefficient, m.discharge_port_area, p_l, t_l,
                                            m.discharge_pressure, t_l, k, gas_constant))     # check valve
    valley_leak = signed_nozzle_flow(m.leak_coefficient, m.stator_clearance * m.axial_length, p_l, t_l, p_s, t_s,
                                     k, gas_constant)
    tip_leak = signed_nozzle_flow(m.leak_coefficient, max(0.0, -tip_penetration) * m.axial_length, p_l, t_l, p_t,
                                  t_t, k, gas_constant)

    # leading chamber: suction port, valley leak (out), tip leak (out), discharge (out)
    energy_suction_leading = _energy_into(suction_leading, h_s, h_l) + _energy_into(-valley_leak, h_s, h_l)
    net_leading = suction_leading - valley_leak - tip_leak - discharge
    energy_leading = energy_suction_leading + _energy_into(-tip_leak, h_t, h_l) - discharge * h_l
    # trailing chamber: suction port, tip leak (in)
    energy_suction_trailing = _energy_into(suction_trailing, h_s, h_t)
    net_trailing = suction_trailing + tip_leak
    energy_trailing = energy_suction_trailing + _energy_into(tip_leak, h_l, h_t)

    # net mass flow as mass_in and net enthalpy flow as enthalpy_in with mass_out = 0: the same equation
    rate_t_l, rate_rho_l = chamber_derivatives(t_l, y[LEADING_DENSITY], volumes[0], volume_rates[0], net_leading,
                                               energy_leading, 0.0, h_l, cv_l, dpdt_l, 0.0)
    rate_t_t, rate_rho_t = chamber_derivatives(t_t, y[TRAILING_DENSITY], volumes[1], volume_rates[1],
                                               net_trailing, energy_trailing, 0.0, h_t, cv_t, dpdt_t, 0.0)
    dydt[LEADING_TEMPERATURE] = rate_t_l
    dydt[LEADING_DENSITY] = rate_rho_l
    dydt[TRAILING_TEMPERATURE] = rate_t_t
    dydt[TRAILING_DENSITY] = rate_rho_t
    dydt[MASS_SUCTION] = suction_leading + suction_trailing - valley_leak
    dydt[ENERGY_SUCTION] = energy_suction_leading + energy_suction_trailing
    dydt[MASS_DISCHARGE] = discharge
    dydt[ENERGY_DISCHARGE] = discharge * h_l
    dydt[WORK_CHAMBERS] = -(p_l * volume_rates[0] + p_t * volume_rates[1])
    return suction_leading + suction_trailing, discharge, tip_leak, valley_leak


@njit(cache=True)
def switch_chambers(y, old_volumes, new_volumes, gas, m):
    """Chamber bookkeeping when the vane crosses a valley (docs/model.md §7.2), volumes with the dead volume included:

    the leading chamber (now the dead volume at the valley) becomes the new trailing chamber: its mass and internal
    energy fill the new trailing volume (adiabatic, T from u at the new density); the trailing chamber becomes an
    idle lobe (vented to the suction plenum); the next idle lobe becomes the new leading chamber at the suction
    state. The cumulative suction-side mass and energy record what was vented and filled. Returns False if a state
    left the property table.
    """
    leading, trailing = chamber_properties(y, gas)
    leading_mass = y[LEADING_DENSITY] * old_volumes[0]
    trailing_mass = y[TRAILING_DENSITY] * old_volumes[1]
    leading_energy = leading[1] - leading[0] / y[LEADING_DENSITY]
    trailing_energy = trailing[1] - trailing[0] / y[TRAILING_DENSITY]
    suction = table_properties(m.suction_temperature, m.suction_density, gas)
    suction_energy = suction[1] - suction[0] / m.suction_density
    merged_density = leading_mass / new_volumes[1]
    merged_temperature = internal_energy_temperature(leading_energy, merged_density, y[LEADING_TEMPERATURE], gas)
    filled_mass = m.suction_density * new_volumes[0]
    y[TRAILING_TEMPERATURE] = merged_temperature
    y[TRAILING_DENSITY] = merged_density
    y[LEADING_TEMPERATURE] = m.suction_temperature
    y[LEADING_DENSITY] = m.suction_density
    y[MASS_SUCTION] += filled_mass - trailing_mass
    y[ENERGY_SUCTION] += filled_mass * suction_energy - trailing_mass * trailing_energy
    return math.isfinite(merged_temperature)
