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
swept angle Delta adds 1/2 c x (Q - P) + 1/2 rho^2 Delta. Only the geometric volume is returned; the chamber
model adds the dead volume.

The stator piece 1 needs int (1/2 r^2 + d N) du from the valley (Steiner's formula, `stator_sectors`); it is a
machine constant tabulated once (`sector_table`, cubic Hermite in the lobe phase with the exact integrand as
derivative, nodes on every breakpoint of the displacement law), so a volume costs a table lookup.

The rate of a volume is the normal velocity of its boundary, integrated over it (Reynolds transport). On the
wetted vane surfaces and the wetted slot wall this is the mechanical power of a unit pressure on them, i.e. the
docs/model.md §6.2 unit loads of `gas_loads.gas_load_basis` (docs/model.md §7.2); the stator and the rotor
circle sweep nothing. The gaps (tip gap, slot-mouth gaps) carry no load but move: their swept area
1/2 (v_P + v_Q) x (Q - P) per segment P -> Q is the gap term, zero when the gaps are closed. Hence
  dV_sigma/dt = (unit-pressure power on sigma's wetted vane and rotor surfaces) + gap_sigma,
  P_gas = sum_sigma p_sigma (dV_sigma/dt - gap_sigma)                         (docs/model.md §6.4, exact).
"""
import math
from typing import NamedTuple

import numpy as np

from ...kernels.kernel import kernel

from .displacement import HARMONIC, HARMONIC_DWELL, displacement

# Gauss-Legendre nodes on [-1, 1] for building the sector table: the harmonic law is analytic over the lobe and 16
# points reach rounding error on half a lobe up to z = 12; the rise of the piecewise laws needs 24.
HARMONIC_NODES, HARMONIC_WEIGHTS = np.polynomial.legendre.leggauss(16)
PIECEWISE_NODES, PIECEWISE_WEIGHTS = np.polynomial.legendre.leggauss(24)
SECTOR_INTERVALS = 2048             # Hermite intervals over half a lobe (error measured in tests/mechanics/test_chambers.py)


class ChamberGeometry(NamedTuple):
    """Geometric volumes of the two chambers (no dead volume) and of the back chamber [m^3], their rates and the gap
    parts of the rates [m^3/s] (docs/model.md §7.2)."""
    volume_leading: float
    volume_trailing: float
    rate_leading: float
    rate_trailing: float
    gap_leading: float
    gap_trailing: float
    volume_back: float
    rate_back: float
    gap_back: float


@kernel
def _rotor_frame_corner(side, p, m):
    """(r, eta, dr/dt, deta/dt) of the vane's bottom corner B = G + xi_B e_xi + side (t/2) e_eta in the rotor frame
    (r = B.e_r, eta = B.e_theta; d e_r/dt = omega e_theta)."""
    arm_x = m.bottom_face * p.exi_x - side * m.half_thickness * p.exi_y
    arm_y = m.bottom_face * p.exi_y + side * m.half_thickness * p.exi_x
    bx, by = p.gx + arm_x, p.gy + arm_y
    vx, vy = p.vx - p.phi_dot * arm_y, p.vy + p.phi_dot * arm_x
    radius = bx * p.er_x + by * p.er_y
    across = -bx * p.er_y + by * p.er_x
    return (radius, across, vx * p.er_x + vy * p.er_y + p.omega * across,
            -vx * p.er_y + vy * p.er_x - p.omega * radius)


@kernel
def back_chamber(p, m):
    """(volume, rate) of the back chamber, the slot below the vane (docs/model.md §7.2): in the rotor frame (r, eta)
    the polygon slot bottom (r_sb, -w/2) -> (r_sb, w/2) -> wall (r_B+, w/2) -> corner B+ -> corner B- ->
    wall (r_B-, -w/2), whose area is A = -1/2 sum (x_i y_i+1 - x_i+1 y_i) (clockwise in (r, eta)); V = L A and
    dV/dt = L dA/dt. The wall-to-corner segments are the back chamber's gaps."""
    half_width = m.half_slot_width
    r_p, eta_p, dr_p, deta_p = _rotor_frame_corner(1.0, p, m)
    r_m, eta_m, dr_m, deta_m = _rotor_frame_corner(-1.0, p, m)
    xs = (m.slot_bottom_radius, m.slot_bottom_radius, r_p, r_p, r_m, r_m)
    ys = (-half_width, half_width, half_width, eta_p, eta_m, -half_width)
    dxs = (0.0, 0.0, dr_p, dr_p, dr_m, dr_m)
    dys = (0.0, 0.0, 0.0, deta_p, deta_m, 0.0)
    area = 0.0
    rate = 0.0
    for i in range(6):
        j = (i + 1) % 6
        area -= 0.5 * (xs[i] * ys[j] - xs[j] * ys[i])
        rate -= 0.5 * (dxs[i] * ys[j] + xs[i] * dys[j] - dxs[j] * ys[i] - xs[j] * dys[i])
    return m.axial_length * area, m.axial_length * rate


class SectorTable(NamedTuple):
    """int_0^x (1/2 r^2 + d N) du on [0, pi/z]: segment rows (start, inverse step, first node) and node rows
    (value, derivative)."""
    segments: np.ndarray
    nodes: np.ndarray


@kernel
def _steiner_integrand(phase, m):
    """1/2 r^2 + d N(u), r = R0 + s(u), N = sqrt(r^2 + r'^2): the non-exact part of 1/2 S x S' (docs/model.md §2.5)."""
    s, s1, _, _ = displacement(phase, m.law, m.stroke, m.lobes, m.bottom_dwell, m.top_dwell)
    r = m.base_radius + s
    return 0.5 * r * r + m.envelope_offset * math.sqrt(r * r + s1 * s1)


@kernel
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


def _breakpoints(m) -> list[float]:
    """Phases in [0, pi/z] where the displacement law is not smooth (ends of the dwells of harmonic_dwell)."""
    half_lobe = math.pi / m.lobes
    points = [0.0, half_lobe]
    if m.law == HARMONIC_DWELL:
        points += [0.5 * m.bottom_dwell, half_lobe - 0.5 * m.top_dwell]
    return sorted({p for p in points if 0.0 <= p <= half_lobe})


@kernel
def _tabulate_sector(edges, m, nodes, first):
    """Node rows first + 1 ... first + edges.size - 1 of a SectorTable from row `first`: each value the previous one
    plus the Gauss-Legendre integral over the interval between consecutive `edges`, each derivative the integrand at
    the interval's end (one call per smooth piece: called per interval from Python, the dispatch cost more than
    the integrals)."""
    for k in range(edges.size - 1):
        nodes[first + k + 1, 0] = nodes[first + k, 0] + _gauss_legendre(edges[k], edges[k + 1], m)
        nodes[first + k + 1, 1] = _steiner_integrand(edges[k + 1], m)


def sector_table(m, intervals=SECTOR_INTERVALS) -> SectorTable:
    """Tabulate F(x) = int_0^x (1/2 r^2 + d N) du over half a lobe (the laws are even about the valley and the
    mid-lobe): F at each node by Gauss-Legendre over the smooth piece from the previous node, F' = the integrand."""
    points = _breakpoints(m)
    total = points[-1] - points[0]
    counts = [max(8, int(round(intervals * (end - start) / total))) for start, end in zip(points[:-1], points[1:])]
    nodes = np.zeros((sum(counts) + 1, 2))
    nodes[0, 1] = _steiner_integrand(0.0, m)
    segments, first = [], 0
    for start, end, count in zip(points[:-1], points[1:], counts):
        segments.append((start, count / (end - start), first))
        _tabulate_sector(np.linspace(start, end, count + 1), m, nodes, first)
        first += count
    return SectorTable(np.array(segments, dtype=np.float64), nodes)


@kernel
def sector_integral(x, table):
    """F(x) for 0 <= x <= pi/z by cubic Hermite interpolation of the table (docs/model.md §7.2 piece 1)."""
    segments = table.segments
    k = 0
    while k + 1 < segments.shape[0] and x >= segments[k + 1, 0]:
        k += 1
    inverse_step = segments[k, 1]
    position = (x - segments[k, 0]) * inverse_step
    last = (segments[k + 1, 2] if k + 1 < segments.shape[0] else table.nodes.shape[0] - 1) - segments[k, 2] - 1
    i = min(max(int(position), 0), int(last))
    t = position - i
    row = int(segments[k, 2]) + i
    step = 1.0 / inverse_step
    f0, d0 = table.nodes[row, 0], table.nodes[row, 1]
    f1, d1 = table.nodes[row + 1, 0], table.nodes[row + 1, 1]
    t2 = t * t
    t3 = t2 * t
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * f0 + (t3 - 2.0 * t2 + t) * step * d0 + (3.0 * t2 - 2.0 * t3) * f1
            + (t3 - t2) * step * d1)


@kernel
def stator_sectors(closest_phase, m, table):
    """1/2 int S x S' du from the start valley to u* (trailing) and from u* to the end valley (leading), in terms
    of the lobe phase phi* = u* - u_k of the closest point (docs/model.md §2.5, §7.2 piece 1).

    With S = C + d n, C x C' = r^2, C x n = -r r'/N and n x n' = kappa_C N = 1 - beta' (Steiner's formula):
      1/2 S x S' = 1/2 r^2 + d N - 1/2 d (r r'/N)' + 1/2 d^2 (1 - beta'),   beta = atan2(r', r)
    so only F = int (1/2 r^2 + d N) du needs the table. The laws are even about the valleys and the mid-lobe, so
    the longer of the two pieces is the whole-lobe integral minus the shorter one. r' = 0 and beta = 0 at the
    valleys. Returns (leading sector, trailing sector) [m^2].
    """
    lobe = 2.0 * math.pi / m.lobes
    shorter = min(closest_phase, lobe - closest_phase)
    short_part = math.copysign(sector_integral(abs(shorter), table), shorter)
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


@kernel
def _segment(ax, ay, bx, by, avx, avy, bvx, bvy):
    """Green term 1/2 a x b of the segment a -> b, and the area it sweeps per unit time to its right (outside a
    counter-clockwise boundary) when its ends move at v_a, v_b: 1/2 (v_a + v_b) x (b - a)."""
    return (0.5 * (ax * by - ay * bx),
            0.5 * ((avx + bvx) * (by - ay) - (avy + bvy) * (bx - ax)))


@kernel
def _slot_side_path(side, s, pose, m):
    """Green sum of the slot-side path of chamber `side` (+1 leading, -1 trailing) from the tip junction J down to
    the slot edge E, and the area its gap segment sweeps to its right (docs/model.md §6.2, §7.2 piece 4):

      exposed face J -> F, F = G + xi_E e_xi + side (t/2) e_eta, if xi_T > xi_E;
      recessed (r_J < R_m): gap -> W = r_J e_r + side (w/2) e_theta, then slot wall W -> E; else gap -> E.
    """
    p = pose
    eeta_x, eeta_y = -p.exi_y, p.exi_x
    et_x, et_y = -p.er_y, p.er_x
    edge_vx = -p.omega * s.edge_y
    edge_vy = p.omega * s.edge_x
    junction_vx = p.vx - p.phi_dot * (s.junction_y - p.gy)
    junction_vy = p.vy + p.phi_dot * (s.junction_x - p.gx)
    px, py, pvx, pvy = s.junction_x, s.junction_y, junction_vx, junction_vy
    area = 0.0
    if m.tip_centre > s.mouth_level:              # exposed flat face, J -> F
        level_rate = ((edge_vx - p.vx) * p.exi_x + (edge_vy - p.vy) * p.exi_y
                      + p.phi_dot * ((s.edge_x - p.gx) * eeta_x + (s.edge_y - p.gy) * eeta_y))
        px = p.gx + s.mouth_level * p.exi_x + side * m.half_thickness * eeta_x
        py = p.gy + s.mouth_level * p.exi_y + side * m.half_thickness * eeta_y
        pvx = p.vx + level_rate * p.exi_x + p.phi_dot * (s.mouth_level * eeta_x - side * m.half_thickness * p.exi_x)
        pvy = p.vy + level_rate * p.exi_y + p.phi_dot * (s.mouth_level * eeta_y - side * m.half_thickness * p.exi_y)
        area += 0.5 * (s.junction_x * py - s.junction_y * px)
    if s.junction_radius < m.mouth_radius:        # recessed junction: gap to the wall, then the wall up to E
        radius_rate = (junction_vx * p.er_x + junction_vy * p.er_y
                       + p.omega * (s.junction_x * et_x + s.junction_y * et_y))
        wall_x = s.junction_radius * p.er_x + side * m.half_slot_width * et_x
        wall_y = s.junction_radius * p.er_y + side * m.half_slot_width * et_y
        wall_vx = radius_rate * p.er_x + p.omega * (s.junction_radius * et_x - side * m.half_slot_width * p.er_x)
        wall_vy = radius_rate * p.er_y + p.omega * (s.junction_radius * et_y - side * m.half_slot_width * p.er_y)
        gap_area, gap_sweep = _segment(px, py, wall_x, wall_y, pvx, pvy, wall_vx, wall_vy)
        area += gap_area + 0.5 * (wall_x * s.edge_y - wall_y * s.edge_x)
    else:
        gap_area, gap_sweep = _segment(px, py, s.edge_x, s.edge_y, pvx, pvy, edge_vx, edge_vy)
        area += gap_area
    return area, gap_sweep


@kernel
def chamber_geometry(pose, tip, sides, basis, lobe_start, m, table):
    """ChamberGeometry of the pose (docs/model.md §7.2): the boundary pieces between the stator point S(u*) and the
    slot edges E+- (tip gap, tip arcs, slot-side paths) with the areas their gaps sweep, the stator sectors and the
    rotor arcs; the rates from the unit-pressure loads `basis` plus the gap sweeps.

    Tip gap S(u*) -> P_V = T + rho n(u*), with S' = N (1 + d kappa_C) tau and n' = N kappa_C tau;
    u*' = (v_T . tau)/(N (1 + g_C kappa_C)) from (T - C(u*)).C'(u*) = 0, g_C = (T - C).n.
    Tip arcs: trailing P_V -> J- (psi_c -> -pi/2), leading J+ -> P_V (pi/2 -> psi_c).
      V_T = L [1/2 int_{u_k}^{u*} S x S' du + boundary pieces + 1/2 R_r^2 (u_k - theta + alpha_m)]
      V_L = L [1/2 int_{u*}^{u_k + 2 pi/z} S x S' du + boundary pieces + 1/2 R_r^2 (theta + alpha_m - u_k - 2 pi/z)]
    alpha_m = atan2(w/2, R_m); theta and u_k in the same 2 pi branch, u* taken into theta's branch.
    """
    p = pose
    eeta_x, eeta_y = -p.exi_y, p.exi_x
    tip_vx = p.vx - p.phi_dot * m.tip_centre * p.exi_y
    tip_vy = p.vy + p.phi_dot * m.tip_centre * p.exi_x
    nx, ny = tip.pitch_normal_x, tip.pitch_normal_y
    tau_x, tau_y = -ny, nx
    d = m.envelope_offset
    rho = m.tip_radius
    pitch_gap = (p.tip_x - tip.pitch_x) * nx + (p.tip_y - tip.pitch_y) * ny
    parameter_rate = (tip_vx * tau_x + tip_vy * tau_y) / (tip.pitch_speed * (1.0 + pitch_gap * tip.pitch_curvature))
    stator_speed = tip.pitch_speed * (1.0 + d * tip.pitch_curvature) * parameter_rate
    normal_turn = rho * tip.pitch_speed * tip.pitch_curvature * parameter_rate
    tip_gap, tip_sweep = _segment(tip.pitch_x + d * nx, tip.pitch_y + d * ny, p.tip_x + rho * nx, p.tip_y + rho * ny,
                                  stator_speed * tau_x, stator_speed * tau_y, tip_vx + normal_turn * tau_x,
                                  tip_vy + normal_turn * tau_y)
    contact_angle = math.atan2(tip.sin_contact_angle, tip.cos_contact_angle)
    # arcs about T: 1/2 T x (Q - P) + 1/2 rho^2 Delta, with J+- = T +- rho e_eta
    trailing_arc = (0.5 * (p.tip_x * (-rho * eeta_y - rho * ny) - p.tip_y * (-rho * eeta_x - rho * nx))
                    + 0.5 * rho * rho * (-0.5 * math.pi - contact_angle))
    leading_arc = (0.5 * (p.tip_x * (rho * ny - rho * eeta_y) - p.tip_y * (rho * nx - rho * eeta_x))
                   + 0.5 * rho * rho * (contact_angle - 0.5 * math.pi))
    path_l, sweep_l = _slot_side_path(1.0, sides[0], p, m)
    path_t, sweep_t = _slot_side_path(-1.0, sides[1], p, m)
    closest = tip.closest_parameter + 2.0 * math.pi * round((p.theta - tip.closest_parameter) / (2.0 * math.pi))
    leading_stator, trailing_stator = stator_sectors(closest - lobe_start, m, table)
    mouth_half_angle = math.atan2(m.half_slot_width, m.mouth_radius)
    rotor_phase = p.theta - lobe_start
    half_square = 0.5 * m.rotor_radius * m.rotor_radius
    lobe = 2.0 * math.pi / m.lobes
    leading = leading_stator - tip_gap + leading_arc - path_l - half_square * (lobe - rotor_phase - mouth_half_angle)
    trailing = trailing_stator + tip_gap + trailing_arc + path_t - half_square * (rotor_phase - mouth_half_angle)
    gap_l = m.axial_length * (-tip_sweep - sweep_l)
    gap_t = m.axial_length * (tip_sweep + sweep_t)
    wall_l = basis.leading.power + p.omega * basis.leading.rotor_moment
    wall_t = basis.trailing.power + p.omega * basis.trailing.rotor_moment
    volume_back, rate_back = back_chamber(p, m)
    wall_b = basis.back.power + p.omega * basis.back.rotor_moment
    return ChamberGeometry(m.axial_length * leading, m.axial_length * trailing, wall_l + gap_l, wall_t + gap_t,
                           gap_l, gap_t, volume_back, rate_back, rate_back - wall_b)
