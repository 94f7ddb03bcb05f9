"""One evaluation of the reduced equations of motion, in the order of docs/model.md §8.1b.

`evaluate` fills the state derivative and the output row (forces, powers, kinematics) for a state y at time t,
given the speed law, the pressure source and the memory of the last accepted step. It is the right-hand side
for both integrators and the source of the recorded history.
"""
import math

from numba import njit

from .contact import (elastic_force, friction_coefficient_effective, normal_force, slot_bottom_contact,
                      slot_mouth_contact, tip_contact)
from .chambers import chamber_volume_rates, chamber_volumes
from .gas_chambers import chamber_gas_derivatives, chamber_properties, switch_chambers
from .gas_loads import gap_moment, mouth_gap_moment, rotor_gas_moment, stator_gas_moment, vane_gas_load
from .layout import (ANGLE, ANGULAR_VELOCITY, GAS_STATE_INVALID, LEADING_DENSITY, LEADING_TEMPERATURE, MASS_SUCTION,
                     MEM_CLOSEST_OFFSET, MEM_LOBE_COUNT, MEM_LOBE_START, MEM_ONSET_VELOCITY, O_ACCELERATION, O_ANGLE,
                     O_CANDIDATE, O_CHAMBER_ENERGY, O_CHAMBER_MASS, O_CLOSEST_OFFSET, O_CONTACT_ANGLE,
                     O_CONTACT_ENERGY, O_DAMPING_POWER, O_DISPLACEMENT, O_DRIVING_TORQUE, O_FRICTION_FORCE,
                     O_FRICTION_POWER, O_GAP_MOMENT, O_INPUT_POWER, O_KINETIC_ENERGY, O_LEADING_PRESSURE,
                     O_LEADING_TEMPERATURE, O_LEADING_VOLUME, O_LOBE_COUNT, O_MASS_SUCTION, O_MODE, O_NORMAL_FORCE,
                     O_OUTPUT_POWER, O_PENETRATION, O_PENETRATION_RATE, O_RADIAL_ACCELERATION, O_RADIAL_VELOCITY,
                     O_ROTOR_FORCE, O_SPEED, O_STATOR_FORCE, O_STATOR_GAS_MOMENT, O_STATOR_MOMENT,
                     O_SUCTION_MASS_FLOW, O_TANGENTIAL_ACCELERATION, O_TANGENTIAL_VELOCITY, O_TILT, O_TIME,
                     O_TRAILING_PRESSURE, O_WORK, TIP_MEMORY_SLOT, TIP_ON_FLAT_FACE, TRAILING_DENSITY,
                     TRAILING_TEMPERATURE, VANE_BOTTOMED, VX, VY, WORK_IN, X, Y)
from .machine import REAL_GAS_MODEL
from .speed import rotor_motion


@njit(cache=True)
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


@njit(cache=True)
def table_pressures(theta, m, gas, memory):
    """(p_L, p_T, p_b): the pressure tables of docs/model.md §6.1 (Level 0 and 0.5) read a p_L(phi) table;
    the trailing chamber is at suction and the back chamber at discharge pressure."""
    phase = theta - memory[MEM_LOBE_START]
    return (leading_pressure_from_table(phase, gas.pressure_table, m.lobes), m.suction_pressure,
            m.discharge_pressure)


@njit(cache=True)
def reported_kinematics(tip_x, tip_y, tip_vx, tip_vy, tip_ax, tip_ay, cg_vx, cg_vy, cg_ax, cg_ay,
                        theta, omega, theta_ddot, base_radius):
    """The thesis's relative kinematics (docs/model.md §3.4):

    s_r = T.e_r - R0,  v_r = v_T.e_r + omega eta_T,  a_r = a_T.e_r + 2 omega v_T.e_theta + theta_ddot eta_T - omega^2 xi_T,
    v_theta = v_G.e_theta,  a_theta = a_G.e_theta,  with xi_T = T.e_r, eta_T = T.e_theta.
    """
    er_x = math.cos(theta)
    er_y = math.sin(theta)
    xi_t = tip_x * er_x + tip_y * er_y
    eta_t = -tip_x * er_y + tip_y * er_x
    v_tangential_tip = -tip_vx * er_y + tip_vy * er_x
    return (xi_t - base_radius,
            tip_vx * er_x + tip_vy * er_y + omega * eta_t,
            tip_ax * er_x + tip_ay * er_y + 2.0 * omega * v_tangential_tip + theta_ddot * eta_t - omega * omega * xi_t,
            -cg_vx * er_y + cg_vy * er_x,
            -cg_ax * er_y + cg_ay * er_x)


@njit(cache=True)
def _mouth_level_and_junction_radius(side, gx, gy, tip_x, tip_y, exi_x, exi_y, er_x, er_y, m):
    """Vane-frame level xi_E of the slot edge E_side and radius r_J = J_side.e_r of the tip junction (docs/model.md §6.2)."""
    edge_x = m.mouth_radius * er_x - side * m.half_slot_width * er_y
    edge_y = m.mouth_radius * er_y + side * m.half_slot_width * er_x
    junction_x = tip_x - side * m.half_thickness * exi_y
    junction_y = tip_y + side * m.half_thickness * exi_x
    return ((edge_x - gx) * exi_x + (edge_y - gy) * exi_y, junction_x * er_x + junction_y * er_y)


@njit(cache=True)
def evaluate(t, y, m, speed_law, gas, memory, dydt, out, report=True):
    """Right-hand side f(t, y) and, if `report`, the output row; returns a status code (0 = fine). docs/model.md §8.1b:

    Intermediate integrator stages pass report=False and skip the quantities that are only reported.
    q_ddot3 = Q3/[m3, m3, J3];  lambda3 = Q1phi;  lambda6 = Q2phi - J2 theta_ddot;  T_d = -lambda6
    dW_in/dt = T_d omega,  dW_out/dt = -P_gas,  dW_fric/dt = sum mu_eff F_n |v_t|,  dW_damp/dt = sum (F_n - F_el) delta_dot
    """
    status = 0
    theta, omega, theta_ddot = rotor_motion(t, speed_law)
    er_x = math.cos(theta)
    er_y = math.sin(theta)
    gx = y[X]
    gy = y[Y]
    phi = y[ANGLE]
    vx = y[VX]
    vy = y[VY]
    phi_dot = y[ANGULAR_VELOCITY]
    exi_x = math.cos(phi)
    exi_y = math.sin(phi)
    tip_x = gx + m.tip_centre * exi_x
    tip_y = gy + m.tip_centre * exi_y

    force_x = 0.0          # Q3
    force_y = 0.0
    moment_vane = 0.0
    moment_rotor = 0.0     # Q2phi
    rotor_fx = 0.0
    rotor_fy = 0.0
    moment_stator = 0.0    # Q1phi
    stator_fx = 0.0
    stator_fy = 0.0
    friction_power = 0.0
    damping_power = 0.0
    contact_energy = 0.0
    mode = 0

    tip = tip_contact(tip_x, tip_y, exi_x, exi_y, memory[MEM_CLOSEST_OFFSET], m)
    sin_contact_angle = tip[8]
    cos_contact_angle = tip[9]
    if cos_contact_angle < 0.0:
        status = TIP_ON_FLAT_FACE
    mouth_leading = slot_mouth_contact(1.0, gx, gy, exi_x, exi_y, er_x, er_y, m)
    mouth_trailing = slot_mouth_contact(-1.0, gx, gy, exi_x, exi_y, er_x, er_y, m)
    bottom_leading = slot_bottom_contact(1.0, gx, gy, exi_x, exi_y, er_x, er_y, m)
    bottom_trailing = slot_bottom_contact(-1.0, gx, gy, exi_x, exi_y, er_x, er_y, m)
    if min(bottom_leading[7], bottom_trailing[7]) <= m.slot_bottom_radius:
        status = VANE_BOTTOMED
    tip_region = 4 if sin_contact_angle > 0.0 else 5
    out[O_CANDIDATE] = mouth_leading[7]
    out[O_CANDIDATE + 1] = mouth_trailing[7]

    for region in range(6):
        if region == 0:
            contact = mouth_leading[:7]
        elif region == 1:
            contact = mouth_trailing[:7]
        elif region == 2:
            contact = bottom_leading[:7]
        elif region == 3:
            contact = bottom_trailing[:7]
        elif region == tip_region:
            contact = tip[:7]
        else:
            contact = (-math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        delta, nx, ny, px, py, vane_curvature, other_curvature = contact
        out[O_NORMAL_FORCE + region] = 0.0
        out[O_FRICTION_FORCE + region] = 0.0
        if delta == -math.inf:      # no valid candidate in this region: reported as not applicable
            out[O_PENETRATION + region] = math.nan
            out[O_PENETRATION_RATE + region] = math.nan
            continue
        out[O_PENETRATION + region] = delta
        # relative velocity of the vane point P against the other body (rotor for c1-c4, stator for c5/c6)
        rel_vx = vx - phi_dot * (py - gy)
        rel_vy = vy + phi_dot * (px - gx)
        if region < 4:
            rel_vx += omega * py
            rel_vy -= omega * px
        normal_speed = rel_vx * nx + rel_vy * ny
        rate = -normal_speed
        out[O_PENETRATION_RATE + region] = rate
        if delta <= 0.0:
            continue
        mode |= 1 << region
        slot = TIP_MEMORY_SLOT if region >= 4 else region
        onset = memory[MEM_ONSET_VELOCITY + slot]
        if onset <= 0.0:
            onset = max(abs(rate), m.onset_velocity_floor)
        elastic, energy = elastic_force(delta, vane_curvature, other_curvature, m)
        force_n = normal_force(elastic, rate, onset, m.restitution)
        slip_x = rel_vx - normal_speed * nx
        slip_y = rel_vy - normal_speed * ny
        slip = math.sqrt(slip_x * slip_x + slip_y * slip_y)
        fx = force_n * nx
        fy = force_n * ny
        if slip > 0.0:
            friction = friction_coefficient_effective(slip, m) * force_n
            fx -= friction * slip_x / slip
            fy -= friction * slip_y / slip
            friction_power += friction * slip
            out[O_FRICTION_FORCE + region] = friction
        damping_power += (force_n - elastic) * rate
        contact_energy += energy
        out[O_NORMAL_FORCE + region] = force_n
        # same application point on both bodies (docs/model.md §5.4)
        force_x += fx
        force_y += fy
        moment_vane += (px - gx) * fy - (py - gy) * fx
        reaction_moment = -(px * fy - py * fx)
        if region < 4:
            rotor_fx -= fx
            rotor_fy -= fy
            moment_rotor += reaction_moment
        else:
            stator_fx -= fx
            stator_fy -= fy
            moment_stator += reaction_moment

    # gas loads (docs/model.md §6.2)
    real_gas = m.pressure_model == REAL_GAS_MODEL
    leading = trailing = (0.0, 0.0, 0.0, 0.0, 0)          # (p, h, c_v, dp/dT, status), Level 1 only
    volumes = (0.0, 0.0)
    flows = (0.0, 0.0, 0.0, 0.0)
    if real_gas:
        leading, trailing = chamber_properties(y, gas.properties)
        if leading[4] != 0 or trailing[4] != 0:
            status = GAS_STATE_INVALID
        leading_pressure, trailing_pressure, back_pressure = leading[0], trailing[0], m.discharge_pressure
    else:
        leading_pressure, trailing_pressure, back_pressure = table_pressures(theta, m, gas, memory)
    xi_mouth_leading, junction_leading = _mouth_level_and_junction_radius(1.0, gx, gy, tip_x, tip_y, exi_x, exi_y,
                                                                         er_x, er_y, m)
    xi_mouth_trailing, junction_trailing = _mouth_level_and_junction_radius(-1.0, gx, gy, tip_x, tip_y, exi_x,
                                                                           exi_y, er_x, er_y, m)
    gas_fx, gas_fy, gas_moment, gas_power_vane = vane_gas_load(
        vx, vy, phi_dot, exi_x, exi_y, xi_mouth_leading, xi_mouth_trailing, sin_contact_angle,
        cos_contact_angle,
        leading_pressure, trailing_pressure, back_pressure, m)
    gas_moment_rotor = rotor_gas_moment(junction_leading, junction_trailing, bottom_leading[7],
                                        bottom_trailing[7], leading_pressure, trailing_pressure, back_pressure, m)
    gas_moment_stator = stator_gas_moment(tip[10], leading_pressure, trailing_pressure, m)
    force_x += gas_fx
    force_y += gas_fy
    moment_vane += gas_moment
    moment_rotor += gas_moment_rotor
    gas_power = gas_power_vane + gas_moment_rotor * omega

    # reduced equations of motion (docs/model.md §3.1)
    ax = force_x / m.vane_mass
    ay = force_y / m.vane_mass
    alpha = moment_vane / m.vane_inertia
    driving_torque = m.rotor_inertia * theta_ddot - moment_rotor
    input_power = driving_torque * omega
    dydt[X] = vx
    dydt[Y] = vy
    dydt[ANGLE] = phi_dot
    dydt[VX] = ax
    dydt[VY] = ay
    dydt[ANGULAR_VELOCITY] = alpha
    dydt[WORK_IN] = input_power
    dydt[WORK_IN + 1] = -gas_power
    dydt[WORK_IN + 2] = friction_power
    dydt[WORK_IN + 3] = damping_power
    if real_gas:
        # geometric volumes and their exact rates (docs/model.md §7.2): the rates are the unit-pressure power on the
        # wetted walls plus the sweep of the load-free gaps (tip and slot-mouth gaps)
        volumes = chamber_volumes(gx, gy, phi, theta, tip[7], memory[MEM_LOBE_START], m)
        rates = chamber_volume_rates(gx, gy, phi, vx, vy, phi_dot, theta, omega, tip[7], m)
        flows = chamber_gas_derivatives(y, leading, trailing, (volumes[0] + m.dead_volume,
                                                               volumes[1] + m.dead_volume),
                                        (rates[0], rates[1]), theta - memory[MEM_LOBE_START], tip[0], m, dydt)

    if not report:
        return status
    # outputs (docs/model.md §3.4, §6.4)
    rx = m.tip_centre * exi_x
    ry = m.tip_centre * exi_y
    tip_vx = vx - phi_dot * ry
    tip_vy = vy + phi_dot * rx
    tip_ax = ax - alpha * ry - phi_dot * phi_dot * rx
    tip_ay = ay + alpha * rx - phi_dot * phi_dot * ry
    kin = reported_kinematics(tip_x, tip_y, tip_vx, tip_vy, tip_ax, tip_ay, vx, vy, ax, ay, theta, omega,
                              theta_ddot, m.base_radius)
    out[O_TIME] = t
    out[O_ANGLE] = theta
    out[O_SPEED] = omega
    out[O_ACCELERATION] = theta_ddot
    out[O_DISPLACEMENT] = kin[0]
    out[O_RADIAL_VELOCITY] = kin[1]
    out[O_RADIAL_ACCELERATION] = kin[2]
    out[O_TANGENTIAL_VELOCITY] = kin[3]
    out[O_TANGENTIAL_ACCELERATION] = kin[4]
    out[O_TILT] = phi - theta
    out[O_MODE] = mode
    out[O_STATOR_FORCE] = stator_fx
    out[O_STATOR_FORCE + 1] = stator_fy
    out[O_STATOR_MOMENT] = moment_stator
    out[O_STATOR_GAS_MOMENT] = gas_moment_stator
    mouth_gaps = 0.0
    for side in (1.0, -1.0):
        edge_x = m.mouth_radius * er_x - side * m.half_slot_width * er_y
        edge_y = m.mouth_radius * er_y + side * m.half_slot_width * er_x
        mouth_gaps += mouth_gap_moment(
            side, edge_x, edge_y, xi_mouth_leading if side > 0.0 else xi_mouth_trailing,
            junction_leading if side > 0.0 else junction_trailing, gx, gy, exi_x, exi_y, er_x, er_y,
            leading_pressure if side > 0.0 else trailing_pressure, m)
    out[O_GAP_MOMENT] = gap_moment(tip[3], tip[4], tip[10], mouth_gaps, 0.0, leading_pressure, trailing_pressure, m)
    out[O_ROTOR_FORCE] = rotor_fx
    out[O_ROTOR_FORCE + 1] = rotor_fy
    out[O_DRIVING_TORQUE] = driving_torque
    out[O_INPUT_POWER] = input_power
    out[O_OUTPUT_POWER] = -gas_power
    out[O_FRICTION_POWER] = friction_power
    out[O_DAMPING_POWER] = damping_power
    out[O_LEADING_PRESSURE] = leading_pressure
    out[O_TRAILING_PRESSURE] = trailing_pressure
    out[O_KINETIC_ENERGY] = 0.5 * m.vane_mass * (vx * vx + vy * vy) + 0.5 * m.vane_inertia * phi_dot * phi_dot
    out[O_CONTACT_ENERGY] = contact_energy
    out[O_CONTACT_ANGLE] = math.atan2(sin_contact_angle, cos_contact_angle)
    offset = tip[7] - math.atan2(tip_y, tip_x)
    out[O_CLOSEST_OFFSET] = offset - 2.0 * math.pi * math.floor(offset / (2.0 * math.pi) + 0.5)
    out[O_LOBE_COUNT] = memory[MEM_LOBE_COUNT]
    for k in range(4):
        out[O_WORK + k] = y[WORK_IN + k]
    if real_gas:
        out[O_LEADING_TEMPERATURE] = y[LEADING_TEMPERATURE]
        out[O_LEADING_TEMPERATURE + 1] = y[TRAILING_TEMPERATURE]
        volume_leading = volumes[0] + m.dead_volume
        volume_trailing = volumes[1] + m.dead_volume
        out[O_LEADING_VOLUME] = volume_leading
        out[O_LEADING_VOLUME + 1] = volume_trailing
        mass_leading = y[LEADING_DENSITY] * volume_leading
        mass_trailing = y[TRAILING_DENSITY] * volume_trailing
        out[O_CHAMBER_MASS] = mass_leading + mass_trailing
        out[O_CHAMBER_ENERGY] = (mass_leading * (leading[1] - leading[0] / y[LEADING_DENSITY])
                                 + mass_trailing * (trailing[1] - trailing[0] / y[TRAILING_DENSITY]))
        for k in range(4):
            out[O_SUCTION_MASS_FLOW + k] = flows[k]
        for k in range(5):
            out[O_MASS_SUCTION + k] = y[MASS_SUCTION + k]
    else:
        for k in range(O_LEADING_TEMPERATURE, O_MASS_SUCTION + 5):
            out[k] = math.nan
    return status


@njit(cache=True)
def pose_chamber_volumes(t, y, memory, m, speed_law):
    """(V_L, V_T) with the dead volume, from the vane pose in y and the current lobe (docs/model.md §7.2)."""
    theta = rotor_motion(t, speed_law)[0]
    exi_x = math.cos(y[ANGLE])
    exi_y = math.sin(y[ANGLE])
    tip_x = y[X] + m.tip_centre * exi_x
    tip_y = y[Y] + m.tip_centre * exi_y
    tip = tip_contact(tip_x, tip_y, exi_x, exi_y, memory[MEM_CLOSEST_OFFSET], m)
    volumes = chamber_volumes(y[X], y[Y], y[ANGLE], theta, tip[7], memory[MEM_LOBE_START], m)
    return volumes[0] + m.dead_volume, volumes[1] + m.dead_volume


@njit(cache=True)
def cross_valley(t, y, memory, m, speed_law, gas):
    """The vane crossed the end valley of its lobe: the next lobe becomes the active one, and under Level 1 the
    chambers are switched (gas_chambers.switch_chambers). Returns False if a chamber state left the table."""
    real_gas = m.pressure_model == REAL_GAS_MODEL
    old_volumes = pose_chamber_volumes(t, y, memory, m, speed_law) if real_gas else (0.0, 0.0)
    memory[MEM_LOBE_START] += 2.0 * math.pi / m.lobes
    memory[MEM_LOBE_COUNT] += 1.0
    if not real_gas:
        return True
    return switch_chambers(y, old_volumes, pose_chamber_volumes(t, y, memory, m, speed_law), gas.properties, m)
