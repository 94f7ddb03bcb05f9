"""The real-gas chambers of the active lobe: states, flow paths and their rates, and the valley switch
(docs/model.md §7.2-§7.4).

The model knows nothing of vanes. Per evaluation the caller (the mechanics time loop) hands it the chambers'
geometric volumes and their rates, the lobe phase of the vane and the gaps of the tip and of the vane's side faces
with their friction-equivalent lengths (`ChamberInputs`); it returns the rates of its state block (`chamber_rates`,
the one entry point per evaluation) and the flows.

State block (offsets below, placed after the vane's states by the caller): temperature and gas mass of the leading
(L) and trailing (T) chambers, then cumulative flows across the chambers' boundary: net mass and energy from the
suction side (ports, valley leaks, chambers filled from or vented to the idle lobes), mass and enthalpy out through
the discharge valve, the compression work -sum p dV on the two chambers, and net mass and energy from the back
chamber (slot side faces). Mass as a state makes the chamber mass balance a linear invariant
(m_L + m_T - M_suction + M_discharge - M_back), which every Runge-Kutta and Rosenbrock-W step keeps to rounding.

Idle lobes are the suction plenum: each is open to its own suction port all the time and has a constant volume, so
its state stays at suction conditions; the valley-seal leaks go there, a trailing chamber that becomes idle is
vented there and a new leading chamber is filled from there. The discharge plenum and the back chamber hold gas
at p_d on the suction isentrope (h_2s; docs/model.md §7.4).

Flow paths (docs/model.md §7.4), every one a real-fluid isentropic nozzle (thermo.real_gas_nozzle, choked flow
included), the leaks each with its own law and coefficient (thermo.leakage); positive in the direction named:
  suction port (area A_s, lobe phases [0, phi_sc]): suction -> L (the part ahead of the vane) and -> T;
  discharge port with check valve (A_d): L -> discharge plenum only while p_L > p_d;
  end-valley seal (c_S L): L -> idle lobe ahead;    start-valley seal (c_S L): T -> idle lobe behind;
  tip gap (lift-off x L): L -> T;                   slot side faces (gap x L): back chamber -> L and -> T.
A path whose throat is the gas-branch (metastable) continuation (nozzle status 8) is accepted and counted
(`ChamberFlows.metastable`); a path whose upstream state the nozzle table refuses (status 1-7) has a NaN flow and
is counted in `ChamberFlows.refused`, which the loop treats as an invalid gas state.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .kernel import kernel, kernel_record
from .control_volume import chamber_derivatives, internal_energy_temperature, port_coverage
from .leakage import leakage_path_open, real_gas_leakage_flow
from .property_table import STATUS_OK, table_properties, table_state
from .real_gas_nozzle import STATUS_THROAT_NEAR_SATURATION, nozzle_flux_between

# the state block
(LEADING_TEMPERATURE, LEADING_MASS, TRAILING_TEMPERATURE, TRAILING_MASS, MASS_SUCTION, MASS_DISCHARGE,
 ENERGY_SUCTION, ENERGY_DISCHARGE, WORK_CHAMBERS, MASS_BACK_CHAMBER, ENERGY_BACK_CHAMBER) = range(11)
GAS_STATE_SIZE = 11
CHAMBER_STATES = 4                 # T_L, m_L, T_T, m_T: the states the flows feed back on

CONSTANT_FIELDS = (
    "suction_pressure", "suction_temperature", "suction_density", "suction_enthalpy",
    "discharge_pressure", "discharge_temperature", "discharge_density", "discharge_enthalpy",
    "dead_volume", "suction_close_angle", "suction_port_area", "suction_port_coefficient", "discharge_port_area",
    "discharge_port_coefficient", "axial_length", "valley_gap", "valley_flow_length",
    "end_valley_law", "end_valley_coefficient", "start_valley_law", "start_valley_coefficient",
    "tip_law", "tip_coefficient", "slot_law", "slot_coefficient",
    "atol_temperature", "atol_mass", "atol_energy",
)
CONSTANTS_DTYPE = np.dtype([(name, np.float64) for name in CONSTANT_FIELDS])


def chamber_constants(**values) -> np.ndarray:
    """The model's constants as a one-row structured array (every CONSTANT_FIELDS entry must be given, SI units;
    laws as thermo.leakage codes); numba reads its fields by name."""
    missing = set(CONSTANT_FIELDS) - set(values)
    unknown = set(values) - set(CONSTANT_FIELDS)
    if missing or unknown:
        raise ValueError(f"chamber constants: missing {sorted(missing)}, unknown {sorted(unknown)}")
    constants = np.zeros(1, dtype=CONSTANTS_DTYPE)
    for name, value in values.items():
        constants[name] = float(value)
    return kernel_record(constants)


class ChamberInputs(NamedTuple):
    """What the chambers need of the vane at one instant: geometric volumes [m^3] and their rates [m^3/s] (the
    dead volume is added here), the vane's phase in its lobe [rad], the tip's lift-off max(0, -delta_S) [m] and
    the gaps between the vane's side faces and the slot walls (narrowest height [m]) with the friction-equivalent
    flow lengths [m] of the tip gap and of the two side-face gaps (docs/model.md §7.4)."""
    volume_leading: float
    volume_trailing: float
    rate_leading: float
    rate_trailing: float
    vane_phase: float
    tip_lift: float
    tip_flow_length: float
    slot_gap_leading: float
    slot_flow_length_leading: float
    slot_gap_trailing: float
    slot_flow_length_trailing: float


class ChamberFlows(NamedTuple):
    """Mass flows [kg/s] in the directions of the module docstring, and how many paths the nozzle table refused
    (their flow is NaN) or continued through a metastable throat (status 8)."""
    suction_leading: float
    suction_trailing: float
    discharge: float
    tip_leak: float
    end_valley_leak: float
    start_valley_leak: float
    slot_leak_leading: float
    slot_leak_trailing: float
    refused: int
    metastable: int


class FlowNode(NamedTuple):
    """A side of a flow path: temperature [K], density [kg/m^3], pressure [Pa], specific enthalpy [J/kg]."""
    temperature: float
    density: float
    pressure: float
    enthalpy: float


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
def _side_flux(needed, a, b, nozzles):
    """(G, factor, status) of thermo.real_gas_nozzle.nozzle_flux_between from node a towards node b if a path
    between them is open (`needed`), else (0, 0, 0) without a table look-up."""
    if not needed:
        return 0.0, 0.0, STATUS_OK
    return nozzle_flux_between(a.temperature, a.density, a.pressure, b.temperature, b.density, b.pressure, nozzles)


@kernel
def _port_flow(coefficient, area, flux, factor):
    """m_dot [kg/s] through a port of area A between two nodes of flux G and factor (a closed port: 0)."""
    return coefficient * area * flux * factor if area > 0.0 else 0.0


@kernel
def _leak_flow(law, coefficient, gap, flow_length, width, flux, factor, a, b, nozzles):
    """m_dot a -> b [kg/s] through a leakage path of height `gap` and width `width` (thermo.leakage)."""
    upstream = a if factor >= 0.0 else b
    return real_gas_leakage_flow(law, coefficient, gap, flow_length, width, flux, factor, upstream.temperature,
                                 upstream.density, nozzles)


@kernel
def _status_counts(statuses):
    """(refused, metastable): how many of the nozzle statuses are refusals (1-7) and metastable throats (8)."""
    refused = 0
    metastable = 0
    for status in statuses:
        metastable += status == STATUS_THROAT_NEAR_SATURATION
        refused += status != STATUS_OK and status != STATUS_THROAT_NEAR_SATURATION
    return refused, metastable


@kernel
def chamber_flows(inputs, c, leading, trailing, nozzles):
    """The ChamberFlows between the FlowNodes of the two chambers and the boundary nodes (suction, and the
    discharge plenum = back chamber) (docs/model.md §7.4). The nozzle flux is looked up once per pair of nodes
    with an open path between them and serves every path of that pair (a port and a seal)."""
    suction = FlowNode(c.suction_temperature, c.suction_density, c.suction_pressure, c.suction_enthalpy)
    back = FlowNode(c.discharge_temperature, c.discharge_density, c.discharge_pressure, c.discharge_enthalpy)
    width = c.axial_length
    port_leading = c.suction_port_area * port_coverage(inputs.vane_phase, 0.0, c.suction_close_angle)
    port_trailing = c.suction_port_area - port_leading
    valve_open = leading.pressure > back.pressure                                  # check valve
    end_valley_open = leakage_path_open(c.end_valley_law, c.valley_gap, width)
    start_valley_open = leakage_path_open(c.start_valley_law, c.valley_gap, width)
    tip_open = leakage_path_open(c.tip_law, inputs.tip_lift, width)
    slot_leading_open = leakage_path_open(c.slot_law, inputs.slot_gap_leading, width)
    slot_trailing_open = leakage_path_open(c.slot_law, inputs.slot_gap_trailing, width)
    # suction -> L: port share ahead of the vane, end-valley seal (L -> idle lobe)
    flux, factor, status_1 = _side_flux(port_leading > 0.0 or end_valley_open, suction, leading, nozzles)
    suction_leading = _port_flow(c.suction_port_coefficient, port_leading, flux, factor)
    end_valley = -_leak_flow(c.end_valley_law, c.end_valley_coefficient, c.valley_gap, c.valley_flow_length, width,
                             flux, factor, suction, leading, nozzles)
    # suction -> T: port share behind the vane, start-valley seal (T -> idle lobe)
    flux, factor, status_2 = _side_flux(port_trailing > 0.0 or start_valley_open, suction, trailing, nozzles)
    suction_trailing = _port_flow(c.suction_port_coefficient, port_trailing, flux, factor)
    start_valley = -_leak_flow(c.start_valley_law, c.start_valley_coefficient, c.valley_gap, c.valley_flow_length,
                               width, flux, factor, suction, trailing, nozzles)
    # L -> T: tip gap
    flux, factor, status_3 = _side_flux(tip_open, leading, trailing, nozzles)
    tip = _leak_flow(c.tip_law, c.tip_coefficient, inputs.tip_lift, inputs.tip_flow_length, width, flux, factor,
                     leading, trailing, nozzles)
    # L -> back: discharge valve, slot side face (back -> L)
    flux, factor, status_4 = _side_flux(valve_open or slot_leading_open, leading, back, nozzles)
    discharge = _port_flow(c.discharge_port_coefficient, c.discharge_port_area if valve_open else 0.0, flux, factor)
    slot_leading = -_leak_flow(c.slot_law, c.slot_coefficient, inputs.slot_gap_leading,
                               inputs.slot_flow_length_leading, width, flux, factor, leading, back, nozzles)
    # T -> back: slot side face (back -> T)
    flux, factor, status_5 = _side_flux(slot_trailing_open, trailing, back, nozzles)
    slot_trailing = -_leak_flow(c.slot_law, c.slot_coefficient, inputs.slot_gap_trailing,
                                inputs.slot_flow_length_trailing, width, flux, factor, trailing, back, nozzles)
    refused, metastable = _status_counts((status_1, status_2, status_3, status_4, status_5))
    return ChamberFlows(suction_leading, suction_trailing, discharge, tip, end_valley, start_valley, slot_leading,
                        slot_trailing, refused, metastable)


@kernel
def chamber_rates(y, block, inputs, c, table, nozzles, rates):
    """Fill the state block's derivatives (from index `block` of `rates`) at the state block of y (from `block`)
    (docs/model.md §7.3-§7.4); return (ChamberFlows, leading FluidState, trailing FluidState). The chamber
    equations are those of thermo.control_volume.chamber_derivatives with dm/dt the net flow:

        dm/dt = sum m_in - sum m_out,
        dT/dt = [ -T (dp/dT)_rho (dV/dt - v dm/dt) - h dm/dt + sum m_in h_up - sum m_out h ] / (m c_v)
    """
    leading, trailing = chamber_fluid_states(y, block, inputs, c, table)
    volume_leading, volume_trailing = volumes_with_dead_volume(inputs, c)
    t_l = y[block + LEADING_TEMPERATURE]
    t_t = y[block + TRAILING_TEMPERATURE]
    density_leading = y[block + LEADING_MASS] / volume_leading
    density_trailing = y[block + TRAILING_MASS] / volume_trailing
    h_l = leading.enthalpy
    h_t = trailing.enthalpy
    h_s = c.suction_enthalpy
    h_b = c.discharge_enthalpy
    flows = chamber_flows(
        inputs, c, FlowNode(t_l, density_leading, leading.pressure, h_l),
        FlowNode(t_t, density_trailing, trailing.pressure, h_t), nozzles)

    # leading chamber: suction port, end-valley seal (out), tip gap (out), slot side face (in), discharge (out)
    energy_suction_leading = (_energy_into(flows.suction_leading, h_s, h_l)
                              + _energy_into(-flows.end_valley_leak, h_s, h_l))
    energy_back_leading = _energy_into(flows.slot_leak_leading, h_b, h_l)
    net_leading = (flows.suction_leading - flows.end_valley_leak - flows.tip_leak + flows.slot_leak_leading
                   - flows.discharge)
    energy_leading = (energy_suction_leading + energy_back_leading + _energy_into(-flows.tip_leak, h_t, h_l)
                      - flows.discharge * h_l)
    # trailing chamber: suction port, start-valley seal (out), tip gap (in), slot side face (in)
    energy_suction_trailing = (_energy_into(flows.suction_trailing, h_s, h_t)
                               + _energy_into(-flows.start_valley_leak, h_s, h_t))
    energy_back_trailing = _energy_into(flows.slot_leak_trailing, h_b, h_t)
    net_trailing = flows.suction_trailing - flows.start_valley_leak + flows.tip_leak + flows.slot_leak_trailing
    energy_trailing = energy_suction_trailing + energy_back_trailing + _energy_into(flows.tip_leak, h_l, h_t)

    rates[block + LEADING_TEMPERATURE] = chamber_derivatives(
        t_l, density_leading, volume_leading, inputs.rate_leading, net_leading, energy_leading, 0.0, h_l,
        leading.heat_capacity_v, leading.pressure_temperature_derivative, 0.0)[0]
    rates[block + LEADING_MASS] = net_leading
    rates[block + TRAILING_TEMPERATURE] = chamber_derivatives(
        t_t, density_trailing, volume_trailing, inputs.rate_trailing, net_trailing, energy_trailing, 0.0, h_t,
        trailing.heat_capacity_v, trailing.pressure_temperature_derivative, 0.0)[0]
    rates[block + TRAILING_MASS] = net_trailing
    rates[block + MASS_SUCTION] = (flows.suction_leading + flows.suction_trailing - flows.end_valley_leak
                                   - flows.start_valley_leak)
    rates[block + ENERGY_SUCTION] = energy_suction_leading + energy_suction_trailing
    rates[block + MASS_DISCHARGE] = flows.discharge
    rates[block + ENERGY_DISCHARGE] = flows.discharge * h_l
    rates[block + WORK_CHAMBERS] = -(leading.pressure * inputs.rate_leading + trailing.pressure * inputs.rate_trailing)
    rates[block + MASS_BACK_CHAMBER] = flows.slot_leak_leading + flows.slot_leak_trailing
    rates[block + ENERGY_BACK_CHAMBER] = energy_back_leading + energy_back_trailing
    return flows, leading, trailing


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
    elif (i == LEADING_MASS or i == TRAILING_MASS or i == MASS_SUCTION or i == MASS_DISCHARGE
          or i == MASS_BACK_CHAMBER):
        atol = c.atol_mass
    else:
        atol = c.atol_energy
    return atol + relative_tolerance * abs(value)
