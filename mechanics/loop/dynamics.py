"""One evaluation of the reduced equations of motion, stage by stage (docs/model.md §8.1b):

kinematics (mechanics.geometry.kinematics) -> contacts (mechanics.contact.detection, mechanics.contact.contact_forces)
-> chamber pressures (the Level 0/0.5 table, or the real-gas chamber model at the chamber geometry of this pose:
thermo.chamber_model, mechanics.geometry.chamber_geometry) -> gas loads (mechanics.gas.gas_loads) -> equations of motion
-> reported outputs.

`evaluate` is the right-hand side of the whole state (vane and, under real gas, the chamber block) for both
integrators and the source of the output row.
"""
import math
from typing import NamedTuple

import numpy as np

from ...kernels.kernel import kernel
from ...thermo.chamber_model import (GAS_STATE_SIZE, LEADING_MASS, LEADING_TEMPERATURE, MASS_SUCTION,
                                     TRAILING_MASS, TRAILING_TEMPERATURE, ChamberInputs, chamber_energy,
                                     chamber_rates, volumes_with_dead_volume)
from ...thermo.flow_paths import BACK, PATH, SUCTION, note_refused
from ...thermo.leakage import parabolic_flank_length, tapered_gap_length
from ...thermo.property_table import PropertyTable, table_quality
from ...thermo.real_gas_nozzle import NozzleTable

from ..geometry.chamber_geometry import SectorTable, chamber_geometry
from ..contact.detection import slot_contacts, tip_contact
from ..contact.contact_forces import contact_loads
from ..gas.gas_loads import combine, gap_moment, gas_load_basis, slot_side
from ..geometry.kinematics import pose_of, reported_kinematics, vane_pose
from .layout import (ANGULAR_VELOCITY, ANGLE, GAS_BLOCK, GAS_STATE_INVALID, MEM_CLOSEST_OFFSET, MEM_LOBE_COUNT,
                     MEM_LOBE_START, TIP_ON_FLAT_FACE, VX, VY, WORK_DAMPING, WORK_ELASTIC, WORK_FRICTION,
                     WORK_GAP, WORK_IN, WORK_INDICATED, WORK_OUT, X, Y)
from .machine import REAL_GAS_MODEL
from .outputs import O, OUTPUT_NAMES, REAL_GAS_COLUMNS

REAL_GAS_FIRST_COLUMN = O.leading_temperature
REAL_GAS_COLUMN_COUNT = len(REAL_GAS_COLUMNS)
assert REAL_GAS_COLUMNS == OUTPUT_NAMES[REAL_GAS_FIRST_COLUMN:REAL_GAS_FIRST_COLUMN + REAL_GAS_COLUMN_COUNT], \
    "the real-gas columns are declared last, together"


class KernelContext(NamedTuple):
    """Everything an evaluation reads besides the state and the memory: the machine constants (record), the speed
    law, the Level 0/0.5 p_L(phase) table, the chamber model's constants (record), the flow network's working values
    (record, thermo.flow_paths.flow_work: written by every evaluation), the fluid property table, the real-gas nozzle
    table (thermo.real_gas_nozzle) and the stator sector table."""
    machine: np.ndarray
    law: np.ndarray
    pressure_table: np.ndarray
    chambers: np.ndarray
    flow_work: np.ndarray
    properties: PropertyTable
    nozzles: NozzleTable
    sectors: SectorTable


@kernel
def leading_pressure_from_table(phase, table, lobes):
    """p_L(phi) by linear interpolation of a uniform table over the lobe phase [0, 2 pi/z] (docs/model.md §6.1)."""
    last = table.size - 1
    position = phase / (2.0 * math.pi / lobes) * last
    if position <= 0.0:
        return table[0]
    if position >= last:
        return table[last]
    i = int(position)
    w = position - i
    return table[i] * (1.0 - w) + table[i + 1] * w


@kernel
def table_pressures(pose, memory, m, pressure_table):
    """(p_L, p_T, p_b) of the Level 0/0.5 models (docs/model.md §6.1): the table read at the vane's lobe phase, the
    trailing chamber at suction, the back chamber at discharge pressure."""
    phase = pose.theta - memory[MEM_LOBE_START]
    return (leading_pressure_from_table(phase, pressure_table, m.lobes), m.suction_pressure, m.discharge_pressure)


@kernel
def tip_gap(tip):
    """(lift-off [m], friction-equivalent flow length [m]) of the gap between the tip circle and the stator
    (docs/model.md §7.4): a line seal h = delta + x^2/(2 R) with 1/R = 1/rho - kappa_S, the curvatures of the
    tip candidate (docs/model.md §4.4), L_eq = (3 pi/8) sqrt(2 R delta)."""
    lift = max(0.0, -tip.candidate.penetration)
    radius = 1.0 / (tip.candidate.vane_curvature + tip.candidate.other_curvature)
    return lift, 2.0 * parabolic_flank_length(lift, radius)


@kernel
def slot_face_gap(mouth, bottom, side, m):
    """(narrowest height [m], friction-equivalent flow length [m]) of the gap between one side face of the vane
    and its slot wall, from the back chamber to the chamber (docs/model.md §7.4). The face and the wall are flat,
    so the height varies linearly from the bottom corner (region c3/c4: -delta) to the slot mouth (c1/c2: -delta
    of its candidate, the bottom corner's if it has none) along the engaged length, from the bottom face xi_B to
    the mouth level xi_E or, when the tip is inside the slot, to the tip centre xi_T; it is closed where the vane
    touches the wall."""
    bottom_gap = max(0.0, -bottom.penetration)
    mouth_gap = max(0.0, -mouth.penetration) if math.isfinite(mouth.penetration) else bottom_gap
    engaged = max(0.0, min(side.mouth_level, m.tip_centre) - m.bottom_face)
    return min(bottom_gap, mouth_gap), tapered_gap_length(bottom_gap, mouth_gap, engaged)


@kernel
def chamber_inputs(pose, slots, tip, sides, geometry, memory, m):
    """What the chamber model needs of this pose: the geometry of docs/model.md §7.2, the lobe phase, the tip and
    side-face gaps (§7.4)."""
    lift, tip_length = tip_gap(tip)
    gap_leading, length_leading = slot_face_gap(slots.mouth_leading, slots.bottom_leading, sides[0], m)
    gap_trailing, length_trailing = slot_face_gap(slots.mouth_trailing, slots.bottom_trailing, sides[1], m)
    return ChamberInputs(geometry.volume_leading, geometry.volume_trailing, geometry.rate_leading,
                         geometry.rate_trailing, pose.theta - memory[MEM_LOBE_START], lift, tip_length,
                         gap_leading, length_leading, gap_trailing, length_trailing)


@kernel
def chamber_powers(geometry, pressures):
    """(indicated power, gap power) of docs/model.md §6.4 over the leading, trailing and back chambers:
    P_ind = -sum_sigma p_sigma dV_sigma/dt,  P_gap = sum_sigma p_sigma gap_sigma;  P_out = -P_gas = P_ind + P_gap."""
    indicated = -(pressures[0] * geometry.rate_leading + pressures[1] * geometry.rate_trailing
                  + pressures[2] * geometry.rate_back)
    gap = pressures[0] * geometry.gap_leading + pressures[1] * geometry.gap_trailing + pressures[2] * geometry.gap_back
    return indicated, gap


@kernel
def chamber_work_rates(geometry, pressures, dydt):
    """dW_ind/dt = P_ind and dW_gap/dt = P_gap (docs/model.md §6.4): the two parts of W_out integrated as states, so
    the ledger's terms are work differences like the others (the steps of the same method; a trapezoidal sum over the
    accepted steps left the ledger of an impacting vane at 1.1e-4 of the shaft work). Returns (P_ind, P_gap), which
    the output row reports."""
    indicated, gap = chamber_powers(geometry, pressures)
    dydt[WORK_INDICATED] = indicated
    dydt[WORK_GAP] = gap
    return indicated, gap


@kernel
def equations_of_motion(pose, contacts, gas, m, dydt):
    """Reduced equations of motion (docs/model.md §3.1) and the work integrals (§6.4); returns (a_x, a_y, alpha,
    T_d):  q_ddot3 = Q3/[m3, m3, J3];  lambda6 = Q2phi - J2 theta_ddot;  T_d = -lambda6;
    dW_in/dt = T_d omega,  dW_out/dt = -P_gas,  dW_fric/dt = P_fric,  dW_damp/dt = P_damp,  dW_el/dt = P_el."""
    ax = (contacts.vane_fx + gas.fx) / m.vane_mass
    ay = (contacts.vane_fy + gas.fy) / m.vane_mass
    alpha = (contacts.vane_moment + gas.moment) / m.vane_inertia
    driving_torque = m.rotor_inertia * pose.theta_ddot - (contacts.rotor_moment + gas.rotor_moment)
    dydt[X] = pose.vx
    dydt[Y] = pose.vy
    dydt[ANGLE] = pose.phi_dot
    dydt[VX] = ax
    dydt[VY] = ay
    dydt[ANGULAR_VELOCITY] = alpha
    dydt[WORK_IN] = driving_torque * pose.omega
    dydt[WORK_OUT] = -gas.power
    dydt[WORK_FRICTION] = contacts.friction_power
    dydt[WORK_DAMPING] = contacts.damping_power
    dydt[WORK_ELASTIC] = contacts.elastic_power
    return ax, ay, alpha, driving_torque


@kernel
def report_outputs(t, y, pose, slots, tip, sides, contacts, gas, accelerations, pressures, suction_pressure, geometry,
                   powers, memory, m, out):
    """Write the reported quantities of the output row (docs/model.md §3.4, §6.4); the per-region ones were written
    by contact_loads, the real-gas ones are written by the chamber step (NaN here). `pressures`: (p_L, p_T, p_b);
    `suction_pressure`: p_s of the moment; `powers`: (P_ind, P_gap) of chamber_work_rates."""
    ax, ay, alpha, driving_torque = accelerations
    kinematics = reported_kinematics(pose, ax, ay, alpha, m)
    out[O.time] = t
    out[O.rotor_angle] = pose.theta
    out[O.rotor_speed] = pose.omega
    out[O.rotor_acceleration] = pose.theta_ddot
    out[O.vane_displacement] = kinematics[0]
    out[O.vane_radial_velocity] = kinematics[1]
    out[O.vane_radial_acceleration] = kinematics[2]
    out[O.vane_tangential_velocity] = kinematics[3]
    out[O.vane_tangential_acceleration] = kinematics[4]
    out[O.vane_tilt] = pose.phi - pose.theta
    out[O.contact_mode] = contacts.mode
    out[O.mouth_candidate_1] = slots.mouth_leading.kind
    out[O.mouth_candidate_2] = slots.mouth_trailing.kind
    out[O.stator_force_x] = contacts.stator_fx
    out[O.stator_force_y] = contacts.stator_fy
    out[O.stator_contact_moment] = contacts.stator_moment
    out[O.stator_gas_moment] = gas.stator_moment
    out[O.stator_reaction_moment] = contacts.stator_moment + gas.stator_moment
    out[O.gap_moment] = gap_moment(pose, sides, tip, pressures[0], pressures[1], suction_pressure, m)
    out[O.rotor_force_x] = contacts.rotor_fx
    out[O.rotor_force_y] = contacts.rotor_fy
    out[O.driving_torque] = driving_torque
    out[O.input_power] = driving_torque * pose.omega
    out[O.output_power] = -gas.power
    out[O.friction_power] = contacts.friction_power
    out[O.damping_power] = contacts.damping_power
    out[O.indicated_power], out[O.gap_power] = powers
    out[O.leading_volume] = geometry.volume_leading + m.dead_volume
    out[O.trailing_volume] = geometry.volume_trailing + m.dead_volume
    out[O.back_volume] = geometry.volume_back
    out[O.leading_pressure] = pressures[0]
    out[O.trailing_pressure] = pressures[1]
    out[O.kinetic_energy] = (0.5 * m.vane_mass * (pose.vx * pose.vx + pose.vy * pose.vy)
                             + 0.5 * m.vane_inertia * pose.phi_dot * pose.phi_dot)
    out[O.contact_energy] = contacts.elastic_energy
    out[O.contact_law_excess] = contacts.law_excess
    out[O.contact_angle] = math.atan2(tip.sin_contact_angle, tip.cos_contact_angle)
    offset = tip.closest_parameter - math.atan2(pose.tip_y, pose.tip_x)
    out[O.closest_parameter_offset] = offset - 2.0 * math.pi * math.floor(offset / (2.0 * math.pi) + 0.5)
    out[O.lobe_count] = memory[MEM_LOBE_COUNT]
    out[O.work_in] = y[WORK_IN]
    out[O.work_out] = y[WORK_OUT]
    out[O.work_friction] = y[WORK_FRICTION]
    out[O.work_damping] = y[WORK_DAMPING]
    out[O.work_elastic] = y[WORK_ELASTIC]
    out[O.work_indicated] = y[WORK_INDICATED]
    out[O.work_gap] = y[WORK_GAP]
    for k in range(REAL_GAS_COLUMN_COUNT):
        out[REAL_GAS_FIRST_COLUMN + k] = math.nan


@kernel
def report_chambers(out, y, inputs, work, status, leading, trailing, c, table):
    """The real-gas columns of the output row, from the chamber state block of y at its geometry and the flow
    network's working values `work` and FlowStatus `status` of chamber_rates there."""
    out[O.leading_temperature] = y[GAS_BLOCK + LEADING_TEMPERATURE]
    out[O.trailing_temperature] = y[GAS_BLOCK + TRAILING_TEMPERATURE]
    volume_leading, volume_trailing = volumes_with_dead_volume(inputs, c)
    out[O.leading_quality] = table_quality(y[GAS_BLOCK + LEADING_TEMPERATURE],
                                           y[GAS_BLOCK + LEADING_MASS] / volume_leading, table)
    out[O.trailing_quality] = table_quality(y[GAS_BLOCK + TRAILING_TEMPERATURE],
                                            y[GAS_BLOCK + TRAILING_MASS] / volume_trailing, table)
    mass, energy = chamber_energy(y, GAS_BLOCK, inputs, c, table)
    out[O.chamber_mass] = mass
    out[O.chamber_internal_energy] = energy
    flow = work.mass_flow
    out[O.suction_mass_flow] = flow[PATH.suction_leading] + flow[PATH.suction_trailing]
    out[O.discharge_mass_flow] = flow[PATH.discharge]
    out[O.tip_leak_mass_flow] = flow[PATH.tip_leak]
    out[O.end_valley_leak_mass_flow] = flow[PATH.end_valley_leak]
    out[O.start_valley_leak_mass_flow] = flow[PATH.start_valley_leak]
    out[O.slot_leak_leading_mass_flow] = flow[PATH.slot_leak_leading]
    out[O.slot_leak_trailing_mass_flow] = flow[PATH.slot_leak_trailing]
    out[O.metastable_flow_paths] = status.metastable
    for k in range(GAS_STATE_SIZE - MASS_SUCTION):
        out[O.mass_suction + k] = y[GAS_BLOCK + MASS_SUCTION + k]


@kernel
def pose_stages(t, y, ctx, memory):
    """The pressure-independent stages of an evaluation: pose, the slot and tip candidates (the features the regions
    of mechanics.contact.regions and the gas loads share; contact_loads builds the region candidates from them), slot
    sides, unit gas loads."""
    m = ctx.machine[0]
    pose = vane_pose(t, y, ctx.law, m)
    slots = slot_contacts(pose, m)
    tip = tip_contact(pose, memory[MEM_CLOSEST_OFFSET], m)
    sides = (slot_side(1.0, pose, m), slot_side(-1.0, pose, m))
    return pose, slots, tip, sides, gas_load_basis(pose, sides, tip, slots, m)


@kernel
def chamber_geometry_of(gx, gy, phi, vx, vy, phi_dot, theta, omega, lobe_start, m, table):
    """The ChamberGeometry (docs/model.md §7.2) of a vane pose and velocity at rotor angle theta and speed omega in
    the lobe starting at lobe_start (the closest stator point is searched from the tip's polar angle)."""
    pose = pose_of(gx, gy, phi, theta, m, vx, vy, phi_dot, omega, 0.0)
    slots = slot_contacts(pose, m)
    tip = tip_contact(pose, 0.0, m)
    sides = (slot_side(1.0, pose, m), slot_side(-1.0, pose, m))
    return chamber_geometry(pose, tip, sides, gas_load_basis(pose, sides, tip, slots, m), lobe_start, m, table)


@kernel
def chamber_inputs_at(t, y, ctx, memory):
    """The ChamberInputs of the state (t, y) (the valley switch compares them before and after)."""
    pose, slots, tip, sides, basis = pose_stages(t, y, ctx, memory)
    m = ctx.machine[0]
    geometry = chamber_geometry(pose, tip, sides, basis, memory[MEM_LOBE_START], m, ctx.sectors)
    return chamber_inputs(pose, slots, tip, sides, geometry, memory, m)


@kernel
def chamber_rates_at(t, y, inputs, ctx, dydt):
    """The chamber block's rates (into dydt from GAS_BLOCK) at time t (the boundary of the moment) and the chamber
    geometry `inputs` of a pose (thermo.chamber_model.chamber_rates); returns (0 or GAS_STATE_INVALID, FlowStatus, leading and trailing
    FluidState). Needs no contact or gas load: the implicit chamber stages of mechanics.loop.integrators iterate it
    at a fixed pose."""
    flows, leading, trailing = chamber_rates(t, y, GAS_BLOCK, inputs, ctx.chambers[0], ctx.properties, ctx.nozzles,
                                             dydt, ctx.flow_work[0])
    status = GAS_STATE_INVALID if leading.status != 0 or trailing.status != 0 or flows.refused != 0 else 0
    if status != 0:
        note_refused(t, ctx.flow_work[0])        # the failed attempt's states, for the stop message
    return status, flows, leading, trailing


@kernel
def evaluate(t, y, ctx, memory, dydt, out, report):
    """Right-hand side dy/dt at (t, y) and, if `report`, the output row (docs/model.md §8.1b); returns 0 or the
    kernel status code of an impossible pose or chamber state. Intermediate integrator stages pass report=False and
    skip what is only reported."""
    return evaluate_with_inputs(t, y, ctx, memory, dydt, out, report)[0]


@kernel
def no_chamber_inputs():
    """The ChamberInputs of a pressure-table model, which has no chambers: all NaN."""
    return ChamberInputs(math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan,
                         math.nan, math.nan)


@kernel
def evaluate_with_inputs(t, y, ctx, memory, dydt, out, report):
    """`evaluate`, returning (status, the ChamberInputs of the pose: no_chamber_inputs under the pressure tables),
    so that what follows at the same state (the chamber Jacobian of mechanics.loop.integrators) need not build the
    pose and the chamber geometry again."""
    m = ctx.machine[0]
    pose, slots, tip, sides, basis = pose_stages(t, y, ctx, memory)
    status = 0
    if tip.cos_contact_angle < 0.0:
        status = TIP_ON_FLAT_FACE
    contacts = contact_loads(pose, slots, tip, memory, m, out)
    real_gas = m.pressure_model == REAL_GAS_MODEL
    geometry = chamber_geometry(pose, tip, sides, basis, memory[MEM_LOBE_START], m, ctx.sectors)
    inputs = no_chamber_inputs()
    if real_gas:
        inputs = chamber_inputs(pose, slots, tip, sides, geometry, memory, m)
        c = ctx.chambers[0]
        work = ctx.flow_work[0]
        gas_status, flows, leading, trailing = chamber_rates_at(t, y, inputs, ctx, dydt)
        if gas_status != 0:
            status = gas_status
        # the boundary of the moment, as chamber_rates wrote it into the network's working values: the back
        # chamber holds p_d (a moving boundary, docs/model.md §7.3.3)
        pressures = (leading.pressure, trailing.pressure, work.pressure[BACK])
        suction_pressure = work.pressure[SUCTION]
    else:
        pressures = table_pressures(pose, memory, m, ctx.pressure_table)
        suction_pressure = m.suction_pressure
    gas = combine(basis, pressures[0], pressures[1], pressures[2], tip, pose.omega, m)
    accelerations = equations_of_motion(pose, contacts, gas, m, dydt)
    powers = chamber_work_rates(geometry, pressures, dydt)
    if report:
        report_outputs(t, y, pose, slots, tip, sides, contacts, gas, accelerations, pressures, suction_pressure,
                       geometry, powers, memory, m, out)
        if real_gas:
            report_chambers(out, y, inputs, work, flows, leading, trailing, c, ctx.properties)
    return status, inputs
