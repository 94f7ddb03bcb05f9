"""The real-gas chambers of the active lobe: states, rates and the valley switch (docs/model.md §7.2-§7.4).

The model knows nothing of vanes. Per evaluation the caller (the mechanics time loop) hands it the chambers'
geometric volumes and their rates, the lobe phase of the vane and the gaps of the tip and of the vane's side faces
with their friction-equivalent lengths (`ChamberInputs`); it returns the rates of its state block (`chamber_rates`,
the one entry point per evaluation) and leaves the flows of the flow network in its working record
(`chamber_flow_work`; thermo.flow_paths: the paths as the rows of one table, one routine for their flows and one
for the sums per node).

State block (thermo.chamber_state, placed after the vane's states by the caller): temperature and gas mass of the
leading (L) and trailing (T) chambers, then cumulative flows across the chambers' boundary (suction side, discharge
valve, back chamber) and the compression work -sum p dV on the two chambers. Mass as a state makes the chamber mass
balance a linear invariant (m_L + m_T - M_suction + M_discharge - M_back), which every Runge-Kutta and Rosenbrock-W
step keeps to rounding.

Idle lobes are the suction plenum: each is open to its own suction port all the time and has a constant volume, so
its state stays at suction conditions; the valley-seal leaks go there, a trailing chamber that becomes idle is
vented there and a new leading chamber is filled from there. The discharge plenum and the back chamber hold gas
at p_d on the suction isentrope (h_2s; docs/model.md §7.4). These boundary states are the record's: held, or moved
linearly over an advance from the values at its start (`boundary_nodes` at time t; docs/model.md §7.3.3);
chamber_rates writes them into the network's working record with the chambers' states, where the flow routines
read every node's state.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .chamber_state import (CHAMBER_STATES, ENERGY_BACK_CHAMBER, ENERGY_DISCHARGE, ENERGY_SUCTION,  # noqa: F401
                            GAS_STATE_SIZE, LEADING_MASS, LEADING_TEMPERATURE, MASS_BACK_CHAMBER, MASS_DISCHARGE,
                            MASS_SUCTION, TRAILING_MASS, TRAILING_TEMPERATURE, WORK_CHAMBERS)
from .control_volume import chamber_derivatives, internal_energy_temperature
from .flow_paths import (BACK, FLOW_PATHS, INPUT_GAP, LEADING, SUCTION, TRAILING, FlowNode, flow_work,
                         network_tables, node_pairs, path_flows, set_node, sum_flows)
from ..kernels.kernel import kernel, kernel_record
from .leakage import LAW_NOZZLE
from .property_table import table_properties, table_state

# the constants the kernels read by name; the flow paths' constants are resolved from named values into per-path
# arrays (`PATH_FIELDS`, thermo.flow_paths)
# (the boundary nodes' fields: the values held, or reached at the end of a ramp; `<field>_from`: their values at the
# ramp's start, `ramp_start`/`ramp_duration` [s] its time span, 0 s when held: boundary_nodes)
NODE_FIELDS = ("suction_temperature", "suction_density", "suction_pressure", "suction_enthalpy",
               "discharge_temperature", "discharge_density", "discharge_pressure", "discharge_enthalpy")
RAMP_FIELDS = (*(f"{name}_from" for name in NODE_FIELDS), "ramp_start", "ramp_duration")
CONSTANT_FIELDS = (
    *NODE_FIELDS, *RAMP_FIELDS,
    "dead_volume", "suction_close_angle", "atol_temperature", "atol_mass", "atol_energy",
)
PATH_FIELDS = ("size", "flow_length", "width", "law", "coefficient")
PORT_DEFAULTS = {"flow_length": 0.0, "width": 1.0, "law": float(LAW_NOZZLE)}   # "" in a port's row


def path_value_names(paths=FLOW_PATHS) -> set[str]:
    """The names of the chamber constants the rows of a path table refer to (ChamberInputs fields excluded)."""
    names = set()
    for path in paths:
        for field in PATH_FIELDS:
            name = getattr(path, field)
            if name and not (path.opening == INPUT_GAP and field in ("size", "flow_length")):
                names.add(name)
    return names


def chamber_constants(paths=FLOW_PATHS, **values) -> np.ndarray:
    """The model's constants as a one-row structured array: every CONSTANT_FIELDS entry and every constant the path
    rows name must be given (SI units; laws as thermo.leakage codes); numba reads its fields by name. The path table
    is resolved into arrays indexed by path: the values its rows name (`path_law[p]`, ...) and its integer tables
    (thermo.flow_paths.network_tables: `path_source[p]`, ..., `pair_first[k]`, `pair_second[k]`)."""
    values = {**{f"{name}_from": values[name] for name in NODE_FIELDS if name in values},
              "ramp_start": 0.0, "ramp_duration": 0.0, **values}          # held unless a ramp is given
    required = set(CONSTANT_FIELDS) | path_value_names(paths)
    missing = required - set(values)
    unknown = set(values) - required
    if missing or unknown:
        raise ValueError(f"chamber constants: missing {sorted(missing)}, unknown {sorted(unknown)}")
    tables = {f"path_{name}": np.asarray(table) for name, table in
              network_tables(paths, ChamberInputs._fields).items()}
    pairs = np.array(node_pairs(paths))
    tables.update(pair_first=pairs[:, 0], pair_second=pairs[:, 1])
    dtype = np.dtype([(name, np.float64) for name in CONSTANT_FIELDS]
                     + [(f"path_{field}", np.float64, (len(paths),)) for field in PATH_FIELDS]
                     + [(name, table.dtype, table.shape) for name, table in tables.items()])
    constants = np.zeros(1, dtype=dtype)
    for name in CONSTANT_FIELDS:
        constants[name] = float(values[name])
    for p, path in enumerate(paths):
        for field in PATH_FIELDS:
            name = getattr(path, field)
            from_inputs = path.opening == INPUT_GAP and field in ("size", "flow_length")
            value = 0.0 if from_inputs else float(values[name]) if name else PORT_DEFAULTS[field]
            constants[f"path_{field}"][0, p] = value
    for name, table in tables.items():
        constants[name][0] = table
    return kernel_record(constants)


class ChamberInputs(NamedTuple):
    """What the chambers need of the vane at one instant: geometric volumes [m^3] and their rates [m^3/s] (the
    dead volume is added here), the vane's phase in its lobe [rad], the tip's lift-off max(0, -delta_S) [m] and
    the gaps between the vane's side faces and the slot walls (narrowest height [m]) with the friction-equivalent
    flow lengths [m] of the tip gap and of the two side-face gaps (docs/model.md §7.4). All floats: the flow
    paths read the gaps by index."""
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


def chamber_flow_work(paths=FLOW_PATHS) -> np.ndarray:
    """The flow network's working values (thermo.flow_paths.flow_work) of a path table, with the ChamberInputs as
    the network's inputs; allocated once per run, passed to chamber_rates."""
    return flow_work(paths, ChamberInputs._fields)


@kernel
def _ramped(start, end, remaining):
    """A field moved linearly from `start` to `end`, `remaining` the fraction of the ramp still ahead (exactly `end`
    at 0)."""
    return end + (start - end) * remaining


@kernel
def boundary_nodes(c, t):
    """(suction, back) FlowNodes at time t: the suction plenum (and idle lobes) and the discharge plenum / back
    chamber. Held (ramp_duration = 0), or during a ramp every field x = x_1 + (x_0 - x_1)(1 - w), w = (t - t_0)/D
    clipped to [0, 1] (docs/model.md §7.3.3: the inputs interpolated over a step, as the speed)."""
    suction = FlowNode(c.suction_temperature, c.suction_density, c.suction_pressure, c.suction_enthalpy)
    back = FlowNode(c.discharge_temperature, c.discharge_density, c.discharge_pressure, c.discharge_enthalpy)
    if c.ramp_duration > 0.0:             # held: the values themselves, which the ramp's formula gives at w = 1
        remaining = min(max(1.0 - (t - c.ramp_start) / c.ramp_duration, 0.0), 1.0)
        suction = FlowNode(_ramped(c.suction_temperature_from, c.suction_temperature, remaining),
                           _ramped(c.suction_density_from, c.suction_density, remaining),
                           _ramped(c.suction_pressure_from, c.suction_pressure, remaining),
                           _ramped(c.suction_enthalpy_from, c.suction_enthalpy, remaining))
        back = FlowNode(_ramped(c.discharge_temperature_from, c.discharge_temperature, remaining),
                        _ramped(c.discharge_density_from, c.discharge_density, remaining),
                        _ramped(c.discharge_pressure_from, c.discharge_pressure, remaining),
                        _ramped(c.discharge_enthalpy_from, c.discharge_enthalpy, remaining))
    return suction, back


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
def chamber_rates(t, y, block, inputs, c, table, nozzles, rates, work):
    """Fill the state block's derivatives (from index `block` of `rates`) at time t and the state block of y (from
    `block`)
    (docs/model.md §7.3-§7.4); return (FlowStatus, leading FluidState, trailing FluidState). The nodes' states go
    into the flow network's working values `work` (thermo.flow_paths.flow_work), the flows of its paths
    (path_flows, then in `work.mass_flow`) are summed per node (sum_flows) into dm/dt and the enthalpy inflow of
    each chamber, which thermo.control_volume.chamber_derivatives turns into

        dT/dt = [ -T (dp/dT)_rho (dV/dt - v dm/dt) - h dm/dt + sum m_in h_up - sum m_out h ] / (m c_v)
    """
    leading, trailing = chamber_fluid_states(y, block, inputs, c, table)
    volume_leading, volume_trailing = volumes_with_dead_volume(inputs, c)
    t_l = y[block + LEADING_TEMPERATURE]
    t_t = y[block + TRAILING_TEMPERATURE]
    density_leading = y[block + LEADING_MASS] / volume_leading
    density_trailing = y[block + TRAILING_MASS] / volume_trailing
    suction, back = boundary_nodes(c, t)
    set_node(work, SUCTION, suction)
    set_node(work, LEADING, FlowNode(t_l, density_leading, leading.pressure, leading.enthalpy))
    set_node(work, TRAILING, FlowNode(t_t, density_trailing, trailing.pressure, trailing.enthalpy))
    set_node(work, BACK, back)
    status = path_flows(inputs, c, work, nozzles)
    sum_flows(c, work, rates, block)
    rates[block + LEADING_TEMPERATURE] = chamber_derivatives(
        t_l, density_leading, volume_leading, inputs.rate_leading, rates[block + LEADING_MASS],
        rates[block + LEADING_TEMPERATURE], 0.0, leading.enthalpy, leading.heat_capacity_v,
        leading.pressure_temperature_derivative, 0.0)[0]
    rates[block + TRAILING_TEMPERATURE] = chamber_derivatives(
        t_t, density_trailing, volume_trailing, inputs.rate_trailing, rates[block + TRAILING_MASS],
        rates[block + TRAILING_TEMPERATURE], 0.0, trailing.enthalpy, trailing.heat_capacity_v,
        trailing.pressure_temperature_derivative, 0.0)[0]
    rates[block + WORK_CHAMBERS] = -(leading.pressure * inputs.rate_leading + trailing.pressure * inputs.rate_trailing)
    return status, leading, trailing


@kernel
def chamber_energy(y, block, inputs, c, table):
    """(mass [kg], internal energy [J]) of the gas in the two chambers."""
    leading, trailing = chamber_fluid_states(y, block, inputs, c, table)
    volume_leading, volume_trailing = volumes_with_dead_volume(inputs, c)
    return (y[block + LEADING_MASS] + y[block + TRAILING_MASS],
            y[block + LEADING_MASS] * (leading.enthalpy - leading.pressure * volume_leading / y[block + LEADING_MASS])
            + y[block + TRAILING_MASS] * (trailing.enthalpy - trailing.pressure * volume_trailing / y[block + TRAILING_MASS]))


@kernel
def switch_chambers(t, y, block, old_inputs, new_inputs, c, table):
    """Chamber bookkeeping when the vane crosses a valley at time t (docs/model.md §7.2):

    the leading chamber (now the dead volume at the valley) becomes the new trailing chamber: its gas fills the new
    trailing volume, expanding adiabatically (T from u at the new density) if that volume is larger; if it is smaller
    (the slot pocket behind the tip is narrower than the one ahead of it when the vane leans towards the trailing
    wall; with a valley gap the tip's cap across the valley line counts against it), the trailing chamber keeps the
    gas at its density and the surplus passes over the slot mouth into the new leading chamber, where the pocket
    ahead of the tip lies at the switch (mixed at constant total internal energy). The trailing chamber becomes an idle lobe (vented to the suction
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
    suction = boundary_nodes(c, t)[0]
    suction_properties = table_properties(suction.temperature, suction.density, table)
    suction_energy = suction_properties[1] - suction_properties[0] / suction.density
    filled_mass = suction.density * new_leading
    if new_trailing >= old_leading:
        kept_mass = leading_mass
        kept_temperature = internal_energy_temperature(leading_energy, leading_mass / new_trailing,
                                                       y[block + LEADING_TEMPERATURE], table)
    else:
        kept_mass = leading_mass * new_trailing / old_leading
        kept_temperature = y[block + LEADING_TEMPERATURE]
    surplus = leading_mass - kept_mass
    new_leading_mass = filled_mass + surplus
    new_leading_temperature = suction.temperature
    if surplus > 0.0:
        mixed_energy = (filled_mass * suction_energy + surplus * leading_energy) / new_leading_mass
        new_leading_temperature = internal_energy_temperature(mixed_energy, new_leading_mass / new_leading,
                                                              suction.temperature, table)
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
