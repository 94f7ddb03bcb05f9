"""Pitch curve, stator envelope and the closest point of the stator to the tip centre (docs/model.md §2.4–§2.6).

The tip centre nominally runs on the pitch curve C(u) = r(u) e_r(u), r = R0 + s(u). The stator is the outer
envelope of the tip circle, the parallel curve S(u) = C(u) + d n(u) with d = rho + c_S.
"""
import math

import numpy as np

from ...kernels.kernel import kernel

from .displacement import DISPLACEMENT_LAWS, displacement, displacement_given_trig

TWO_PI = 2.0 * math.pi


@kernel
def pitch_curve(u, law, stroke, lobes, bottom_dwell, top_dwell, base_radius):
    """C(u), C'(u), C''(u) as six floats (docs/model.md §2.4).

    C = r e_r,  C' = r' e_r + r e_theta,  C'' = (r'' - r) e_r + 2 r' e_theta,  r = R0 + s(u).
    """
    s, s1, s2, _ = displacement(u, law, stroke, lobes, bottom_dwell, top_dwell)
    r = base_radius + s
    c = math.cos(u)
    si = math.sin(u)
    d1r = s1 * c - r * si
    d1t = s1 * si + r * c
    ar = s2 - r
    at = 2.0 * s1
    return (r * c, r * si, d1r, d1t, ar * c - at * si, ar * si + at * c)


@kernel
def pitch_frame(u, law, stroke, lobes, bottom_dwell, top_dwell, base_radius):
    """Point C, unit outward normal n, speed N = |C'| and signed curvature kappa_C at u (docs/model.md §2.4).

    n = (r e_r - r' e_theta)/N,  kappa_C = (r^2 + 2 r'^2 - r r'')/(r^2 + r'^2)^(3/2)  (> 0: centre towards O).
    """
    s, s1, s2, _ = displacement(u, law, stroke, lobes, bottom_dwell, top_dwell)
    r = base_radius + s
    c = math.cos(u)
    si = math.sin(u)
    speed = math.sqrt(r * r + s1 * s1)
    nr = r / speed
    nt = -s1 / speed
    curvature = (r * r + 2.0 * s1 * s1 - r * s2) / speed ** 3
    return r * c, r * si, nr * c - nt * si, nr * si + nt * c, speed, curvature


@kernel
def stator_point(u, law, stroke, lobes, bottom_dwell, top_dwell, base_radius, offset):
    """S(u) = C + d n, its derivative S' = N (1 + d kappa_C) tau and curvature kappa_S (docs/model.md §2.5)."""
    cx, cy, nx, ny, speed, curvature = pitch_frame(u, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)
    stretch = speed * (1.0 + offset * curvature)
    # tangent tau = n rotated +90 degrees
    return (cx + offset * nx, cy + offset * ny, -ny * stretch, nx * stretch,
            curvature / (1.0 + offset * curvature))


@kernel
def _closest_point_residual(u, tx, ty, law, stroke, lobes, bottom_dwell, top_dwell, base_radius):
    """f(u) = (T - C(u)).C'(u) and f'(u) = -|C'|^2 + (T - C).C'' (docs/model.md §2.6)."""
    cx, cy, d1x, d1y, d2x, d2y = pitch_curve(u, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)
    gx = tx - cx
    gy = ty - cy
    return gx * d1x + gy * d1y, -(d1x * d1x + d1y * d1y) + gx * d2x + gy * d2y


@kernel
def _brent_root(a, b, tx, ty, law, stroke, lobes, bottom_dwell, top_dwell, base_radius):
    """Brent-Dekker root of f on a sign-changing bracket [a, b] (safeguard of docs/model.md §2.6)."""
    fa = _closest_point_residual(a, tx, ty, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)[0]
    fb = _closest_point_residual(b, tx, ty, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)[0]
    if fa * fb > 0.0:
        return math.nan
    c, fc, d = a, fa, b - a
    e = d
    for _ in range(200):
        if fb * fc > 0.0:
            c, fc, d = a, fa, b - a
            e = d
        if abs(fc) < abs(fb):
            a, b, c = b, c, b
            fa, fb, fc = fb, fc, fb
        tol = 2e-16 * abs(b) + 1e-14
        m = 0.5 * (c - b)
        if abs(m) <= tol or fb == 0.0:
            return b
        if abs(e) >= tol and abs(fa) > abs(fb):
            s = fb / fa
            if a == c:
                p = 2.0 * m * s
                q = 1.0 - s
            else:
                q = fa / fc
                r = fb / fc
                p = s * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0))
                q = (q - 1.0) * (r - 1.0) * (s - 1.0)
            if p > 0.0:
                q = -q
            else:
                p = -p
            if 2.0 * p < min(3.0 * m * q - abs(tol * q), abs(e * q)):
                e = d
                d = p / q
            else:
                d = m
                e = m
        else:
            d = m
            e = m
        a, fa = b, fb
        b += d if abs(d) > tol else (tol if m > 0.0 else -tol)
        fb = _closest_point_residual(b, tx, ty, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)[0]
    return b


@kernel
def _newton_closest(tx, ty, u_start, law, stroke, lobes, bottom_dwell, top_dwell, base_radius):
    """Newton on f(u) = (T - C).C' = 0 from u_start, steps limited to 0.05 rad, stop at |du| < 1e-13 (docs/model.md §2.6).

    Returns (converged, u, iterations, r, s', s'', cos u, sin u) with the values of the last iterate; not converged
    if f' >= 0, after 20 iterations, or on a root more than pi/(2z) from u_start (another root of f, reachable
    from a far start).
    """
    u = u_start
    r = s1 = s2 = c = si = 0.0
    for iteration in range(1, 21):
        c = math.cos(u)
        si = math.sin(u)
        s, s1, s2, _ = displacement_given_trig(u, c, si, law, stroke, lobes, bottom_dwell, top_dwell)
        r = base_radius + s
        d1x = s1 * c - r * si
        d1y = s1 * si + r * c
        ar = s2 - r
        at = 2.0 * s1
        gx = tx - r * c
        gy = ty - r * si
        f = gx * d1x + gy * d1y
        df = -(d1x * d1x + d1y * d1y) + gx * (ar * c - at * si) + gy * (ar * si + at * c)
        if df >= 0.0:
            break
        du = -f / df
        if du > 0.05:
            du = 0.05
        elif du < -0.05:
            du = -0.05
        if abs(du) < 1e-13:
            return abs(u - u_start) <= 0.5 * math.pi / lobes, u, iteration, r, s1, s2, c, si
        u += du
    return False, u, 20, r, s1, s2, c, si


@kernel
def closest_pitch_parameter(tx, ty, u_start, law, stroke, lobes, bottom_dwell, top_dwell, base_radius):
    """Parameter u* of the point of C closest to T, and the Newton iterations used (docs/model.md §2.6).

    Newton from u_start (the previous u*, or atan2(T)); if it does not converge (see `_newton_closest`): Brent on
    [u0 - pi/(2z), u0 + pi/(2z)] around u0 = atan2(T) unwrapped next to u_start, and iterations = -1.
    Offset curves share normals, so u* is also the closest point of the stator S.
    """
    polar = math.atan2(ty, tx)
    polar += TWO_PI * round((u_start - polar) / TWO_PI)
    converged, u, iterations, _, _, _, _, _ = _newton_closest(tx, ty, u_start, law, stroke, lobes, bottom_dwell,
                                                              top_dwell, base_radius)
    if converged and abs(u - polar) <= 0.5 * math.pi / lobes:
        return u, iterations
    half_width = 0.5 * math.pi / lobes
    u = _brent_root(polar - half_width, polar + half_width, tx, ty, law, stroke, lobes, bottom_dwell, top_dwell,
                    base_radius)
    return u, -1


@kernel
def closest_pitch_frame(tx, ty, u_start, law, stroke, lobes, bottom_dwell, top_dwell, base_radius):
    """u* and the pitch frame there: (u*, C_x, C_y, n_x, n_y, N = |C'|, kappa_C), for the time loop
    (docs/model.md §2.6).

    The frame is built from the values of the last Newton iterate, so no extra trigonometric evaluation is needed.
    """
    converged, u, _, r, s1, s2, c, si = _newton_closest(tx, ty, u_start, law, stroke, lobes, bottom_dwell,
                                                        top_dwell, base_radius)
    if not converged:
        u, _ = closest_pitch_parameter(tx, ty, u_start, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)
        cx, cy, nx, ny, speed, curvature = pitch_frame(u, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)
        return u, cx, cy, nx, ny, speed, curvature
    speed = math.sqrt(r * r + s1 * s1)
    nr = r / speed
    nt = -s1 / speed
    return (u, r * c, r * si, nr * c - nt * si, nr * si + nt * c, speed,
            (r * r + 2.0 * s1 * s1 - r * s2) / speed ** 3)


# ---------------------------------------------------------------------------------------------------------
# Whole-curve properties (set-up, validation and tests; not in the time loop)

def law_arguments(params):
    """The displacement-law arguments (law code, h, z, beta0, beta1, R0) of a parameter set."""
    return (DISPLACEMENT_LAWS.code(params.displacement_law, "displacement_law"), params.stroke, float(params.lobes),
            params.bottom_dwell, params.top_dwell, params.base_radius)


def lobe_profile(params, samples: int = 2001) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """s, ds/dtheta and d2s/dtheta2 at `samples` angles over one lobe, both ends included (docs/model.md §2.3)."""
    law, stroke, lobes, bottom_dwell, top_dwell, _ = law_arguments(params)
    angles = np.linspace(0.0, 2.0 * math.pi / lobes, samples)
    values = np.array([displacement(a, law, stroke, lobes, bottom_dwell, top_dwell)[:3] for a in angles])
    return values[:, 0], values[:, 1], values[:, 2]


@kernel(allocates=True)
def _regularity_on_grid(samples, law, stroke, lobes, bottom_dwell, top_dwell, base_radius, offset):
    lowest = np.inf
    where = 0.0
    for i in range(samples):
        u = TWO_PI / lobes * i / samples
        curvature = pitch_frame(u, law, stroke, lobes, bottom_dwell, top_dwell, base_radius)[5]
        value = 1.0 + offset * curvature
        if value < lowest:
            lowest = value
            where = u
    return lowest, where


def stator_regularity(params, samples=20000):
    """min over a lobe of 1 + d kappa_C(u) and where it occurs (docs/model.md §2.5); must be > 0."""
    return _regularity_on_grid(samples, *law_arguments(params), params.envelope_offset)


def check_stator_regularity(params) -> None:
    """Raise ValueError if the stator envelope has a cusp: 1 + d kappa_C <= 0 somewhere (docs/model.md §2.5)."""
    lowest, where = stator_regularity(params)
    if not lowest > 0.0:
        raise ValueError(
            f"parameter 'stroke' = {params.stroke!r} with lobes = {params.lobes}, vane_thickness = "
            f"{params.vane_thickness!r}, stator_clearance = {params.stator_clearance!r} gives a stator profile with "
            f"a cusp: 1 + d*kappa_C = {lowest:.4g} at u = {where:.4g} rad; allowed: 1 + d*kappa_C > 0 everywhere "
            f"(reduce stroke or lobes, or the vane thickness)")


@kernel
def _lobe_integral(nodes, weights, law, stroke, lobes, bottom_dwell, top_dwell, base_radius, offset, rotor_radius):
    total = 0.0
    for i in range(nodes.size):
        sx, sy, dsx, dsy, _ = stator_point(nodes[i], law, stroke, lobes, bottom_dwell, top_dwell, base_radius,
                                           offset)
        total += weights[i] * (sx * dsy - sy * dsx)
    return 0.5 * total - 0.5 * rotor_radius ** 2 * TWO_PI / lobes


def _composite_gauss_legendre(edges, order=16):
    """(nodes, weights) of an order-point Gauss-Legendre rule on every interval between consecutive edges."""
    x, w = np.polynomial.legendre.leggauss(order)
    half = 0.5 * np.diff(edges)
    return ((edges[:-1, None] + half[:, None] * (x[None, :] + 1.0)).ravel(), (half[:, None] * w[None, :]).ravel())


def lobe_area(params, panels=64, order=16):
    """Area between stator and rotor over one lobe (docs/model.md §2.5), composite Gauss-Legendre:

    A_lobe = 1/2 int_{u_j}^{u_j+1} (S_x S'_y - S_y S'_x) du - 1/2 R_r^2 (2 pi / z)
    """
    nodes, weights = _composite_gauss_legendre(np.linspace(0.0, TWO_PI / params.lobes, panels + 1), order)
    return _lobe_integral(nodes, weights, *law_arguments(params), params.envelope_offset, params.rotor_radius)


@kernel
def _seal_integral(nodes, weights, gap, law, stroke, lobes, bottom_dwell, top_dwell, base_radius, offset,
                   rotor_radius):
    total = 0.0
    for i in range(nodes.size):
        sx, sy, dsx, dsy, _ = stator_point(nodes[i], law, stroke, lobes, bottom_dwell, top_dwell, base_radius,
                                           offset)
        total += weights[i] * (gap / (math.sqrt(sx * sx + sy * sy) - rotor_radius)) ** 3 * math.sqrt(
            dsx * dsx + dsy * dsy)
    return total


SEAL_FLANK_START = 1e-8             # rad: the flank's first interval (the seal of c_S = 1 nm spans 3e-4 rad)
SEAL_FLANK_INTERVALS = 64           # geometrically graded from SEAL_FLANK_START to the mid-lobe


def valley_seal_length(params) -> float:
    """Friction-equivalent flow length [m] of the seal between the rotor and the stator at a valley
    (docs/model.md §7.4):

        L_eq = delta^3 int ds / g(u)^3,   g(u) = |S(u)| - R_r,   ds = |S'(u)| du,   delta = g(valley) = c_S

    over the lobe on both sides of the valley (the laws are even about it), with the stator of §2.5: a bottom dwell
    is a concentric stretch (g = c_S: L_flat = (R_r + c_S) beta0), a harmonic flank the parabolic gap of the
    curvatures at the valley ((3 pi/16) sqrt(2 R c_S) each, thermo.leakage), and the cycloidal and 3-4-5 laws,
    whose curvature at the valley is the rotor's, a gap growing with the cube of the angle. Composite
    Gauss-Legendre on the dwell and on intervals graded geometrically away from it, which resolve the seal at any
    clearance (no scipy: this runs at every start). 0 at c_S = 0 (closed)."""
    gap = params.stator_clearance
    if gap == 0.0:
        return 0.0
    dwell_end = 0.5 * params.bottom_dwell if params.displacement_law == "harmonic_dwell" else 0.0
    flank = dwell_end + np.concatenate(([0.0], np.geomspace(SEAL_FLANK_START, math.pi / params.lobes - dwell_end,
                                                            SEAL_FLANK_INTERVALS)))
    edges = np.concatenate(([0.0], flank)) if dwell_end > 0.0 else flank
    nodes, weights = _composite_gauss_legendre(edges)
    return 2.0 * _seal_integral(nodes, weights, gap, *law_arguments(params), params.envelope_offset,
                                params.rotor_radius)
