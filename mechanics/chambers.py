"""Leading (L) and trailing (T) chamber volumes of the active lobe and their rates (docs/model.md §7.2, §6.2, §6.4).

Volumes follow from Green's theorem, A = 1/2 oint (x dy - y dx) on a counter-clockwise boundary, times the
axial length L. The trailing chamber T of lobe k is bounded by
  1. the stator S(u) from the start valley u_k to the closest point u*:  1/2 int S x S' du;
  2. the tip gap, the segment S(u*) -> P_V = T + rho n(u*) (zero length when the tip touches the stator);
  3. the trailing tip arc from psi_c to -pi/2, ending at the junction J-;
  4. the slot-side path from J- to the slot edge E-: the exposed trailing face J- -> F- down to the level of E-
     (if xi_T > xi_E-), then either the slot-mouth gap -> E- or, when the junction is recessed below the mouth
     (r_J- < R_m), the gap -> W- (slot-wall point at the junction radius) and the slot wall W- -> E- (the
     rotor crescent of docs/model.md §6.2);
  5. the rotor arc from E- (polar angle theta - alpha_m, alpha_m = atan2(w/2, R_m)) back to the valley,
     clockwise: 1/2 R_r^2 (u_k - theta + alpha_m);
  6. the valley gap, the radial segment from R_r to R_r + c_S at u_k (fixed, no Green term).
The leading chamber L is the same construction on the other side, from u* to the end valley u_k + 2 pi/z.
A straight segment P -> Q adds 1/2 P x Q; a circular arc of centre c and radius rho from P to Q through the
swept angle Delta adds 1/2 c x (Q - P) + 1/2 rho^2 Delta. Only the geometric volume is returned; the caller adds
the dead volume.

The rate of a volume is the normal velocity of its boundary, integrated over it (Reynolds transport). On the
wetted vane surfaces and the wetted slot wall this is the mechanical power of a unit pressure on them, i.e. the
docs/model.md §6.2 resultants of `gas_loads` at p_sigma = 1 with all other pressures 0 (docs/model.md §7.2); the stator and the
rotor circle sweep nothing. The gaps (tip gap, slot-mouth gaps) carry no load but move: their swept area
1/2 (v_P + v_Q) x (Q - P) per segment P -> Q is the gap term, zero when the gaps are closed (c_S = c_R = 0 on
the nominal path). Hence
  dV_sigma/dt = (unit-pressure power on sigma's wetted vane and rotor surfaces) + gap_sigma,
  P_gas = sum_sigma p_sigma (dV_sigma/dt - gap_sigma)                         (docs/model.md §6.4, exact).
"""
import math

import numpy as np
from numba import njit

from .displacement import HARMONIC, HARMONIC_DWELL, displacement
from .gas_loads import rotor_gas_moment, vane_gas_load
from .geometry import pitch_frame

# Gauss-Legendre nodes on [-1, 1]: the harmonic law is analytic over the lobe and 16 points reach rounding error on
# half a lobe up to z = 12; the rise of the piecewise laws holds a full period of the cam curve and needs 24.
HARMONIC_NODES, HARMONIC_WEIGHTS = np.polynomial.legendre.leggauss(16)
PIECEWISE_NODES, PIECEWISE_WEIGHTS = np.polynomial.legendre.leggauss(24)


@njit(cache=True)
def _steiner_integrand(phase, m):
    """1/2 r^2 + d N(u), r = R0 + s(u), N = sqrt(r^2 + r'^2): the non-exact part of 1/2 S x S' (docs/model.md §2.5)."""
    s, s1, _, _ = displacement(phase, m.law, m.stroke, m.lobes, m.bottom_dwell, m.top_dwell)
    r = m.base_radius + s
    return 0.5 * r * r + m.envelope_offset * math.sqrt(r * r + s1 * s1)


@njit(cache=True)
def _gauss_legendre(start, end, m):
    """int_start^end (1/2 r^2 + d N) du by Gauss-Legendre on one smooth piece of at most half a lobe."""
    if m.law == HARMONIC:
        nodes, weights = HARMONIC_NODES, HARMONIC_WEIGHTS
    else:
        nodes, weights = PIECEWISE_NODES, PIECEWISE_WEIGHTS
    half = 0.5 * (end - start)
    middle = 0.5 * (end + start)
    total = 0.0
    for i in range(nodes.size):
        total += weights[i] * _steiner_integrand(middle + half * nodes[i], m)
    return half * total


@njit(cache=True)
def _smooth_part(extent, m):
    """int_0^extent (1/2 r^2 + d N) du over lobe phases 0 <= extent <= pi/z, split at the ends of the dwells of
    the harmonic_dwell law so that every Gauss-Legendre piece is smooth (the other laws are smooth there)."""
    if m.law != HARMONIC_DWELL:
        return _gauss_legendre(0.0, extent, m)
    total = 0.0
    start = 0.0
    for breakpoint in (0.5 * m.bottom_dwell, math.pi / m.lobes - 0.5 * m.top_dwell):
        if start < breakpoint < extent:
            total += _gauss_legendre(start, breakpoint, m)
            start = breakpoint
    return total + _gauss_legendre(start, extent, m)


def stator_lobe_integral(m) -> float:
    """int (1/2 r^2 + d N) du over a whole lobe (twice the half-lobe integral, the laws being even about the
    mid-lobe): a constant of the machine, computed once (Machine.stator_lobe_integral)."""
    return 2.0 * _smooth_part(0.5 * 2.0 * math.pi / m.lobes, m)


@njit(cache=True)
def stator_sectors(closest_phase, m):
    """1/2 int S x S' du from the start valley to u* (trailing) and from u* to the end valley (leading), in terms
    of the lobe phase phi* = u* - u_k of the closest point (docs/model.md §2.5, §7.2 piece 1).

    With S = C + d n, C x C' = r^2, C x n = -r r'/N and n x n' = kappa_C N = 1 - beta' (Steiner's formula):
      1/2 S x S' = 1/2 r^2 + d N - 1/2 d (r r'/N)' + 1/2 d^2 (1 - beta'),   beta = atan2(r', r)
    so only int (1/2 r^2 + d N) du needs quadrature (Gauss-Legendre per smooth piece of at most half a lobe).
    The laws are even about the valleys and the mid-lobe, so the longer of the two pieces is the half-lobe integral
    doubled minus the shorter one. r' = 0 and beta = 0 at the valleys.
    Returns (leading sector, trailing sector) [m^2].
    """
    lobe = 2.0 * math.pi / m.lobes
    shorter = min(closest_phase, lobe - closest_phase)
    short_part = math.copysign(_smooth_part(abs(shorter), m), shorter)
    long_part = m.stator_lobe_integral - short_part
    if closest_phase <= 0.5 * lobe:
        trailing, leading = short_part, long_part
    else:
        trailing, leading = long_part, short_part
    s, s1, _, _ = displacement(closest_phase, m.law, m.stroke, m.lobes, m.bottom_dwell, m.top_dwell)
    r = m.base_radius + s
    d = m.envelope_offset
    boundary = 0.5 * d * r * s1 / math.sqrt(r * r + s1 * s1)
    turning = 0.5 * d * d * math.atan2(s1, r)
    return (leading + boundary + 0.5 * d * d * (lobe - closest_phase) + turning,
            trailing - boundary + 0.5 * d * d * closest_phase - turning)


@njit(cache=True)
def _segment(ax, ay, bx, by, avx, avy, bvx, bvy):
    """Green term 1/2 a x b of the segment a -> b, and the area it sweeps per unit time to its right (outside a
    counter-clockwise boundary) when its ends move at v_a, v_b: 1/2 (v_a + v_b) x (b - a)."""
    return (0.5 * (ax * by - ay * bx),
            0.5 * ((avx + bvx) * (by - ay) - (avy + bvy) * (bx - ax)))


@njit(cache=True)
def _slot_side(side, gx, gy, exi_x, exi_y, vx, vy, phi_dot, er_x, er_y, omega, m):
    """The slot-side boundary of chamber `side` (+1 leading, -1 trailing), oriented from the tip junction J down
    to the slot edge E (docs/model.md §6.2, §7.2 piece 2):

      J = T + side (t/2) e_eta (vane),  E = R_m e_r + side (w/2) e_theta (rotor),  xi_E = (E - G).e_xi,
      r_J = J.e_r;  exposed face J -> F, F = G + xi_E e_xi + side (t/2) e_eta, if xi_T > xi_E;
      recessed (r_J < R_m): gap -> W = r_J e_r + side (w/2) e_theta, then slot wall W -> E; else gap -> E.
    Returns (xi_E, r_J, Green sum of the path [m^2], area swept by its gap segment to its right [m^2/s]).
    """
    eeta_x, eeta_y = -exi_y, exi_x
    et_x, et_y = -er_y, er_x
    edge_x = m.mouth_radius * er_x + side * m.half_slot_width * et_x
    edge_y = m.mouth_radius * er_y + side * m.half_slot_width * et_y
    edge_vx = -omega * edge_y
    edge_vy = omega * edge_x
    junction_x = gx + m.tip_centre * exi_x + side * m.half_thickness * eeta_x
    junction_y = gy + m.tip_centre * exi_y + side * m.half_thickness * eeta_y
    junction_vx = vx - phi_dot * (junction_y - gy)
    junction_vy = vy + phi_dot * (junction_x - gx)
    mouth_level = (edge_x - gx) * exi_x + (edge_y - gy) * exi_y
    junction_radius = junction_x * er_x + junction_y * er_y
    px, py, pvx, pvy = junction_x, junction_y, junction_vx, junction_vy
    area = 0.0
    if m.tip_centre > mouth_level:              # exposed flat face, J -> F
        level_rate = ((edge_vx - vx) * exi_x + (edge_vy - vy) * exi_y
                      + phi_dot * ((edge_x - gx) * eeta_x + (edge_y - gy) * eeta_y))
        px = gx + mouth_level * exi_x + side * m.half_thickness * eeta_x
        py = gy + mouth_level * exi_y + side * m.half_thickness * eeta_y
        pvx = vx + level_rate * exi_x + phi_dot * (mouth_level * eeta_x - side * m.half_thickness * exi_x)
        pvy = vy + level_rate * exi_y + phi_dot * (mouth_level * eeta_y - side * m.half_thickness * exi_y)
        area += 0.5 * (junction_x * py - junction_y * px)
    if junction_radius < m.mouth_radius:        # recessed junction: gap to the wall, then the wall up to E
        radius_rate = (junction_vx * er_x + junction_vy * er_y
                       + omega * (junction_x * et_x + junction_y * et_y))
        wall_x = junction_radius * er_x + side * m.half_slot_width * et_x
        wall_y = junction_radius * er_y + side * m.half_slot_width * et_y
        wall_vx = radius_rate * er_x + omega * (junction_radius * et_x - side * m.half_slot_width * er_x)
        wall_vy = radius_rate * er_y + omega * (junction_radius * et_y - side * m.half_slot_width * er_y)
        gap_area, gap_sweep = _segment(px, py, wall_x, wall_y, pvx, pvy, wall_vx, wall_vy)
        area += gap_area + 0.5 * (wall_x * edge_y - wall_y * edge_x)
    else:
        gap_area, gap_sweep = _segment(px, py, edge_x, edge_y, pvx, pvy, edge_vx, edge_vy)
        area += gap_area
    return mouth_level, junction_radius, area, gap_sweep


@njit(cache=True)
def _vane_side_boundaries(gx, gy, phi, vx, vy, phi_dot, theta, omega, closest_parameter, m):
    """Green sums of the chamber boundary pieces between the stator point S(u*) and the slot edges E+-
    (tip gap, tip arcs, slot-side paths), and the areas their gaps sweep per unit time (docs/model.md §7.2 pieces 2-4).

    Tip gap S(u*) -> P_V = T + rho n(u*), with S' = N (1 + d kappa_C) tau and n' = N kappa_C tau;
    u*' = (v_T . tau)/(N (1 + g_C kappa_C)) from (T - C(u*)).C'(u*) = 0, g_C = (T - C).n.
    Tip arcs: trailing P_V -> J- (psi_c -> -pi/2), leading J+ -> P_V (pi/2 -> psi_c).
    Returns (leading sum, trailing sum [m^2], leading gap sweep, trailing gap sweep [m^2/s], xi_E+, xi_E-,
    r_J+, r_J-, e_xi, sin psi_c, cos psi_c): the last ones are the inputs of the docs/model.md §6.2 gas loads.
    """
    exi_x = math.cos(phi)
    exi_y = math.sin(phi)
    eeta_x, eeta_y = -exi_y, exi_x
    er_x = math.cos(theta)
    er_y = math.sin(theta)
    tip_x = gx + m.tip_centre * exi_x
    tip_y = gy + m.tip_centre * exi_y
    tip_vx = vx - phi_dot * m.tip_centre * exi_y
    tip_vy = vy + phi_dot * m.tip_centre * exi_x
    cx, cy, nx, ny, speed, curvature = pitch_frame(closest_parameter, m.law, m.stroke, m.lobes, m.bottom_dwell,
                                                   m.top_dwell, m.base_radius)
    tau_x, tau_y = -ny, nx
    d = m.envelope_offset
    rho = m.tip_radius
    pitch_gap = (tip_x - cx) * nx + (tip_y - cy) * ny
    parameter_rate = (tip_vx * tau_x + tip_vy * tau_y) / (speed * (1.0 + pitch_gap * curvature))
    stator_speed = speed * (1.0 + d * curvature) * parameter_rate
    normal_turn = rho * speed * curvature * parameter_rate
    stator_x = cx + d * nx
    stator_y = cy + d * ny
    vane_x = tip_x + rho * nx
    vane_y = tip_y + rho * ny
    tip_gap, tip_sweep = _segment(stator_x, stator_y, vane_x, vane_y, stator_speed * tau_x, stator_speed * tau_y,
                                  tip_vx + normal_turn * tau_x, tip_vy + normal_turn * tau_y)
    cos_contact = nx * exi_x + ny * exi_y
    sin_contact = nx * eeta_x + ny * eeta_y
    contact_angle = math.atan2(sin_contact, cos_contact)
    # arcs about T: 1/2 T x (Q - P) + 1/2 rho^2 Delta, with J+- = T +- rho e_eta
    trailing_arc = (0.5 * (tip_x * (-rho * eeta_y - rho * ny) - tip_y * (-rho * eeta_x - rho * nx))
                    + 0.5 * rho * rho * (-0.5 * math.pi - contact_angle))
    leading_arc = (0.5 * (tip_x * (rho * ny - rho * eeta_y) - tip_y * (rho * nx - rho * eeta_x))
                   + 0.5 * rho * rho * (contact_angle - 0.5 * math.pi))
    level_l, radius_l, path_l, sweep_l = _slot_side(1.0, gx, gy, exi_x, exi_y, vx, vy, phi_dot, er_x, er_y, omega,
                                                    m)
    level_t, radius_t, path_t, sweep_t = _slot_side(-1.0, gx, gy, exi_x, exi_y, vx, vy, phi_dot, er_x, er_y,
                                                    omega, m)
    return (-tip_gap + leading_arc - path_l, tip_gap + trailing_arc + path_t, -tip_sweep - sweep_l,
            tip_sweep + sweep_t, level_l, level_t, radius_l, radius_t, exi_x, exi_y, sin_contact, cos_contact)


@njit(cache=True)
def chamber_volumes(x, y, phi, theta, closest_parameter, lobe_start, m):
    """Geometric volumes (V_L, V_T) [m^3] of the leading and trailing chambers of the active lobe (docs/model.md §7.2).

    x, y, phi: vane pose (centre of mass G, axis angle phi3); theta: rotor angle (slot centreline), in the same
    2 pi branch as lobe_start; closest_parameter: u* of the stator point closest to the tip centre (tip_contact,
    any 2 pi branch); lobe_start: u_k, angle of the valley that opened the lobe (the lobe ends at u_k + 2 pi/z).
      V_T = L [1/2 int_{u_k}^{u*} S x S' du + boundary pieces + 1/2 R_r^2 (u_k - theta + alpha_m)]
      V_L = L [1/2 int_{u*}^{u_k + 2 pi/z} S x S' du + boundary pieces + 1/2 R_r^2 (theta + alpha_m - u_k - 2 pi/z)]
    alpha_m = atan2(w/2, R_m). No dead volume is included.
    """
    closest = closest_parameter + 2.0 * math.pi * round((theta - closest_parameter) / (2.0 * math.pi))
    leading_stator, trailing_stator = stator_sectors(closest - lobe_start, m)
    boundaries = _vane_side_boundaries(x, y, phi, 0.0, 0.0, 0.0, theta, 0.0, closest, m)
    mouth_half_angle = math.atan2(m.half_slot_width, m.mouth_radius)
    rotor_phase = theta - lobe_start
    half_square = 0.5 * m.rotor_radius * m.rotor_radius
    lobe = 2.0 * math.pi / m.lobes
    leading = leading_stator + boundaries[0] - half_square * (lobe - rotor_phase - mouth_half_angle)
    trailing = trailing_stator + boundaries[1] - half_square * (rotor_phase - mouth_half_angle)
    return m.axial_length * leading, m.axial_length * trailing


@njit(cache=True)
def chamber_volume_rates(x, y, phi, vx, vy, phi_dot, theta, omega, closest_parameter, m):
    """(dV_L/dt, dV_T/dt, gap_L, gap_T) [m^3/s]: the exact time derivatives of `chamber_volumes` and their gap
    parts (docs/model.md §7.2, §6.4).

    x, y, phi, vx, vy, phi_dot: vane pose and velocity (centre of mass G); theta, omega: rotor angle and speed;
    closest_parameter: the converged u* of the pose (any 2 pi branch; its rate follows from the closest-point
    condition). With the docs/model.md §6.2 resultants of `gas_loads`:
      dV_sigma/dt = [vane_gas_load power + rotor_gas_moment omega](p_sigma = 1, other pressures 0) + gap_sigma
    gap_sigma = L sum 1/2 (v_P + v_Q) x (Q - P) over the load-free gap segments of chamber sigma (tip gap and
    slot-mouth gap), so P_gas = sum_sigma p_sigma (dV_sigma/dt - gap_sigma) holds exactly.
    """
    (_, _, gap_l, gap_t, level_l, level_t, radius_l, radius_t, exi_x, exi_y, sin_contact,
     cos_contact) = _vane_side_boundaries(x, y, phi, vx, vy, phi_dot, theta, omega, closest_parameter, m)
    wall_l = (vane_gas_load(vx, vy, phi_dot, exi_x, exi_y, level_l, level_t, sin_contact, cos_contact, 1.0, 0.0,
                            0.0, m)[3]
              + omega * rotor_gas_moment(radius_l, radius_t, 0.0, 0.0, 1.0, 0.0, 0.0, m))
    wall_t = (vane_gas_load(vx, vy, phi_dot, exi_x, exi_y, level_l, level_t, sin_contact, cos_contact, 0.0, 1.0,
                            0.0, m)[3]
              + omega * rotor_gas_moment(radius_l, radius_t, 0.0, 0.0, 0.0, 1.0, 0.0, m))
    gap_l *= m.axial_length
    gap_t *= m.axial_length
    return wall_l + gap_l, wall_t + gap_t, gap_l, gap_t
