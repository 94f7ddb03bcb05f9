"""Contact detection for the contact regions of mechanics.contact.regions (docs/model.md §4).

Detectors are pure: from the vane pose (mechanics.geometry.kinematics.VanePose) they return a `ContactCandidate` per
region: the signed penetration delta (> 0 in contact), the unit normal n pointing from the other body into the vane, the
application point P, the curvatures (1/R) of the vane feature and of the other body at P, the radial position of
P and, for the slot-mouth regions, the candidate type of docs/model.md §4.2. The force laws are in
mechanics.contact.contact_laws, the per-region forces in mechanics.contact.contact_forces.
"""
import math
from typing import NamedTuple


from ...kernels.kernel import kernel

from ..geometry.stator import closest_pitch_frame
from .regions import SLOT_MOUTH, TIP, WALL_CORNER

# candidate types of the slot-mouth regions c1/c2 (docs/model.md §4.2), used by the extended mode key
NO_CANDIDATE, EDGE_ON_FACE, EDGE_ON_ARC, TIP_ON_WALL = 0, 1, 2, 3
CANDIDATE_TYPES = 4


class ContactCandidate(NamedTuple):
    """The deepest valid candidate of one region; penetration = -inf if the region has none (docs/model.md §4.1)."""
    penetration: float
    normal_x: float
    normal_y: float
    point_x: float
    point_y: float
    vane_curvature: float
    other_curvature: float
    radius: float           # |P . e_r|: radial position of P (of the bottom corner for c3/c4)
    kind: int               # c1/c2 candidate type (NO_CANDIDATE for the other regions)


class TipContact(NamedTuple):
    """Tip circle vs stator (docs/model.md §2.6, §4.4): the candidate, the closest pitch-curve point u* with its
    frame (C, n, N = |C'|, kappa_C), the contact angle psi_c and |S(u*)|^2."""
    candidate: ContactCandidate
    closest_parameter: float
    pitch_x: float
    pitch_y: float
    pitch_normal_x: float
    pitch_normal_y: float
    pitch_speed: float
    pitch_curvature: float
    sin_contact_angle: float
    cos_contact_angle: float
    stator_radius_squared: float


class SlotContacts(NamedTuple):
    """The four slot regions c1-c4 of one pose."""
    mouth_leading: ContactCandidate
    mouth_trailing: ContactCandidate
    bottom_leading: ContactCandidate
    bottom_trailing: ContactCandidate


NONE = ContactCandidate(-math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, NO_CANDIDATE)


@kernel
def slot_mouth_contact(side, pose, m):
    """Region c1 (side = +1, leading) or c2 (side = -1, trailing): the deepest valid candidate (docs/model.md §4.2).

    A edge vs flat face:   xi_E <= xi_T:                delta = t/2 - side eta_E,  n = -side e_eta,  P = E
    B edge vs tip arc:     xi_E > xi_T, side eta_E > 0:  delta = rho - |E - T|,     n = (T - E)/|T - E|, P = E
    C tip/junction vs wall: T.e_r < R_m, support P_s.e_r <= R_m:  delta = side P_s.e_theta - w/2,  n = -side e_theta
    """
    p = pose
    eeta_x, eeta_y = -p.exi_y, p.exi_x
    et_x, et_y = -p.er_y, p.er_x
    edge_x = m.mouth_radius * p.er_x + side * m.half_slot_width * et_x
    edge_y = m.mouth_radius * p.er_y + side * m.half_slot_width * et_y
    xi_e = (edge_x - p.gx) * p.exi_x + (edge_y - p.gy) * p.exi_y
    eta_e = (edge_x - p.gx) * eeta_x + (edge_y - p.gy) * eeta_y
    best = NONE
    edge_curvature = 1.0 / m.edge_radius
    if xi_e <= m.tip_centre:
        best = ContactCandidate(m.half_thickness - side * eta_e, -side * eeta_x, -side * eeta_y, edge_x, edge_y,
                                0.0, edge_curvature, m.mouth_radius, EDGE_ON_FACE)
    elif side * eta_e > 0.0:
        dx = p.tip_x - edge_x
        dy = p.tip_y - edge_y
        distance = math.sqrt(dx * dx + dy * dy)
        delta = m.tip_radius - distance
        if delta > best.penetration:
            best = ContactCandidate(delta, dx / distance, dy / distance, edge_x, edge_y, 1.0 / m.tip_radius,
                                    edge_curvature, m.mouth_radius, EDGE_ON_ARC)
    if p.tip_x * p.er_x + p.tip_y * p.er_y < m.mouth_radius:
        wall_x = side * et_x
        wall_y = side * et_y
        if wall_x * p.exi_x + wall_y * p.exi_y >= 0.0:
            support_x = p.tip_x + m.tip_radius * wall_x
            support_y = p.tip_y + m.tip_radius * wall_y
            vane_curvature = 1.0 / m.tip_radius
        else:
            support_x = p.tip_x + side * m.half_thickness * eeta_x
            support_y = p.tip_y + side * m.half_thickness * eeta_y
            vane_curvature = edge_curvature
        support_radius = support_x * p.er_x + support_y * p.er_y
        if support_radius <= m.mouth_radius:
            delta = side * (support_x * et_x + support_y * et_y) - m.half_slot_width
            if delta > best.penetration:
                best = ContactCandidate(delta, -wall_x, -wall_y, support_x, support_y, vane_curvature, 0.0,
                                        support_radius, TIP_ON_WALL)
    return best


@kernel
def slot_bottom_contact(side, pose, m):
    """Region c3 (side = +1) or c4 (side = -1): bottom corner B vs slot wall, half-plane method (docs/model.md §4.3).

    B = G + xi_B e_xi + side (t/2) e_eta,   delta = side B.e_theta - w/2,   n = -side e_theta,   P = B.
    """
    p = pose
    corner_x = p.gx + m.bottom_face * p.exi_x - side * m.half_thickness * p.exi_y
    corner_y = p.gy + m.bottom_face * p.exi_y + side * m.half_thickness * p.exi_x
    et_x, et_y = -p.er_y, p.er_x
    return ContactCandidate(side * (corner_x * et_x + corner_y * et_y) - m.half_slot_width, -side * et_x,
                            -side * et_y, corner_x, corner_y, 1.0 / m.edge_radius, 0.0,
                            corner_x * p.er_x + corner_y * p.er_y, NO_CANDIDATE)


@kernel
def slot_floor_contact(side, pose, m):
    """Region c7 (side = +1) or c8 (side = -1): bottom corner B vs the flat slot bottom (docs/model.md §4.4b).

    B = G + xi_B e_xi + side (t/2) e_eta,   delta = r_sb - B.e_r,   n = e_r,   P = B.
    """
    p = pose
    corner_x = p.gx + m.bottom_face * p.exi_x - side * m.half_thickness * p.exi_y
    corner_y = p.gy + m.bottom_face * p.exi_y + side * m.half_thickness * p.exi_x
    radius = corner_x * p.er_x + corner_y * p.er_y
    return ContactCandidate(m.slot_bottom_radius - radius, p.er_x, p.er_y, corner_x, corner_y,
                            1.0 / m.edge_radius, 0.0, radius, NO_CANDIDATE)


@kernel
def region_candidate(detector, side, slots, tip, pose, m):
    """The candidate of a region from its detector kind and side (mechanics.contact.regions): the slot-mouth and
    wall-corner candidates of this pose (`slots`), the tip candidate on its side of the apex (none on the other side),
    or the bottom corner on the slot bottom."""
    if detector == SLOT_MOUTH:
        return slots.mouth_leading if side > 0.0 else slots.mouth_trailing
    if detector == WALL_CORNER:
        return slots.bottom_leading if side > 0.0 else slots.bottom_trailing
    if detector == TIP:
        return tip.candidate if (tip.sin_contact_angle > 0.0) == (side > 0.0) else NONE
    return slot_floor_contact(side, pose, m)


@kernel
def slot_contacts(pose, m):
    """The candidates of c1-c4."""
    return SlotContacts(slot_mouth_contact(1.0, pose, m), slot_mouth_contact(-1.0, pose, m),
                        slot_bottom_contact(1.0, pose, m), slot_bottom_contact(-1.0, pose, m))


@kernel
def tip_contact(pose, parameter_offset, m):
    """Tip circle vs stator, regions c5 (psi_c > 0) and c6 (psi_c < 0) (docs/model.md §2.6, §4.4).

    g_C = (T - C(u*)).n(u*),  delta = g_C - c_S,  n_contact = -n(u*),  P = T + rho n(u*),
    psi_c = atan2(n.e_eta, n.e_xi),  kappa_S = kappa_C/(1 + d kappa_C),  1/R* = 1/rho - kappa_S.
    The search starts at u = atan2(T) + parameter_offset (the offset u* - atan2(T) of the last accepted step).
    """
    p = pose
    u, cx, cy, nx, ny, speed, curvature = closest_pitch_frame(
        p.tip_x, p.tip_y, math.atan2(p.tip_y, p.tip_x) + parameter_offset, m.law, m.stroke, m.lobes,
        m.bottom_dwell, m.top_dwell, m.base_radius)
    gap = (p.tip_x - cx) * nx + (p.tip_y - cy) * ny
    stator_curvature = curvature / (1.0 + m.envelope_offset * curvature)
    sx = cx + m.envelope_offset * nx
    sy = cy + m.envelope_offset * ny
    point_x = p.tip_x + m.tip_radius * nx
    point_y = p.tip_y + m.tip_radius * ny
    candidate = ContactCandidate(gap - m.stator_clearance, -nx, -ny, point_x, point_y, 1.0 / m.tip_radius,
                                 -stator_curvature, math.sqrt(point_x * point_x + point_y * point_y), NO_CANDIDATE)
    return TipContact(candidate, u, cx, cy, nx, ny, speed, curvature, -nx * p.exi_y + ny * p.exi_x,
                      nx * p.exi_x + ny * p.exi_y, sx * sx + sy * sy)
