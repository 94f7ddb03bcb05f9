"""The flow network of the real-gas chambers (docs/model.md §7.4): its nodes, its flow paths as the rows of one
table (`FLOW_PATHS`), and the two generic compiled routines that evaluate every path's flow (`path_flows`) and sum
mass and energy per node (`sum_flows`), as PDSim's FlowPath and sumterms do.

Nodes (`NODES`): the suction plenum, which is also every idle lobe (open to its own suction port with a constant
volume, its state stays at suction conditions), the leading (L) and trailing (T) chambers, and the back node: the
discharge plenum and the back chamber, both at p_d on the suction isentrope. The routines take the nodes' states
(`FlowNode`) as an argument, the boundary nodes' with the chambers'.

A path runs from its source node to its target node (its flow is positive in that direction) through a section
set by its opening:
  SUCTION_PORT_AHEAD, SUCTION_PORT_BEHIND: the share of a port's area ahead of / behind the vane (the port spans
    the lobe phases [0, phi_sc], thermo.control_volume.port_coverage);
  CHECK_VALVE: a port's area while p_source > p_target, else closed;
  FIXED_GAP: a gap of constant height and friction-equivalent length;
  INPUT_GAP: a gap whose height and friction-equivalent length are fields of the chambers' ChamberInputs.
Its law and coefficient (thermo.leakage; a port is the nozzle law through its area), and the size, width and flow
length of its section, are named constants of the chamber model: thermo.chamber_model.chamber_constants resolves
the names of every row into per-path arrays of the constants record (`path_law`, `path_coefficient`, `path_size`,
`path_width`, `path_flow_length`). Its `ledger` names the cumulative boundary flow of the state block it crosses
(`BOUNDARY_FLOWS`; "" for a path between the two chambers).

Every path is a real-fluid isentropic nozzle (thermo.real_gas_nozzle, choked flow included) with its law: the
nozzle flux is looked up once per pair of nodes with an open path between them and serves every path of that pair.
A path whose throat is the gas-branch (metastable) continuation (nozzle status 8) is accepted and counted
(`ChamberFlows.metastable`); a pair whose upstream state the nozzle table refuses (status 1-7) gives its paths a NaN
flow and is counted in `ChamberFlows.refused`, which the loop treats as an invalid gas state.

The routines loop over a `Network` (`network_of` a path table): tuples of integer codes, which
thermo.chamber_model.chamber_rates receives as the default argument NETWORK, so that they are compile-time constants
of the compiled loop (a test may pass another network; it compiles a variant).
"""
from __future__ import annotations

from typing import NamedTuple

from numba.cpython.unsafe.tuple import tuple_setitem
from numba.extending import overload

from .chamber_state import (ENERGY_BACK_CHAMBER, ENERGY_DISCHARGE, ENERGY_SUCTION, LEADING_MASS, LEADING_TEMPERATURE,
                            MASS_BACK_CHAMBER, MASS_DISCHARGE, MASS_SUCTION, TRAILING_MASS, TRAILING_TEMPERATURE)
from .control_volume import port_coverage
from .kernel import kernel
from .leakage import leakage_path_open, real_gas_leakage_flow
from .property_table import STATUS_OK
from .real_gas_nozzle import STATUS_THROAT_NEAR_SATURATION, nozzle_flux_between


class FlowNode(NamedTuple):
    """A node of the flow network: temperature [K], density [kg/m^3], pressure [Pa], specific enthalpy [J/kg]."""
    temperature: float
    density: float
    pressure: float
    enthalpy: float


NODES = ("suction", "leading", "trailing", "back")
SUCTION, LEADING, TRAILING, BACK = range(len(NODES))
# a chamber node's balance in the state block: (net mass inflow = dm/dt, enthalpy inflow sum m_in h_up - m_out h);
# the enthalpy inflow is held in the chamber's temperature slot until chamber_model.chamber_rates turns it into dT/dt
CHAMBER_BALANCES = {LEADING: (LEADING_MASS, LEADING_TEMPERATURE), TRAILING: (TRAILING_MASS, TRAILING_TEMPERATURE)}

SUCTION_PORT_AHEAD, SUCTION_PORT_BEHIND, CHECK_VALVE, FIXED_GAP, INPUT_GAP = range(5)


class BoundaryFlow(NamedTuple):
    """A cumulative flow across the chambers' boundary in the state block: its mass and energy slots, and +1 if it
    counts what enters the chambers, -1 what leaves them."""
    name: str
    mass: int
    energy: int
    direction: float


BOUNDARY_FLOWS = (BoundaryFlow("suction_side", MASS_SUCTION, ENERGY_SUCTION, 1.0),
                  BoundaryFlow("discharge", MASS_DISCHARGE, ENERGY_DISCHARGE, -1.0),
                  BoundaryFlow("back_chamber", MASS_BACK_CHAMBER, ENERGY_BACK_CHAMBER, 1.0))


class FlowPath(NamedTuple):
    """One row of the flow network (module docstring). `size`, `flow_length`, `width`, `law` and `coefficient` name
    chamber constants (thermo.chamber_model.chamber_constants), except that an INPUT_GAP's `size` and `flow_length`
    name ChamberInputs fields; "" for a port's flow length, width (1: the size is the area) and law (nozzle)."""
    name: str
    source: int
    target: int
    opening: int
    size: str
    flow_length: str
    width: str
    law: str
    coefficient: str
    ledger: str


FLOW_PATHS = (
    FlowPath("suction_leading", SUCTION, LEADING, SUCTION_PORT_AHEAD, "suction_port_area", "", "", "",
             "suction_port_coefficient", "suction_side"),
    FlowPath("suction_trailing", SUCTION, TRAILING, SUCTION_PORT_BEHIND, "suction_port_area", "", "", "",
             "suction_port_coefficient", "suction_side"),
    FlowPath("end_valley_leak", LEADING, SUCTION, FIXED_GAP, "valley_gap", "valley_flow_length", "axial_length",
             "end_valley_law", "end_valley_coefficient", "suction_side"),
    FlowPath("start_valley_leak", TRAILING, SUCTION, FIXED_GAP, "valley_gap", "valley_flow_length", "axial_length",
             "start_valley_law", "start_valley_coefficient", "suction_side"),
    FlowPath("tip_leak", LEADING, TRAILING, INPUT_GAP, "tip_lift", "tip_flow_length", "axial_length", "tip_law",
             "tip_coefficient", ""),
    FlowPath("slot_leak_leading", BACK, LEADING, INPUT_GAP, "slot_gap_leading", "slot_flow_length_leading",
             "axial_length", "slot_law", "slot_coefficient", "back_chamber"),
    FlowPath("slot_leak_trailing", BACK, TRAILING, INPUT_GAP, "slot_gap_trailing", "slot_flow_length_trailing",
             "axial_length", "slot_law", "slot_coefficient", "back_chamber"),
    FlowPath("discharge", LEADING, BACK, CHECK_VALVE, "discharge_port_area", "", "", "",
             "discharge_port_coefficient", "discharge"),
)


class Network(NamedTuple):
    """A path table as the kernels read it: per path (in table order) its nodes, opening, the ChamberInputs indices
    of an INPUT_GAP, its node pair and orientation in it (+1: source -> target is the pair's a -> b), the state-block
    offsets of its source's and target's balances and of its boundary flow (-1: none) with the sign it is booked
    with; the node pairs (a < b); every offset `sum_flows` fills; a zero per path."""
    source: tuple
    target: tuple
    opening: tuple
    gap_field: tuple
    length_field: tuple
    pair: tuple
    orientation: tuple
    source_mass: tuple
    source_energy: tuple
    target_mass: tuple
    target_energy: tuple
    ledger_mass: tuple
    ledger_energy: tuple
    ledger_sign: tuple
    pairs: tuple
    balances: tuple
    zeros: tuple


def _ledger(path: FlowPath) -> tuple[int, int, float]:
    """(mass offset, energy offset, sign) of the boundary flow a path crosses; (-1, -1, 0) between the chambers."""
    if not path.ledger:
        return -1, -1, 0.0
    flows = {flow.name: flow for flow in BOUNDARY_FLOWS}
    if path.ledger not in flows:
        raise ValueError(f"flow path {path.name!r}: ledger={path.ledger!r} is out of range; allowed: "
                         f"'' or one of {', '.join(flows)}")
    into_chambers = 1.0 if path.target in CHAMBER_BALANCES else -1.0
    if (path.source in CHAMBER_BALANCES) == (path.target in CHAMBER_BALANCES):
        raise ValueError(f"flow path {path.name!r}: a boundary flow ({path.ledger!r}) needs one chamber node and "
                         f"one boundary node, not {NODES[path.source]} -> {NODES[path.target]}")
    flow = flows[path.ledger]
    return flow.mass, flow.energy, flow.direction * into_chambers


def network_of(paths: tuple[FlowPath, ...], input_fields: tuple[str, ...]) -> Network:
    """The kernels' Network of a path table; `input_fields` are the ChamberInputs field names (INPUT_GAP sizes)."""
    pairs = []
    for path in paths:
        if not (0 <= path.source < len(NODES) and 0 <= path.target < len(NODES) and path.source != path.target):
            raise ValueError(f"flow path {path.name!r}: nodes {path.source!r} -> {path.target!r} are out of range; "
                             f"allowed: two different nodes of {NODES}")
        pair = (min(path.source, path.target), max(path.source, path.target))
        if pair not in pairs:
            pairs.append(pair)
    gaps = [path.opening == INPUT_GAP for path in paths]
    ledgers = [_ledger(path) for path in paths]
    none = (-1, -1)
    balances = sorted({slot for balance in CHAMBER_BALANCES.values() for slot in balance}
                      | {slot for flow in BOUNDARY_FLOWS for slot in (flow.mass, flow.energy)})
    return Network(
        source=tuple(p.source for p in paths), target=tuple(p.target for p in paths),
        opening=tuple(p.opening for p in paths),
        gap_field=tuple(input_fields.index(p.size) if gap else 0 for p, gap in zip(paths, gaps)),
        length_field=tuple(input_fields.index(p.flow_length) if gap else 0 for p, gap in zip(paths, gaps)),
        pair=tuple(pairs.index((min(p.source, p.target), max(p.source, p.target))) for p in paths),
        orientation=tuple(1.0 if p.source < p.target else -1.0 for p in paths),
        source_mass=tuple(CHAMBER_BALANCES.get(p.source, none)[0] for p in paths),
        source_energy=tuple(CHAMBER_BALANCES.get(p.source, none)[1] for p in paths),
        target_mass=tuple(CHAMBER_BALANCES.get(p.target, none)[0] for p in paths),
        target_energy=tuple(CHAMBER_BALANCES.get(p.target, none)[1] for p in paths),
        ledger_mass=tuple(ledger[0] for ledger in ledgers), ledger_energy=tuple(ledger[1] for ledger in ledgers),
        ledger_sign=tuple(ledger[2] for ledger in ledgers), pairs=tuple(pairs), balances=tuple(balances),
        zeros=(0.0,) * len(paths))


def path_index(paths: tuple[FlowPath, ...] = FLOW_PATHS):
    """The paths' indices by name (`PATH.tip_leak`): ChamberFlows.mass_flow[PATH.<name>] is that path's flow."""
    return NamedTuple("PathIndex", [(p.name, int) for p in paths])(*range(len(paths)))


PATH = path_index()


class ChamberFlows(NamedTuple):
    """Mass flow [kg/s] of every path in its direction (`mass_flow[PATH.<name>]`), and how many node pairs the
    nozzle table refused (their paths' flow is NaN) or continued through a metastable throat (status 8)."""
    mass_flow: tuple
    refused: int
    metastable: int


def replaced(values: tuple, index: int, value) -> tuple:
    """`values` with item `index` replaced by `value` (compiled: on the stack, numba's tuple_setitem)."""
    return values[:index] + (value,) + values[index + 1:]


@overload(replaced)
def _replaced_compiled(values, index, value):
    return lambda values, index, value: tuple_setitem(values, index, value)


@kernel
def path_section(p, inputs, c, nodes, network):
    """(size, friction-equivalent flow length) of path p's section: the area [m^2] of a port (its width is 1) or
    the height [m] of a gap (module docstring)."""
    opening = network.opening[p]
    if opening == INPUT_GAP:
        return inputs[network.gap_field[p]], inputs[network.length_field[p]]
    size = c.path_size[p]
    if opening == SUCTION_PORT_AHEAD:
        size = size * port_coverage(inputs.vane_phase, 0.0, c.suction_close_angle)
    elif opening == SUCTION_PORT_BEHIND:
        size = size - size * port_coverage(inputs.vane_phase, 0.0, c.suction_close_angle)
    elif opening == CHECK_VALVE and not nodes[network.source[p]].pressure > nodes[network.target[p]].pressure:
        size = 0.0
    return size, c.path_flow_length[p]


@kernel
def path_flows(inputs, c, nodes, nozzles, network):
    """The ChamberFlows of every path of `network` between the FlowNodes `nodes` (indexed by node code) at the
    chambers' ChamberInputs (docs/model.md §7.4); the nozzle flux of a node pair is looked up only if a path between
    them is open, once for all of them."""
    sizes = network.zeros
    lengths = network.zeros
    for p in range(len(network.zeros)):
        size, length = path_section(p, inputs, c, nodes, network)
        sizes = replaced(sizes, p, size)
        lengths = replaced(lengths, p, length)
    flows = network.zeros
    refused = 0
    metastable = 0
    for k in range(len(network.pairs)):
        needed = False
        for p in range(len(network.zeros)):
            if network.pair[p] == k and leakage_path_open(c.path_law[p], sizes[p], c.path_width[p]):
                needed = True
        if not needed:
            continue
        a = nodes[network.pairs[k][0]]
        b = nodes[network.pairs[k][1]]
        flux, factor, status = nozzle_flux_between(a.temperature, a.density, a.pressure, b.temperature, b.density,
                                                   b.pressure, nozzles)
        metastable += status == STATUS_THROAT_NEAR_SATURATION
        refused += status != STATUS_OK and status != STATUS_THROAT_NEAR_SATURATION
        upstream = a if factor >= 0.0 else b
        for p in range(len(network.zeros)):
            if network.pair[p] == k:
                flows = replaced(flows, p, network.orientation[p] * real_gas_leakage_flow(
                    c.path_law[p], c.path_coefficient[p], sizes[p], lengths[p], c.path_width[p], flux, factor,
                    upstream.temperature, upstream.density, nozzles))
    return ChamberFlows(flows, refused, metastable)


@kernel
def sum_flows(flows, nodes, rates, block, network):
    """Sum mass and energy per node (docs/model.md §7.3-§7.4) into the state block of `rates` (from index `block`):
    each chamber's net mass inflow dm/dt into its mass slot and its enthalpy inflow sum m_in h_up - sum m_out h into
    its temperature slot (chamber_rates turns that into dT/dt), and each boundary flow of BOUNDARY_FLOWS. A path's
    energy flow is its mass flow times the upwind node's enthalpy."""
    for offset in network.balances:
        rates[block + offset] = 0.0
    for p in range(len(network.zeros)):
        flow = flows.mass_flow[p]
        energy = flow * (nodes[network.source[p]].enthalpy if flow > 0.0 else nodes[network.target[p]].enthalpy)
        if network.source_mass[p] >= 0:
            rates[block + network.source_mass[p]] -= flow
            rates[block + network.source_energy[p]] -= energy
        if network.target_mass[p] >= 0:
            rates[block + network.target_mass[p]] += flow
            rates[block + network.target_energy[p]] += energy
        if network.ledger_mass[p] >= 0:
            rates[block + network.ledger_mass[p]] += network.ledger_sign[p] * flow
            rates[block + network.ledger_energy[p]] += network.ledger_sign[p] * energy
