"""The flow network of the real-gas chambers (docs/model.md §7.4): its nodes, its flow paths as the rows of one
table (`FLOW_PATHS`), and the two generic compiled routines that evaluate every path's flow (`path_flows`) and sum
mass and energy per node (`sum_flows`), as PDSim's FlowPath and sumterms do.

Nodes (`NODES`): the suction plenum, which is also every idle lobe (open to its own suction port with a constant
volume, its state stays at suction conditions), the leading (L) and trailing (T) chambers, and the back node: the
discharge plenum and the back chamber, both at p_d on the suction isentrope. The routines read every node's state
(`FlowNode`) from the network's working values (`flow_work`), where the caller writes the chambers' and the
boundary nodes' states (`set_node`).

A path runs from its source node to its target node (its flow is positive in that direction) through a section
set by its opening:
  SUCTION_PORT_AHEAD, SUCTION_PORT_BEHIND: the share of a port's area ahead of / behind the vane (the port spans
    the lobe phases [0, phi_sc], thermo.control_volume.port_coverage);
  CHECK_VALVE: a port's area while p_source > p_target, else closed;
  FIXED_GAP: a gap of constant height and friction-equivalent length;
  INPUT_GAP: a gap whose height and friction-equivalent length are fields of the chambers' ChamberInputs.
Its law and coefficient (thermo.leakage; a port is the nozzle law through its area), and the size, width and flow
length of its section, are named constants of the chamber model. Its `ledger` names the cumulative boundary flow of
the state block it crosses (`BOUNDARY_FLOWS`; "" for a path between the two chambers).

Every path is a real-fluid isentropic nozzle (thermo.real_gas_nozzle, choked flow included) with its law: the
nozzle flux is looked up once per pair of nodes with an open path between them and serves every path of that pair.
A path whose throat is the gas-branch (metastable) continuation (nozzle status 8) is accepted and counted
(`FlowStatus.metastable`); a pair whose upstream state the nozzle table refuses (status 1-7) gives its paths a NaN
flow and is counted in `FlowStatus.refused`, which the loop treats as an invalid gas state.

The table is data at run time: thermo.chamber_model.chamber_constants resolves every row into per-path arrays of
the constants record, the named values (`path_law`, `path_coefficient`, `path_size`, `path_width`,
`path_flow_length`) and the integer tables of `network_tables` (`path_source`, `path_pair`, ..., and per node pair
`pair_first`, `pair_second`), so the routines are plain loops over array entries and another table (a test's
extra row) needs no other code.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .chamber_state import (ENERGY_BACK_CHAMBER, ENERGY_DISCHARGE, ENERGY_SUCTION, LEADING_MASS, LEADING_TEMPERATURE,
                            MASS_BACK_CHAMBER, MASS_DISCHARGE, MASS_SUCTION, TRAILING_MASS, TRAILING_TEMPERATURE)
from .control_volume import port_coverage
from ..kernels.kernel import kernel, kernel_record
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
# every state-block slot sum_flows fills
BALANCE_SLOTS = tuple(sorted({slot for balance in CHAMBER_BALANCES.values() for slot in balance}
                             | {slot for flow in BOUNDARY_FLOWS for slot in (flow.mass, flow.energy)}))


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


MAX_PAIRS = 63                     # path_flows marks the pairs it needs as the bits of one integer


def node_pairs(paths: tuple[FlowPath, ...]) -> list[tuple[int, int]]:
    """The node pairs (a, b), a < b, with a path between them, in the order of their first path."""
    pairs = []
    for path in paths:
        if not (0 <= path.source < len(NODES) and 0 <= path.target < len(NODES) and path.source != path.target):
            raise ValueError(f"flow path {path.name!r}: nodes {path.source!r} -> {path.target!r} are out of range; "
                             f"allowed: two different nodes of {NODES}")
        pair = (min(path.source, path.target), max(path.source, path.target))
        if pair not in pairs:
            pairs.append(pair)
    if len(pairs) > MAX_PAIRS:
        raise ValueError(f"flow paths: {len(pairs)} node pairs is out of range; allowed: at most {MAX_PAIRS}")
    return pairs


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


def network_tables(paths: tuple[FlowPath, ...], input_fields: tuple[str, ...]) -> dict[str, list]:
    """The integer tables the kernels read of a path table, as lists by name (thermo.chamber_model.chamber_constants
    stores them in the constants record as `path_<name>` per path and `pair_first`, `pair_second` per node pair).
    Per path: its nodes, opening, the ChamberInputs indices of an INPUT_GAP's height and length (`input_fields`:
    the ChamberInputs field names), its node pair and orientation in it (+1: source -> target is the pair's
    first -> second), the state-block offsets of its source's and target's balances and of its boundary flow (-1:
    none) with the sign it is booked with."""
    pairs = node_pairs(paths)
    gaps = [path.opening == INPUT_GAP for path in paths]
    ledgers = [_ledger(path) for path in paths]
    none = (-1, -1)
    return dict(
        source=[p.source for p in paths], target=[p.target for p in paths], opening=[p.opening for p in paths],
        input_size=[input_fields.index(p.size) if gap else 0 for p, gap in zip(paths, gaps)],
        input_length=[input_fields.index(p.flow_length) if gap else 0 for p, gap in zip(paths, gaps)],
        pair=[pairs.index((min(p.source, p.target), max(p.source, p.target))) for p in paths],
        orientation=[1.0 if p.source < p.target else -1.0 for p in paths],
        source_mass=[CHAMBER_BALANCES.get(p.source, none)[0] for p in paths],
        source_energy=[CHAMBER_BALANCES.get(p.source, none)[1] for p in paths],
        target_mass=[CHAMBER_BALANCES.get(p.target, none)[0] for p in paths],
        target_energy=[CHAMBER_BALANCES.get(p.target, none)[1] for p in paths],
        ledger_mass=[ledger[0] for ledger in ledgers], ledger_energy=[ledger[1] for ledger in ledgers],
        ledger_sign=[ledger[2] for ledger in ledgers])


def flow_work(paths: tuple[FlowPath, ...], input_fields: tuple[str, ...]) -> np.ndarray:
    """The flow network's working values as a one-row structured array, written by every evaluation before they are
    read (the caller allocates it once, as the loop's workspace rows): the chambers' inputs as an array (`inputs`,
    `input_fields` the ChamberInputs field names: an INPUT_GAP reads its height and length by index, and a named
    tuple read by a run-time index costs a branch per read), per node its state (`temperature` [K], `density`
    [kg/m^3], `pressure` [Pa], `enthalpy` [J/kg]), per path the size and flow length of its section (`section`,
    `section_length`) and its mass flow [kg/s] in its direction (`mass_flow[PATH.<name>]`), per node pair the nozzle
    flux and its signed factor (`flux`, `flux_factor`); and the node states of the last evaluation a table refused
    (`refused_temperature`, `refused_density`, at time `refused_time`, NaN until then: `note_refused`), so that a
    run stopped by a refused state can say which state of the failed attempt left the tables."""
    pairs = len(node_pairs(paths))
    dtype = np.dtype([("inputs", np.float64, (len(input_fields),))]
                     + [(name, np.float64, (len(NODES),)) for name in FlowNode._fields]
                     + [(name, np.float64, (len(NODES),)) for name in ("refused_temperature", "refused_density")]
                     + [("refused_time", np.float64)]
                     + [(name, np.float64, (len(paths),)) for name in ("section", "section_length", "mass_flow")]
                     + [(name, np.float64, (pairs,)) for name in ("flux", "flux_factor")])
    work = np.zeros(1, dtype=dtype)
    work["refused_time"] = np.nan
    return kernel_record(work)


def path_index(paths: tuple[FlowPath, ...] = FLOW_PATHS):
    """The paths' indices by name (`PATH.tip_leak`): `mass_flow[PATH.<name>]` of the working values is that path's
    flow."""
    return NamedTuple("PathIndex", [(p.name, int) for p in paths])(*range(len(paths)))


PATH = path_index()


class FlowStatus(NamedTuple):
    """How many node pairs the nozzle table refused (their paths' flow is NaN) or continued through a metastable
    throat (status 8) in one evaluation of the network."""
    refused: int
    metastable: int


@kernel
def set_node(work, node, state):
    """Write the FlowNode `state` of node `node` into the working values (`flow_work`)."""
    work.temperature[node] = state.temperature
    work.density[node] = state.density
    work.pressure[node] = state.pressure
    work.enthalpy[node] = state.enthalpy


@kernel
def note_refused(t, work):
    """Keep the node states of an evaluation at time t that a table refused (`flow_work`'s `refused_*`), unless a
    state is not a number: a stage computed from a refused stage's NaN rates says nothing of how the state left."""
    for node in range(len(NODES)):
        if not (math.isfinite(work.temperature[node]) and math.isfinite(work.density[node])):
            return
    for node in range(len(NODES)):
        work.refused_temperature[node] = work.temperature[node]
        work.refused_density[node] = work.density[node]
    work.refused_time = t


@kernel
def path_section(p, inputs, c, work):
    """(size, friction-equivalent flow length) of path p's section: the area [m^2] of a port (its width is 1) or
    the height [m] of a gap (module docstring)."""
    opening = c.path_opening[p]
    if opening == INPUT_GAP:
        return work.inputs[c.path_input_size[p]], work.inputs[c.path_input_length[p]]
    size = c.path_size[p]
    if opening == SUCTION_PORT_AHEAD:
        size = size * port_coverage(inputs.vane_phase, 0.0, c.suction_close_angle)
    elif opening == SUCTION_PORT_BEHIND:
        size = size - size * port_coverage(inputs.vane_phase, 0.0, c.suction_close_angle)
    elif opening == CHECK_VALVE and not work.pressure[c.path_source[p]] > work.pressure[c.path_target[p]]:
        size = 0.0
    return size, c.path_flow_length[p]


@kernel
def path_flows(inputs, c, work, nozzles):
    """Every path's mass flow into `work.mass_flow` (docs/model.md §7.4), between the node states of `work` at the
    chambers' ChamberInputs `inputs`; returns the FlowStatus. Three passes: each path's section, marking the node
    pairs with an open path; the nozzle flux of each marked pair, looked up once for all its paths; each path's
    flow."""
    for i in range(len(inputs)):
        work.inputs[i] = inputs[i]
    needed = 0
    for p in range(len(work.mass_flow)):
        size, length = path_section(p, inputs, c, work)
        work.section[p] = size
        work.section_length[p] = length
        if leakage_path_open(c.path_law[p], size, c.path_width[p]):
            needed |= 1 << c.path_pair[p]
    refused = 0
    metastable = 0
    for k in range(len(work.flux)):
        flux, factor, status = 0.0, 0.0, STATUS_OK
        if needed >> k & 1:
            a = c.pair_first[k]
            b = c.pair_second[k]
            flux, factor, status = nozzle_flux_between(work.temperature[a], work.density[a], work.pressure[a],
                                                       work.temperature[b], work.density[b], work.pressure[b],
                                                       nozzles)
        metastable += status == STATUS_THROAT_NEAR_SATURATION
        refused += status != STATUS_OK and status != STATUS_THROAT_NEAR_SATURATION
        work.flux[k] = flux
        work.flux_factor[k] = factor
    for p in range(len(work.mass_flow)):
        k = c.path_pair[p]
        factor = work.flux_factor[k]
        upstream = c.pair_first[k] if factor >= 0.0 else c.pair_second[k]
        work.mass_flow[p] = c.path_orientation[p] * real_gas_leakage_flow(
            c.path_law[p], c.path_coefficient[p], work.section[p], work.section_length[p], c.path_width[p],
            work.flux[k], factor, work.temperature[upstream], work.density[upstream], nozzles)
    return FlowStatus(refused, metastable)


@kernel
def sum_flows(c, work, rates, block):
    """Sum mass and energy per node (docs/model.md §7.3-§7.4) into the state block of `rates` (from index `block`):
    each chamber's net mass inflow dm/dt into its mass slot and its enthalpy inflow sum m_in h_up - sum m_out h into
    its temperature slot (chamber_rates turns that into dT/dt), and each boundary flow of BOUNDARY_FLOWS. A path's
    energy flow is its mass flow (`work.mass_flow`) times the upwind node's enthalpy."""
    for offset in BALANCE_SLOTS:
        rates[block + offset] = 0.0
    for p in range(len(work.mass_flow)):
        flow = work.mass_flow[p]
        energy = flow * (work.enthalpy[c.path_source[p]] if flow > 0.0 else work.enthalpy[c.path_target[p]])
        if c.path_source_mass[p] >= 0:
            rates[block + c.path_source_mass[p]] -= flow
            rates[block + c.path_source_energy[p]] -= energy
        if c.path_target_mass[p] >= 0:
            rates[block + c.path_target_mass[p]] += flow
            rates[block + c.path_target_energy[p]] += energy
        if c.path_ledger_mass[p] >= 0:
            rates[block + c.path_ledger_mass[p]] += c.path_ledger_sign[p] * flow
            rates[block + c.path_ledger_energy[p]] += c.path_ledger_sign[p] * energy
