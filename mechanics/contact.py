"""Contact detection for the six regions and the contact force laws (docs/model.md §4, §5).

Detection functions are pure: they take the poses as floats and return, per region, the signed penetration
delta (> 0 in contact), the unit normal n pointing from the other body into the vane, the application point P
and the curvatures (1/R) of the vane feature and of the other body at P. Force laws are pure functions of
delta, its rate and the stored impact velocity.
"""
import math

from numba import njit

from .geometry import closest_pitch_frame

# candidate types of the slot-mouth regions c1/c2 (docs/model.md §4.2), used by the extended mode key
NO_CANDIDATE, EDGE_ON_FACE, EDGE_ON_ARC, TIP_ON_WALL = 0, 1, 2, 3
HERTZ_POINT, JOHNSON_LINE = 0, 1
THRELFALL, AMBROSIO = 0, 1
HERTZ_EXPONENT = 1.5


@njit(cache=True)
def slot_mouth_contact(side, gx, gy, exi_x, exi_y, er_x, er_y, m):
    """Region c1 (side = +1, leading) or c2 (side = -1, trailing): the deepest valid candidate (docs/model.md §4.2).

    A edge vs flat face:   xi_E <= xi_T:                delta = t/2 - side eta_E,  n = -side e_eta,  P = E
    B edge vs tip arc:     xi_E > xi_T, side eta_E > 0:  delta = rho - |E - T|,     n = (T - E)/|T - E|, P = E
    C tip/junction vs wall: T.e_r < R_m, support P_s.e_r <= R_m:  delta = side P_s.e_theta - w/2,  n = -side e_theta
    Returns (delta, n_x, n_y, P_x, P_y, vane curvature, other curvature, candidate type); delta = -inf if none.
    """
    eeta_x, eeta_y = -exi_y, exi_x
    et_x, et_y = -er_y, er_x
    edge_x = m.mouth_radius * er_x + side * m.half_slot_width * et_x
    edge_y = m.mouth_radius * er_y + side * m.half_slot_width * et_y
    tip_x = gx + m.tip_centre * exi_x
    tip_y = gy + m.tip_centre * exi_y
    xi_e = (edge_x - gx) * exi_x + (edge_y - gy) * exi_y
    eta_e = (edge_x - gx) * eeta_x + (edge_y - gy) * eeta_y
    best = (-math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, NO_CANDIDATE)
    edge_curvature = 1.0 / m.edge_radius
    if xi_e <= m.tip_centre:
        delta = m.half_thickness - side * eta_e
        best = (delta, -side * eeta_x, -side * eeta_y, edge_x, edge_y, 0.0, edge_curvature, EDGE_ON_FACE)
    elif side * eta_e > 0.0:
        dx = tip_x - edge_x
        dy = tip_y - edge_y
        distance = math.sqrt(dx * dx + dy * dy)
        delta = m.tip_radius - distance
        if delta > best[0]:
            best = (delta, dx / distance, dy / distance, edge_x, edge_y, 1.0 / m.tip_radius, edge_curvature,
                    EDGE_ON_ARC)
    if tip_x * er_x + tip_y * er_y < m.mouth_radius:
        wall_x = side * et_x
        wall_y = side * et_y
        if wall_x * exi_x + wall_y * exi_y >= 0.0:
            support_x = tip_x + m.tip_radius * wall_x
            support_y = tip_y + m.tip_radius * wall_y
            vane_curvature = 1.0 / m.tip_radius
        else:
            support_x = tip_x + side * m.half_thickness * eeta_x
            support_y = tip_y + side * m.half_thickness * eeta_y
            vane_curvature = edge_curvature
        if support_x * er_x + support_y * er_y <= m.mouth_radius:
            delta = side * (support_x * et_x + support_y * et_y) - m.half_slot_width
            if delta > best[0]:
                best = (delta, -wall_x, -wall_y, support_x, support_y, vane_curvature, 0.0, TIP_ON_WALL)
    return best


@njit(cache=True)
def slot_bottom_contact(side, gx, gy, exi_x, exi_y, er_x, er_y, m):
    """Region c3 (side = +1) or c4 (side = -1): bottom corner B vs slot wall, half-plane method (docs/model.md §4.3).

    B = G + xi_B e_xi + side (t/2) e_eta,   delta = side B.e_theta - w/2,   n = -side e_theta,   P = B.
    Returns (delta, n_x, n_y, P_x, P_y, vane curvature, other curvature, radial position of B).
    """
    corner_x = gx + m.bottom_face * exi_x - side * m.half_thickness * exi_y
    corner_y = gy + m.bottom_face * exi_y + side * m.half_thickness * exi_x
    et_x, et_y = -er_y, er_x
    delta = side * (corner_x * et_x + corner_y * et_y) - m.half_slot_width
    return (delta, -side * et_x, -side * et_y, corner_x, corner_y, 1.0 / m.edge_radius, 0.0,
            corner_x * er_x + corner_y * er_y)


@njit(cache=True)
def tip_contact(tip_x, tip_y, exi_x, exi_y, parameter_offset, m):
    """Tip circle vs stator, regions c5 (psi_c > 0) and c6 (psi_c < 0) (docs/model.md §2.6, §4.4).

    g_C = (T - C(u*)).n(u*),  delta = g_C - c_S,  n_contact = -n(u*),  P = T + rho n(u*),
    psi_c = atan2(n.e_eta, n.e_xi),  kappa_S = kappa_C/(1 + d kappa_C),  1/R* = 1/rho - kappa_S.
    The search starts at u = atan2(T) + parameter_offset (the offset u* - atan2(T) of the last accepted step).
    Returns (delta, n_x, n_y, P_x, P_y, vane curvature, other curvature, u*, sin psi_c, cos psi_c, |S(u*)|^2).
    """
    u, cx, cy, nx, ny, curvature = closest_pitch_frame(
        tip_x, tip_y, math.atan2(tip_y, tip_x) + parameter_offset, m.law, m.stroke, m.lobes, m.bottom_dwell,
        m.top_dwell, m.base_radius)
    gap = (tip_x - cx) * nx + (tip_y - cy) * ny
    stator_curvature = curvature / (1.0 + m.envelope_offset * curvature)
    sx = cx + m.envelope_offset * nx
    sy = cy + m.envelope_offset * ny
    return (gap - m.stator_clearance, -nx, -ny, tip_x + m.tip_radius * nx, tip_y + m.tip_radius * ny,
            1.0 / m.tip_radius, -stator_curvature, u, -nx * exi_y + ny * exi_x, nx * exi_x + ny * exi_y,
            sx * sx + sy * sy)


@njit(cache=True)
def hertz_stiffness(vane_curvature, other_curvature, effective_modulus):
    """K = (4/3) E* sqrt(R*),  1/R* = 1/R_i + 1/R_j (concave negative, plane 0) (docs/model.md §5.2 option P)."""
    return 4.0 / 3.0 * effective_modulus / math.sqrt(vane_curvature + other_curvature)


@njit(cache=True)
def _line_contact_constants(vane_curvature, other_curvature, m):
    """delta(F) = F (A - B ln F) for the Johnson line contact (docs/model.md §5.2 option L):

    b = sqrt(4 F R*/(pi L E*)),  delta = F/(pi L) sum_curved c_k (2 ln(4 R_k/b) - 1),  c_k = (1 - nu^2)/E.
    """
    equivalent_radius = 1.0 / (vane_curvature + other_curvature)
    log_width_factor = math.log(4.0 * equivalent_radius / (math.pi * m.axial_length * m.effective_modulus))
    a = 0.0
    b = 0.0
    for curvature in (vane_curvature, other_curvature):
        if curvature != 0.0:
            radius = 1.0 / abs(curvature)
            a += m.compliance * (2.0 * math.log(4.0 * radius) - log_width_factor - 1.0)
            b += m.compliance
    scale = 1.0 / (math.pi * m.axial_length)
    return a * scale, b * scale


@njit(cache=True)
def elastic_force(penetration, vane_curvature, other_curvature, m):
    """Elastic normal force and stored elastic energy at penetration delta > 0 (docs/model.md §5.1-§5.2).

    Option P: F = K delta^1.5, energy K delta^2.5 / 2.5.
    Option L: F solves delta = F (A - B ln F) by Newton in ln F; energy = A F^2/2 - B F^2 ln F/2 - B F^2/4.
    """
    if m.stiffness_model == HERTZ_POINT:
        stiffness = hertz_stiffness(vane_curvature, other_curvature, m.effective_modulus)
        force = stiffness * penetration * math.sqrt(penetration)      # K delta^1.5
        return force, force * penetration / (HERTZ_EXPONENT + 1.0)
    a, b = _line_contact_constants(vane_curvature, other_curvature, m)
    log_force = math.log(penetration / (a - b * math.log(100.0)))     # start from the slope at F = 100 N
    for _ in range(50):
        force = math.exp(log_force)
        residual = force * (a - b * log_force) - penetration
        slope = force * (a - b * log_force - b)          # d residual / d ln F
        step = residual / slope
        log_force -= step
        if abs(step) < 1e-12:
            break
    force = math.exp(log_force)
    return force, 0.5 * a * force * force - 0.5 * b * force * force * log_force - 0.25 * b * force * force


@njit(cache=True)
def normal_force(elastic, penetration_rate, onset_velocity, restitution):
    """Lankarani-Nikravesh: F_n = F_el [1 + 3(1 - c_e^2)/4 * delta_dot/delta_dot^-], clamped at 0 (docs/model.md §5.1)."""
    force = elastic * (1.0 + 0.75 * (1.0 - restitution * restitution) * penetration_rate / onset_velocity)
    return force if force > 0.0 else 0.0


@njit(cache=True)
def friction_coefficient_effective(slip_speed, m):
    """mu_eff(|v_t|): Threlfall mu (1 - exp(-3|v_t|/v_0)) or Ambrosio's piecewise-linear ramp (docs/model.md §5.3)."""
    if m.friction_model == THRELFALL:
        exponent = 3.0 * slip_speed / m.friction_velocity
        if exponent > 40.0:         # 1 - exp(-40) is 1.0 in double precision
            return m.friction_coefficient
        return m.friction_coefficient * (1.0 - math.exp(-exponent))
    if slip_speed < m.friction_velocity:
        return 0.0
    if slip_speed > m.friction_velocity_full:
        return m.friction_coefficient
    return m.friction_coefficient * (slip_speed - m.friction_velocity) / (m.friction_velocity_full
                                                                          - m.friction_velocity)
