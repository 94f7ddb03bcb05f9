"""Gas force resultants on the vane, the rotor and the stator, and their power (docs/model.md §6.2, §6.4).

All functions are pure. The vane is loaded on its exposed leading/trailing flat faces, on its two tip arcs
(split at the contact angle psi_c, never clipped) and on its bottom face (back-chamber pressure); the rotor on the
slot wall between a recessed tip junction and the mouth; the stator on the active lobe's wall.
"""
from numba import njit


@njit(cache=True)
def _load(force_x, force_y, arm_x, arm_y, vx, vy, angular_velocity):
    """(F_x, F_y, moment about G, power F.v3(P)) of one force F applied at P = G + arm on the vane."""
    point_vx = vx - angular_velocity * arm_y
    point_vy = vy + angular_velocity * arm_x
    return (force_x, force_y, arm_x * force_y - arm_y * force_x, force_x * point_vx + force_y * point_vy)


@njit(cache=True)
def vane_gas_load(vx, vy, angular_velocity, exi_x, exi_y, xi_mouth_leading, xi_mouth_trailing,
                  sin_contact_angle, cos_contact_angle, leading_pressure, trailing_pressure, back_pressure, m):
    """Resultant (F_x, F_y, moment about G) and power sum F_i . v3(point_i) of the gas on the vane (docs/model.md §6.2).

    flat face side s:  F = -s p_s L l_s e_eta at ((xi_E + xi_T)/2, s t/2),  l_s = xi_T - xi_E,s  (if > 0)
    tip arc [psi1, psi2] at p:  F = -p L rho [(sin psi2 - sin psi1) e_xi + (cos psi1 - cos psi2) e_eta], through T
    (leading arc [psi_c, pi/2] at p_L, trailing arc [-pi/2, psi_c] at p_T)
    bottom face:  F = +p_b t L e_xi at (xi_B, 0)
    """
    eeta_x, eeta_y = -exi_y, exi_x
    length = m.axial_length
    total = (0.0, 0.0, 0.0, 0.0)
    for side in (1.0, -1.0):
        mouth_level = xi_mouth_leading if side > 0.0 else xi_mouth_trailing
        pressure = leading_pressure if side > 0.0 else trailing_pressure
        exposed = m.tip_centre - mouth_level
        if exposed > 0.0:
            force = -side * pressure * length * exposed
            xi = 0.5 * (mouth_level + m.tip_centre)
            eta = side * m.half_thickness
            face = _load(force * eeta_x, force * eeta_y, xi * exi_x + eta * eeta_x, xi * exi_y + eta * eeta_y,
                         vx, vy, angular_velocity)
            total = (total[0] + face[0], total[1] + face[1], total[2] + face[2], total[3] + face[3])
    scale_l = -leading_pressure * length * m.tip_radius
    scale_t = -trailing_pressure * length * m.tip_radius
    along = scale_l * (1.0 - sin_contact_angle) + scale_t * (sin_contact_angle + 1.0)
    across = (scale_l - scale_t) * cos_contact_angle
    arcs = _load(along * exi_x + across * eeta_x, along * exi_y + across * eeta_y, m.tip_centre * exi_x,
                 m.tip_centre * exi_y, vx, vy, angular_velocity)
    force = back_pressure * 2.0 * m.half_thickness * length
    bottom = _load(force * exi_x, force * exi_y, m.bottom_face * exi_x, m.bottom_face * exi_y, vx, vy,
                   angular_velocity)
    return (total[0] + arcs[0] + bottom[0], total[1] + arcs[1] + bottom[1], total[2] + arcs[2] + bottom[2],
            total[3] + arcs[3] + bottom[3])


@njit(cache=True)
def rotor_gas_moment(junction_radius_leading, junction_radius_trailing, corner_radius_leading,
                     corner_radius_trailing, leading_pressure, trailing_pressure, back_pressure, m):
    """Moment about O of the gas on the rotor's slot walls (docs/model.md §6.2, extended to the back chamber):

    crescents above a recessed tip junction:  sum_s s p_s L (R_m^2 - r_J,s^2)/2  for r_J,s < R_m
    back chamber, walls from the slot bottom up to the vane's bottom corners:  p_b L (r_B+^2 - r_B-^2)/2
    The second term is the rotor's share of the closed back-chamber contour whose vane share is the bottom-face
    load; it is zero for an untilted vane and closes the global torque balance for a tilted one.
    """
    moment = 0.5 * back_pressure * m.axial_length * (corner_radius_leading ** 2 - corner_radius_trailing ** 2)
    if junction_radius_leading < m.mouth_radius:
        moment += leading_pressure * m.axial_length * (m.mouth_radius ** 2 - junction_radius_leading ** 2) / 2.0
    if junction_radius_trailing < m.mouth_radius:
        moment -= trailing_pressure * m.axial_length * (m.mouth_radius ** 2 - junction_radius_trailing ** 2) / 2.0
    return moment


@njit(cache=True)
def stator_gas_moment(stator_radius_squared, leading_pressure, trailing_pressure, m):
    """M_gas,stator = 1/2 L (p_L - p_T)(|S(u*)|^2 - R_v^2),  R_v = R_r + c_S (docs/model.md §6.2)."""
    valley_radius = m.rotor_radius + m.stator_clearance
    return 0.5 * m.axial_length * (leading_pressure - trailing_pressure) * (stator_radius_squared
                                                                            - valley_radius ** 2)


@njit(cache=True)
def mouth_gap_moment(side, edge_x, edge_y, mouth_level, junction_radius, gx, gy, exi_x, exi_y, er_x, er_y,
                     pressure, m):
    """Moment of chamber pressure p on the slot-mouth gap of one side, the short segment from the slot edge E
    (or, for a recessed tip, from the wall point at the junction radius) to the vane (E-F or W-J), carried by no
    body: M = -s 1/2 p L (|a|^2 - |b|^2) for the segment a -> b (docs/model.md §6.2's wall-arc rule)."""
    if junction_radius < m.mouth_radius:
        a_x = junction_radius * er_x - side * m.half_slot_width * er_y
        a_y = junction_radius * er_y + side * m.half_slot_width * er_x
        level = m.tip_centre
    else:
        a_x = edge_x
        a_y = edge_y
        level = min(mouth_level, m.tip_centre)
    b_x = gx + level * exi_x - side * m.half_thickness * exi_y
    b_y = gy + level * exi_y + side * m.half_thickness * exi_x
    return side * 0.5 * pressure * m.axial_length * (a_x * a_x + a_y * a_y - b_x * b_x - b_y * b_y)


@njit(cache=True)
def gap_moment(vane_point_x, vane_point_y, stator_radius_squared, mouth_gap_leading, mouth_gap_trailing,
               leading_pressure, trailing_pressure, m):
    """Moment about O of the chamber pressures on the gaps that bound the chambers but belong to no body: the tip
    gap (P_V = T + rho n to S(u*)), the end-valley gap (R_r to R_r + c_S, leading chamber against the idle lobe
    at suction) and the two slot-mouth gaps:

    M_gap = 1/2 L (p_L - p_T)(|P_V|^2 - |S(u*)|^2) + 1/2 L (p_L - p_s)((R_r + c_S)^2 - R_r^2) + M_mouth,+ + M_mouth,-
    A diagnostic, not a load: it closes the global angular-momentum balance
    <T_d> = <lambda3 + M_gas,stator + M_gap> (docs/model.md §11 T11) when the tip does not sit exactly on the stator.
    """
    tip = 0.5 * m.axial_length * (leading_pressure - trailing_pressure) * (
        vane_point_x * vane_point_x + vane_point_y * vane_point_y - stator_radius_squared)
    valley = 0.5 * m.axial_length * (leading_pressure - m.suction_pressure) * (
        (m.rotor_radius + m.stator_clearance) ** 2 - m.rotor_radius ** 2)
    return tip + valley + mouth_gap_leading + mouth_gap_trailing
