"""Chamber areas by counting points: an independent check of the Green's-theorem chamber volumes of docs/model.md §7.2.

The library walks the boundary of each chamber and sums 1/2 (x dy - y dx) along it. Here the plane is sampled
instead (one jittered point per cell of a polar grid that is uniform in r^2 and in the polar angle, so every cell
has the same area), and each point is classified by membership tests on the bodies themselves:

- inside the stator: inside the pitch curve C (a polar curve, so r <= r_C(angle)) or within d = rho + c_S of it
  (the stator is the outer offset of C, docs/model.md §2.5); the distance by Newton's method on (X - C(u)).C'(u);
- the rotor body: the disc of radius R_r without the slot (|eta_R| < w/2, r_R > r_sb), docs/model.md §2.2;
- the vane body: the rectangle xi_B <= xi <= xi_T, |eta| <= t/2 and the tip disc of radius rho about T (§2.1);
- the side of the vane: a point beside the vane (xi <= xi_T) is leading if eta > 0; above the tip centre the
  divider is the line from T through the contact point P_V along the stator normal n(u*) (the tip gap, §7.2).

The chambers are then these sets (what the boundary walk of docs/model.md §7.2 encloses, counted with its winding
number):

- the slot pocket of side sigma: points inside the rotor circle, in the slot, outside the vane, on side sigma and
  above the slot-mouth gap of that side (the segment from the face at the mouth level, or from the junction J, to
  the slot edge E, or to the wall point W level with a recessed junction);
- above the rotor circle, inside the stator: +1 for gas on side sigma within the lobe, -1 for anything not on side
  sigma (vane or the other side) beyond the lobe's valley ray on that side (u_k + 2 pi/z for L, u_k for T). The
  -1 part is only non-empty when the vane straddles a valley: with a valley gap c_S the tip protrudes above the
  rotor circle across the valley line, and that part of it counts against the chamber on that side;
- -1 for the vane's overlaps on side sigma: the part of the tip beyond the stator (a tip contact's penetration)
  and the part of the vane inside the rotor above that side's mouth gap (a slot contact pressing into the wall).

So V_sigma / L = pocket_sigma + (gas of sigma in the lobe above R_r) - (not-sigma beyond the valley above R_r)
- (overlaps of sigma).
Nothing here is imported from the project's packages. The sampling error of a count is about the cell area times
the square root of the number of cells the boundaries cross; `ChamberAreas.resolution` estimates it.
"""
import math
from typing import NamedTuple

import numpy as np

from reference_formulas import HarmonicPitch


class VaneShape(NamedTuple):
    """The bodies' dimensions from a parameter set (docs/model.md §2.1, §2.2; harmonic law only)."""
    thickness: float
    tip_radius: float
    tip_centre: float          # xi_T, vane frame with origin at the centre of mass
    bottom_face: float         # xi_B
    slot_width: float
    rotor_radius: float
    mouth_radius: float
    slot_bottom: float
    stator_clearance: float
    lobes: int
    pitch: HarmonicPitch


def vane_shape(params):
    """docs/model.md §2.1: xi_G = (A_r xi_r + A_s xi_s)/(A_r + A_s) with the rectangle below T and the half disc
    above it; xi_T = -xi_G."""
    if params.displacement_law != "harmonic":
        raise ValueError("the raster reference knows the harmonic stator only")
    t = params.vane_thickness
    rho = 0.5 * t
    rectangle = params.vane_length - rho
    area_rectangle, area_disc = t * rectangle, 0.5 * math.pi * rho ** 2
    centroid = (area_rectangle * (-0.5 * rectangle) + area_disc * 4.0 * rho / (3.0 * math.pi)) / (
        area_rectangle + area_disc)
    width = t + params.slot_clearance
    return VaneShape(t, rho, -centroid, -centroid - rectangle, width, params.rotor_radius,
                     math.sqrt(params.rotor_radius ** 2 - (0.5 * width) ** 2), params.slot_bottom_radius,
                     params.stator_clearance, params.lobes,
                     HarmonicPitch(params.rotor_radius - rho, params.stroke, params.lobes))


class Pose(NamedTuple):
    """Vane centre of mass (x, y) [m], vane angle phi and rotor angle theta [rad]."""
    x: float
    y: float
    phi: float
    theta: float


class ChamberAreas(NamedTuple):
    """Areas [m^2] of the leading and trailing chambers (the cross-section of V/L without the dead volume), their
    parts (slot pockets; above the rotor circle the gas within the lobe and what counts against the chamber beyond
    its valley line; the vane's overlaps with stator and rotor) and the estimated sampling error (one standard
    deviation) of one area."""
    leading: float
    trailing: float
    pocket_leading: float
    pocket_trailing: float
    gas_leading: float
    gas_trailing: float
    beyond_leading: float
    beyond_trailing: float
    overlap_leading: float
    overlap_trailing: float
    resolution: float


def _unit(angle):
    return np.array([math.cos(angle), math.sin(angle)])


def _outside_pitch_distance(px, py, pitch, iterations=8):
    """|X - C(u*)| for points outside the pitch curve, u* by Newton on f(u) = (X - C).C' from the polar angle."""
    u = np.arctan2(py, px)
    for _ in range(iterations):
        c, c1, c2 = pitch.point(u), pitch.derivative(u), pitch.second_derivative(u)
        dx, dy = px - c[0], py - c[1]
        f = dx * c1[0] + dy * c1[1]
        df = -(c1[0] ** 2 + c1[1] ** 2) + dx * c2[0] + dy * c2[1]
        u = u - np.clip(f / df, -0.05, 0.05)
    c = pitch.point(u)
    return np.hypot(px - c[0], py - c[1])


def _inside_stator(px, py, shape):
    radius = np.hypot(px, py)
    inside = radius <= shape.pitch.radius(np.arctan2(py, px))[0]
    near = ~inside & (radius <= shape.pitch.base_radius + shape.pitch.stroke + 2.0 * shape.tip_radius
                      + 2.0 * shape.stator_clearance)
    inside[near] = _outside_pitch_distance(px[near], py[near], shape.pitch) <= (shape.tip_radius
                                                                                 + shape.stator_clearance)
    return inside


class _Frames(NamedTuple):
    g: np.ndarray
    exi: np.ndarray
    eeta: np.ndarray
    tip: np.ndarray
    normal: np.ndarray         # stator normal n(u*) at the tip's closest point
    er: np.ndarray
    et: np.ndarray


def _frames(pose, shape):
    g = np.array([pose.x, pose.y])
    exi = _unit(pose.phi)
    tip = g + shape.tip_centre * exi
    closest = shape.pitch.closest(tip[0], tip[1])
    er = _unit(pose.theta)
    return _Frames(g, exi, np.array([-exi[1], exi[0]]), tip, shape.pitch.normal(closest), er,
                   np.array([-er[1], er[0]]))


def _side(px, py, f, shape):
    """+1 on the leading side of the vane and its tip gap, -1 on the trailing side (docs/model.md §1.2)."""
    dx, dy = px - f.g[0], py - f.g[1]
    xi = dx * f.exi[0] + dy * f.exi[1]
    eta = dx * f.eeta[0] + dy * f.eeta[1]
    tx, ty = px - f.tip[0], py - f.tip[1]
    across = f.normal[0] * ty - f.normal[1] * tx
    return np.where(xi <= shape.tip_centre, np.sign(eta), np.sign(across))


def _in_vane(px, py, f, shape):
    dx, dy = px - f.g[0], py - f.g[1]
    xi = dx * f.exi[0] + dy * f.exi[1]
    eta = dx * f.eeta[0] + dy * f.eeta[1]
    body = (xi >= shape.bottom_face) & (xi <= shape.tip_centre) & (np.abs(eta) <= 0.5 * shape.thickness)
    return body | (np.hypot(px - f.tip[0], py - f.tip[1]) <= shape.tip_radius)


def _mouth_gap(sigma, f, shape):
    """The slot-mouth gap of side sigma (docs/model.md §7.2 piece 4): from the face at the mouth level (if the tip
    centre is above it) or the junction J, to the slot edge E or, for a recessed junction (r_J < R_m), to the
    wall point W at the junction's radius."""
    edge = shape.mouth_radius * f.er + sigma * 0.5 * shape.slot_width * f.et
    level = np.dot(edge - f.g, f.exi)
    junction = f.tip + sigma * shape.tip_radius * f.eeta
    start = f.g + level * f.exi + sigma * 0.5 * shape.thickness * f.eeta if shape.tip_centre > level else junction
    junction_radius = np.dot(junction, f.er)
    end = (junction_radius * f.er + sigma * 0.5 * shape.slot_width * f.et if junction_radius < shape.mouth_radius
           else edge)
    return start, end


def _below_mouth_gap(px, py, sigma, f, shape):
    """Points below the line of side sigma's slot-mouth gap (the side of it towards the slot bottom). With the vane
    pressed into a slot wall the gap segment runs backwards; its line still separates the pocket from the slot."""
    start, end = _mouth_gap(sigma, f, shape)
    normal = np.array([start[1] - end[1], end[0] - start[0]])
    length = math.hypot(*normal)
    normal = f.er if length < 1e-15 else normal * math.copysign(1.0 / length, np.dot(normal, f.er))
    return (px - start[0]) * normal[0] + (py - start[1]) * normal[1] < 0.0


def _in_slot(px, py, f, shape):
    radial = px * f.er[0] + py * f.er[1]
    across = px * f.et[0] + py * f.et[1]
    return (np.abs(across) < 0.5 * shape.slot_width) & (radial > shape.slot_bottom)


def _terms(px, py, angle, f, shape, lobe_start):
    """The point sets of ChamberAreas at the points (px, py) of polar angle `angle` (in the window's branch), in
    the order leading, trailing of: slot pocket, gas above the rotor circle within the lobe, not-sigma above the
    rotor circle beyond the valley line, and the overlaps of the vane with the stator or the rotor."""
    lobe_end = lobe_start + 2.0 * math.pi / shape.lobes
    side = _side(px, py, f, shape)
    vane = _in_vane(px, py, f, shape)
    radius = np.hypot(px, py)
    inside_stator = _inside_stator(px, py, shape)
    above = (radius >= shape.rotor_radius) & inside_stator
    in_rotor = radius < shape.rotor_radius
    slot = in_rotor & _in_slot(px, py, f, shape)
    terms = []
    for sigma in (1.0, -1.0):
        above_gap = ~_below_mouth_gap(px, py, sigma, f, shape)
        terms.append(slot & ~vane & (side == sigma) & above_gap)
        terms.append(vane & (side == sigma) & (~inside_stator | (in_rotor & ~slot & above_gap)))
    return (terms[0], terms[2],
            above & ~vane & (side > 0) & (angle <= lobe_end), above & ~vane & (side < 0) & (angle >= lobe_start),
            above & (vane | (side < 0)) & (angle > lobe_end), above & (vane | (side > 0)) & (angle < lobe_start),
            terms[1], terms[3])


def chamber_areas(params, pose, lobe_start, angles, radii, cells=(1000, 1000), sides=(1, -1), seed=0,
                  chunk=500_000):
    """ChamberAreas of `pose` in the lobe [lobe_start, lobe_start + 2 pi/z], counting one jittered point per cell
    of the polar grid over `angles` = (a0, a1) [rad] x `radii` = (r0, r1) [m] with `cells` = (angle cells, r^2
    cells). The window must reach past the vane and the valley lines on each side (outside it every term
    vanishes: behind the vane and before the lobe, or ahead of it and past the lobe) and below the mouth gaps;
    a window that cuts a chamber is refused. `sides` (+1 leading, -1 trailing) chooses the chambers to count (a
    window around the end valley holds the leading chamber of the lobe that ends there and the trailing chamber of
    the next one, not the others); the other one's terms are NaN. The resolution bounds the count's standard
    deviation: a quarter cell area of variance for each cell a boundary crosses (cells whose neighbour, along
    either grid direction, is classified differently)."""
    shape = vane_shape(params)
    f = _frames(pose, shape)
    n_angle, n_square = cells
    square0, square1 = radii[0] ** 2, radii[1] ** 2
    cell_area = 0.5 * (square1 - square0) * (angles[1] - angles[0]) / (n_angle * n_square)
    wanted = np.array([sigma in sides for sigma in (1, -1)] * 4)
    _check_window(angles, radii, f, shape, lobe_start, wanted)
    rng = np.random.default_rng(seed)
    totals = np.zeros(8)
    crossed = 0
    columns = max(1, chunk // n_square)
    for first in range(0, n_angle, columns):
        column = np.arange(first, min(first + columns, n_angle))
        a = angles[0] + (angles[1] - angles[0]) * (column[:, None] + rng.random((column.size, n_square))) / n_angle
        r = np.sqrt(square0 + (square1 - square0) * (np.arange(n_square) + rng.random((column.size, n_square)))
                    / n_square)
        parts = [part for part, keep in zip(_terms(r * np.cos(a), r * np.sin(a), a, f, shape, lobe_start), wanted)
                 if keep]
        totals[wanted] += [np.count_nonzero(part) for part in parts]
        changed = np.zeros((column.size, n_square), dtype=bool)
        for part in parts:
            changed[:, 1:] |= part[:, 1:] != part[:, :-1]
            changed[1:, :] |= part[1:, :] != part[:-1, :]
        crossed += int(np.count_nonzero(changed))
    totals[~wanted] = math.nan
    pocket_l, pocket_t, gas_l, gas_t, beyond_l, beyond_t, overlap_l, overlap_t = totals * cell_area
    return ChamberAreas(pocket_l + gas_l - beyond_l - overlap_l, pocket_t + gas_t - beyond_t - overlap_t, pocket_l,
                        pocket_t, gas_l, gas_t, beyond_l, beyond_t, overlap_l, overlap_t,
                        0.5 * cell_area * math.sqrt(max(crossed, 1)))


def _check_window(angles, radii, f, shape, lobe_start, wanted, samples=4001):
    """Refuse a window whose edges hold a point of some chamber term (the window would cut a chamber)."""
    a = np.linspace(angles[0], angles[1], samples)
    r = np.linspace(radii[0], radii[1], samples)
    px = np.concatenate([radii[0] * np.cos(a), radii[1] * np.cos(a), r * math.cos(angles[0]), r * math.cos(angles[1])])
    py = np.concatenate([radii[0] * np.sin(a), radii[1] * np.sin(a), r * math.sin(angles[0]), r * math.sin(angles[1])])
    angle = np.concatenate([a, a, np.full(samples, angles[0]), np.full(samples, angles[1])])
    parts = _terms(px, py, angle, f, shape, lobe_start)
    if any(np.any(part) for part, keep in zip(parts, wanted) if keep):
        raise ValueError(f"the raster window {angles} rad x {radii} m cuts a chamber: widen it")
