"""Gas loads on the vane, the rotor and the stator, and their power (docs/model.md §6.2, §6.4).

The loads are linear in the three pressures (leading p_L, trailing p_T, back chamber p_b), so each RHS evaluation
computes them once per unit pressure (`gas_load_basis`) and combines them (`combine`). The same unit-pressure
powers are the wetted-wall part of the chamber volume rates (mechanics.geometry.chamber_geometry, docs/model.md §7.2).

The vane is loaded on its exposed leading/trailing flat faces, on its two tip arcs (split at the contact angle
psi_c, never clipped) and on its bottom face (back-chamber pressure); the rotor on the slot wall between a
recessed tip junction and the mouth, and on the back-chamber walls; the stator on the active lobe's wall.
"""
from typing import NamedTuple
from ...kernels.kernel import kernel



class SlotSide(NamedTuple):
    """One side (leading +1, trailing -1) of the slot mouth (docs/model.md §6.2): the slot edge E, the tip
    junction J = T + side (t/2) e_eta, the vane-frame level xi_E = (E - G).e_xi and r_J = J.e_r."""
    edge_x: float
    edge_y: float
    junction_x: float
    junction_y: float
    mouth_level: float
    junction_radius: float


class UnitLoad(NamedTuple):
    """Load of a unit pressure on one chamber's wetted surfaces: force on the vane, its moment about G, its power
    F.v on the vane, and the moment about O on the rotor."""
    fx: float
    fy: float
    moment: float
    power: float
    rotor_moment: float


class GasLoadBasis(NamedTuple):
    leading: UnitLoad
    trailing: UnitLoad
    back: UnitLoad


class GasLoad(NamedTuple):
    """Gas resultants at given pressures: on the vane (force, moment about G), on the rotor (moment about O), the
    power on vane and rotor P_gas, and the stator moment M_gas,stator."""
    fx: float
    fy: float
    moment: float
    rotor_moment: float
    power: float
    stator_moment: float


@kernel
def slot_side(side, pose, m):
    """The SlotSide of one side of the slot for this pose."""
    p = pose
    edge_x = m.mouth_radius * p.er_x - side * m.half_slot_width * p.er_y
    edge_y = m.mouth_radius * p.er_y + side * m.half_slot_width * p.er_x
    junction_x = p.tip_x - side * m.half_thickness * p.exi_y
    junction_y = p.tip_y + side * m.half_thickness * p.exi_x
    return SlotSide(edge_x, edge_y, junction_x, junction_y,
                    (edge_x - p.gx) * p.exi_x + (edge_y - p.gy) * p.exi_y,
                    junction_x * p.er_x + junction_y * p.er_y)


@kernel
def _vane_load(fx, fy, arm_x, arm_y, pose):
    """(F_x, F_y, moment about G, power F.v3(P)) of one force F applied at P = G + arm on the vane."""
    return (fx, fy, arm_x * fy - arm_y * fx,
            fx * (pose.vx - pose.phi_dot * arm_y) + fy * (pose.vy + pose.phi_dot * arm_x))


@kernel
def _chamber_unit_load(side, sides, pose, sin_contact, cos_contact, m):
    """Unit pressure in the leading (side +1) or trailing (side -1) chamber (docs/model.md §6.2):

    flat face:  F = -side L l e_eta at ((xi_E + xi_T)/2, side t/2),  l = xi_T - xi_E (if > 0)
    tip arc (leading [psi_c, pi/2], trailing [-pi/2, psi_c]) through T:
        F = -L rho [(1 - side sin psi_c) e_xi + side cos psi_c e_eta]
    rotor: the crescent above a recessed junction, side L (R_m^2 - r_J^2)/2 for r_J < R_m.
    """
    p = pose
    s = sides[0] if side > 0.0 else sides[1]
    eeta_x, eeta_y = -p.exi_y, p.exi_x
    length = m.axial_length
    fx = fy = moment = power = 0.0
    exposed = m.tip_centre - s.mouth_level
    if exposed > 0.0:
        force = -side * length * exposed
        xi = 0.5 * (s.mouth_level + m.tip_centre)
        eta = side * m.half_thickness
        fx, fy, moment, power = _vane_load(force * eeta_x, force * eeta_y, xi * p.exi_x + eta * eeta_x,
                                           xi * p.exi_y + eta * eeta_y, p)
    along = -length * m.tip_radius * (1.0 - side * sin_contact)
    across = -length * m.tip_radius * side * cos_contact
    arc = _vane_load(along * p.exi_x + across * eeta_x, along * p.exi_y + across * eeta_y, m.tip_centre * p.exi_x,
                     m.tip_centre * p.exi_y, p)
    rotor_moment = 0.0
    if s.junction_radius < m.mouth_radius:
        rotor_moment = side * length * (m.mouth_radius ** 2 - s.junction_radius ** 2) / 2.0
    return UnitLoad(fx + arc[0], fy + arc[1], moment + arc[2], power + arc[3], rotor_moment)


@kernel
def gas_load_basis(pose, sides, tip, slots, m):
    """Unit-pressure loads of the leading, trailing and back chambers for this pose (docs/model.md §6.2):

    back chamber: F = t L e_xi on the bottom face at (xi_B, 0); on the rotor, the walls from the slot bottom up to
    the vane's bottom corners: L (r_B+^2 - r_B-^2)/2 (zero for an untilted vane; it closes the global torque
    balance for a tilted one).
    """
    p = pose
    force = 2.0 * m.half_thickness * m.axial_length
    bottom = _vane_load(force * p.exi_x, force * p.exi_y, m.bottom_face * p.exi_x, m.bottom_face * p.exi_y, p)
    back = UnitLoad(bottom[0], bottom[1], bottom[2], bottom[3],
                    0.5 * m.axial_length * (slots.bottom_leading.radius ** 2 - slots.bottom_trailing.radius ** 2))
    return GasLoadBasis(_chamber_unit_load(1.0, sides, p, tip.sin_contact_angle, tip.cos_contact_angle, m),
                        _chamber_unit_load(-1.0, sides, p, tip.sin_contact_angle, tip.cos_contact_angle, m), back)


@kernel
def combine(basis, leading_pressure, trailing_pressure, back_pressure, tip, omega, m):
    """The GasLoad at the given pressures: sum_sigma p_sigma (unit load sigma); P_gas = F.v + M_rotor omega;
    M_gas,stator = 1/2 L (p_L - p_T)(|S(u*)|^2 - R_v^2), R_v = R_r + c_S (docs/model.md §6.2)."""
    lead, trail, back = basis.leading, basis.trailing, basis.back
    p_l, p_t, p_b = leading_pressure, trailing_pressure, back_pressure
    fx = p_l * lead.fx + p_t * trail.fx + p_b * back.fx
    fy = p_l * lead.fy + p_t * trail.fy + p_b * back.fy
    moment = p_l * lead.moment + p_t * trail.moment + p_b * back.moment
    rotor_moment = p_l * lead.rotor_moment + p_t * trail.rotor_moment + p_b * back.rotor_moment
    power = (p_l * (lead.power + lead.rotor_moment * omega) + p_t * (trail.power + trail.rotor_moment * omega)
             + p_b * (back.power + back.rotor_moment * omega))
    valley_radius = m.rotor_radius + m.stator_clearance
    stator_moment = 0.5 * m.axial_length * (leading_pressure - trailing_pressure) * (tip.stator_radius_squared
                                                                                     - valley_radius ** 2)
    return GasLoad(fx, fy, moment, rotor_moment, power, stator_moment)


@kernel
def _mouth_gap_moment(side, s, pose, pressure, m):
    """Moment of chamber pressure p on the slot-mouth gap of one side, the short segment from the slot edge E
    (or, for a recessed tip, from the wall point at the junction radius) to the vane (E-F or W-J), carried by no
    body: M = -s 1/2 p L (|a|^2 - |b|^2) for the segment a -> b (docs/model.md §6.2's wall-arc rule)."""
    p = pose
    if s.junction_radius < m.mouth_radius:
        a_x = s.junction_radius * p.er_x - side * m.half_slot_width * p.er_y
        a_y = s.junction_radius * p.er_y + side * m.half_slot_width * p.er_x
        level = m.tip_centre
    else:
        a_x = s.edge_x
        a_y = s.edge_y
        level = min(s.mouth_level, m.tip_centre)
    b_x = p.gx + level * p.exi_x - side * m.half_thickness * p.exi_y
    b_y = p.gy + level * p.exi_y + side * m.half_thickness * p.exi_x
    return side * 0.5 * pressure * m.axial_length * (a_x * a_x + a_y * a_y - b_x * b_x - b_y * b_y)


@kernel
def gap_moment(pose, sides, tip, leading_pressure, trailing_pressure, suction_pressure, m):
    """Moment about O of the chamber pressures on the gaps that bound the chambers but belong to no body: the tip
    gap (P_V = T + rho n to S(u*)), the end-valley gap (R_r to R_r + c_S, leading chamber against the idle lobe
    at suction) and the two slot-mouth gaps:

    M_gap = 1/2 L (p_L - p_T)(|P_V|^2 - |S(u*)|^2) + 1/2 L (p_L - p_s)((R_r + c_S)^2 - R_r^2) + M_mouth,+ + M_mouth,-
    A diagnostic, not a load: it closes the global angular-momentum balance <T_d> = <lambda3 + M_gas,stator + M_gap>
    (docs/model.md §11) when the tip does not sit exactly on the stator. p_s: the suction pressure of the moment
    (a moving boundary, docs/model.md §7.3.3).
    """
    point = tip.candidate
    tip_gap = 0.5 * m.axial_length * (leading_pressure - trailing_pressure) * (
        point.point_x * point.point_x + point.point_y * point.point_y - tip.stator_radius_squared)
    valley = 0.5 * m.axial_length * (leading_pressure - suction_pressure) * (
        (m.rotor_radius + m.stator_clearance) ** 2 - m.rotor_radius ** 2)
    return (tip_gap + valley + _mouth_gap_moment(1.0, sides[0], pose, leading_pressure, m)
            + _mouth_gap_moment(-1.0, sides[1], pose, trailing_pressure, m))
