"""The real-gas chambers of the active lobe: states, flow paths and their rates, and the valley switch
(docs/model.md §7.2-§7.4).

The model knows nothing of vanes. Per evaluation the caller (the mechanics time loop) hands it the chambers'
geometric volumes and their rates, the lobe phase of the vane and the tip's lift-off (`ChamberInputs`); it returns
the rates of its state block (`chamber_rates`, the one entry point per evaluation) and the flows.

State block (offsets below, placed after the vane's states by the caller): temperature and gas mass of the leading
(L) and trailing (T) chambers, then cumulative flows across the chambers' boundary: net mass and energy from the
suction side (ports, valley leak, chambers filled from or vented to the idle lobes), mass and enthalpy out through
the discharge valve, and the compression work -sum p dV on the two chambers. Mass as a state makes the chamber
mass balance a linear invariant (m_L + m_T - M_suction + M_discharge), which every Runge-Kutta and Rosenbrock-W
step keeps to rounding.

Idle lobes are the suction plenum: each is open to its own suction port all the time and has a constant volume, so
its state stays at suction conditions; the valley-seal leak of the leading chamber goes there, a trailing chamber
that becomes idle is vented there, and a new leading chamber is filled from there.

Flow paths (docs/model.md §7.4), positive into the chamber named first:
  suction port (area A_s, lobe phases [0, phi_sc]): split between L (the part ahead of the vane) and T;
  discharge port with check valve (A_d): L -> discharge plenum only while p_L > p_d;
  valley-seal leak (c_S L): L <-> idle lobe at suction state;
  tip leak (max(0, -delta_S) L, tip lifted off the stator): L <-> T.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .kernel import kernel
from .control_volume import chamber_derivatives, internal_energy_temperature, port_coverage, signed_nozzle_flow
from .property_table import table_properties, table_state

# the state block
(LEADING_TEMPERATURE, LEADING_MASS, TRAILING_TEMPERATURE, TRAILING_MASS, MASS_SUCTION, MASS_DISCHARGE,
 ENERGY_SUCTION, ENERGY_DISCHARGE, WORK_CHAMBERS) = range(9)
GAS_STATE_SIZE = 9
CHAMBER_STATES = 4                 # T_L, m_L, T_T, m_T: the states the flows feed back on

CONSTANT_FIELDS = (
    "suction_pressure", "suction_temperature", "suction_density", "suction_enthalpy", "discharge_pressure",
    "dead_volume", "suction_close_angle", "suction_port_area", "suction_port_coefficient", "discharge_port_area",
    "discharge_port_coefficient", "leak_coefficient", "valley_leak_area", "axial_length",
    "nozzle_heat_capacity_ratio", "nozzle_gas_constant", "atol_temperature", "atol_mass", "atol_energy",
)
CONSTANTS_DTYPE = np.dtype([(name, np.float64) for name in CONSTANT_FIELDS])


def chamber_constants(**values) -> np.ndarray:
    """The model's constants as a one-row structured array (every CONSTANT_FIELDS entry must be given, SI units);
    numba reads its fields by name."""
    missing = set(CONSTANT_FIELDS) - set(values)
    unknown = set(values) - set(CONSTANT_FIELDS)
    if missing or unknown:
        raise ValueError(f"chamber constants: missing {sorted(missing)}, unknown {sorted(unknown)}")
    constants = np.zeros(1, dtype=CONSTANTS_DTYPE)
    for name, value in values.items():
        constants[name] = float(value)
    return constants


class ChamberInputs(NamedTuple):
    """What the chambers need of the vane at one instant: geometric volumes [m^3] and their rates [m^3/s] (the
    dead volume is added here), the vane's phase in its lobe [rad] and the tip's lift-off max(0, -delta_S) [m]."""
    volume_leading: float
    volume_trailing: float
    rate_leading: float
    rate_trailing: float
    vane_phase: float
    tip_lift: float


class ChamberFlows(NamedTuple):
    """Mass flows [kg/s]: suction port into both chambers, discharge valve, tip leak L -> T, valley leak L -> idle."""
    suction: float
    discharge: float
    tip_leak: float
    valley_leak: float


@kernel
def volumes_with_dead_volume(inputs, c):
    """(V_L, V_T) including the dead volume of each chamber [m^3]."""
    return inputs.volume_leading + c.dead_volume, inputs.volume_trailing + c.dead_volume


@kernel
def chamber_fluid_states(y, block, inputs, c, table):
    """The FluidState (thermo.property_table) of the leading and trailing chamber, at rho = m/V; the state block
    starts at index `block` of y."""
    volume_leading, volume_trailing = volumes_with_dead_volume(inputs, c)
    return (table_state(y[block + LEADING_TEMPERATURE], y[block + LEADING_MASS] / volume_leading, table),
            table_state(y[block + TRAILING_TEMPERATURE], y[block + TRAILING_MASS] / volume_trailing, table))


@kernel
def _energy_into(flow, upstream_enthalpy, own_enthalpy):
    """Enthalpy flow [W] into a chamber carried by a signed mass flow (positive = into the chamber)."""
    return flow * (upstream_enthalpy if flow > 0.0 else own_enthalpy)


@kernel
def chamber_rates(y, block, inputs, c, table, rates):
    """Fill the state block's derivatives (from index `block` of `rates`) at the state block of y (from `block`)
    (docs/model.md §7.3-§7.4); return
    (ChamberFlows, leading FluidState, trailing FluidState). The chamber equations are those of
    thermo.control_volume.chamber_derivatives with dm/dt the net flow:

        dm/dt = sum m_in - sum m_out,
        dT/dt = [ -T (dp/dT)_rho (dV/dt - v dm/dt) - h dm/dt + sum m_in h_up - sum m_out h ] / (m c_v)
    """
    leading, trailing = chamber_fluid_states(y, block, inputs, c, table)
    volume_leading, volume_trailing = volumes_with_dead_volume(inputs, c)
    k = c.nozzle_heat_capacity_ratio
    gas_constant = c.nozzle_gas_constant
    p_s = c.suction_pressure
    t_s = c.suction_temperature
    h_s = c.suction_enthalpy
    t_l = y[block + LEADING_TEMPERATURE]
    t_t = y[block + TRAILING_TEMPERATURE]
    p_l, h_l = leading.pressure, leading.enthalpy
    p_t, h_t = trailing.pressure, trailing.enthalpy

    ahead = port_coverage(inputs.vane_phase, 0.0, c.suction_close_angle)
    suction_leading = signed_nozzle_flow(c.suction_port_coefficient, c.suction_port_area * ahead, p_s, t_s, p_l,
                                         t_l, k, gas_constant)
    suction_trailing = signed_nozzle_flow(c.suction_port_coefficient, c.suction_port_area * (1.0 - ahead), p_s,
                                          t_s, p_t, t_t, k, gas_constant)
    discharge = max(0.0, signed_nozzle_flow(c.discharge_port_coefficient, c.discharge_port_area, p_l, t_l,
                                            c.discharge_pressure, t_l, k, gas_constant))     # check valve
    valley_leak = signed_nozzle_flow(c.leak_coefficient, c.valley_leak_area, p_l, t_l, p_s, t_s, k, gas_constant)
    tip_leak = signed_nozzle_flow(c.leak_coefficient, inputs.tip_lift * c.axial_length, p_l, t_l, p_t, t_t, k,
                                  gas_constant)

    # leading chamber: suction port, valley leak (out), tip leak (out), discharge (out)
    energy_suction_leading = _energy_into(suction_leading, h_s, h_l) + _energy_into(-valley_leak, h_s, h_l)
    net_leading = suction_leading - valley_leak - tip_leak - discharge
    energy_leading = energy_suction_leading + _energy_into(-tip_leak, h_t, h_l) - discharge * h_l
    # trailing chamber: suction port, tip leak (in)
    energy_suction_trailing = _energy_into(suction_trailing, h_s, h_t)
    net_trailing = suction_trailing + tip_leak
    energy_trailing = energy_suction_trailing + _energy_into(tip_leak, h_l, h_t)

    rates[block + LEADING_TEMPERATURE] = chamber_derivatives(
        t_l, y[block + LEADING_MASS] / volume_leading, volume_leading, inputs.rate_leading, net_leading, energy_leading,
        0.0, h_l, leading.heat_capacity_v, leading.pressure_temperature_derivative, 0.0)[0]
    rates[block + LEADING_MASS] = net_leading
    rates[block + TRAILING_TEMPERATURE] = chamber_derivatives(
        t_t, y[block + TRAILING_MASS] / volume_trailing, volume_trailing, inputs.rate_trailing, net_trailing,
        energy_trailing, 0.0, h_t, trailing.heat_capacity_v, trailing.pressure_temperature_derivative, 0.0)[0]
    rates[block + TRAILING_MASS] = net_trailing
    rates[block + MASS_SUCTION] = suction_leading + suction_trailing - valley_leak
    rates[block + ENERGY_SUCTION] = energy_suction_leading + energy_suction_trailing
    rates[block + MASS_DISCHARGE] = discharge
    rates[block + ENERGY_DISCHARGE] = discharge * h_l
    rates[block + WORK_CHAMBERS] = -(p_l * inputs.rate_leading + p_t * inputs.rate_trailing)
    return (ChamberFlows(suction_leading + suction_trailing, discharge, tip_leak, valley_leak), leading, trailing)


@kernel
def chamber_energy(y, block, inputs, c, table):
    """(mass [kg], internal energy [J]) of the gas in the two chambers."""
    leading, trailing = chamber_fluid_states(y, block, inputs, c, table)
    volume_leading, volume_trailing = volumes_with_dead_volume(inputs, c)
    return (y[block + LEADING_MASS] + y[block + TRAILING_MASS],
            y[block + LEADING_MASS] * (leading.enthalpy - leading.pressure * volume_leading / y[block + LEADING_MASS])
            + y[block + TRAILING_MASS] * (trailing.enthalpy - trailing.pressure * volume_trailing / y[block + TRAILING_MASS]))


@kernel
def switch_chambers(y, block, old_inputs, new_inputs, c, table):
    """Chamber bookkeeping when the vane crosses a valley (docs/model.md §7.2):

    the leading chamber (now the dead volume at the valley) becomes the new trailing chamber: its gas fills the new
    trailing volume, expanding adiabatically (T from u at the new density) if that volume is larger; if it is smaller
    (a wide valley gap: the pocket beside the vane is counted on the other side of the valley line), the trailing
    chamber keeps the gas at its density and the surplus passes through the valley gap into the new leading chamber
    (mixed at constant total internal energy). The trailing chamber becomes an idle lobe (vented to the suction
    plenum); the next idle lobe becomes the new leading chamber at the suction state. The cumulative suction-side
    mass and energy record what was vented and filled. Returns False if a state left the property table or the new
    trailing chamber has no volume.
    """
    leading, trailing = chamber_fluid_states(y, block, old_inputs, c, table)
    old_leading, old_trailing = volumes_with_dead_volume(old_inputs, c)
    new_leading, new_trailing = volumes_with_dead_volume(new_inputs, c)
    if new_trailing <= 0.0 or new_leading <= 0.0:
        return False
    leading_mass = y[block + LEADING_MASS]
    trailing_mass = y[block + TRAILING_MASS]
    leading_energy = leading.enthalpy - leading.pressure * old_leading / leading_mass
    trailing_energy = trailing.enthalpy - trailing.pressure * old_trailing / trailing_mass
    suction = table_properties(c.suction_temperature, c.suction_density, table)
    suction_energy = suction[1] - suction[0] / c.suction_density
    filled_mass = c.suction_density * new_leading
    if new_trailing >= old_leading:
        kept_mass = leading_mass
        kept_temperature = internal_energy_temperature(leading_energy, leading_mass / new_trailing,
                                                       y[block + LEADING_TEMPERATURE], table)
    else:
        kept_mass = leading_mass * new_trailing / old_leading
        kept_temperature = y[block + LEADING_TEMPERATURE]
    surplus = leading_mass - kept_mass
    new_leading_mass = filled_mass + surplus
    new_leading_temperature = c.suction_temperature
    if surplus > 0.0:
        mixed_energy = (filled_mass * suction_energy + surplus * leading_energy) / new_leading_mass
        new_leading_temperature = internal_energy_temperature(mixed_energy, new_leading_mass / new_leading,
                                                              c.suction_temperature, table)
    y[block + TRAILING_TEMPERATURE] = kept_temperature
    y[block + TRAILING_MASS] = kept_mass
    y[block + LEADING_TEMPERATURE] = new_leading_temperature
    y[block + LEADING_MASS] = new_leading_mass
    y[block + MASS_SUCTION] += filled_mass - trailing_mass
    y[block + ENERGY_SUCTION] += filled_mass * suction_energy - trailing_mass * trailing_energy
    return math.isfinite(kept_temperature) and math.isfinite(new_leading_temperature)


@kernel
def gas_tolerance(i, value, c, relative_tolerance):
    """atol_i + rtol |g_i| for the state block: temperatures [K], masses [kg], energies and work [J]."""
    if i == LEADING_TEMPERATURE or i == TRAILING_TEMPERATURE:
        atol = c.atol_temperature
    elif i == LEADING_MASS or i == TRAILING_MASS or i == MASS_SUCTION or i == MASS_DISCHARGE:
        atol = c.atol_mass
    else:
        atol = c.atol_energy
    return atol + relative_tolerance * abs(value)
