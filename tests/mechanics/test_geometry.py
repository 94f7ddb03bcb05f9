"""Geometry checks: displacement laws (docs/model.md §2.3), pitch curve and stator envelope (docs/model.md §11 T1), closest point
(T1b) and vane mass properties (T2).

Expected values come from the closed forms and tables of docs/model.md or from independent numerics written here
(finite differences, complex-step derivatives, brute-force search, scipy quadrature/minimisation).
"""
import math

import numpy as np
import pytest
from scipy import integrate
from scipy.optimize import brentq, minimize_scalar

from rotary_vane.mechanics import CompressorParameters
from rotary_vane.mechanics.geometry import stator
from rotary_vane.mechanics.geometry.displacement import DISPLACEMENT_LAWS, displacement
from rotary_vane.mechanics.geometry.stator import (closest_pitch_parameter, law_arguments, lobe_area, pitch_curve,
                                                   pitch_frame, stator_point, stator_regularity)
from rotary_vane.mechanics.loop.machine import machine_from_parameters, vane_mass_properties

H = 5.0e-3            # docs/model.md §9 stroke
R_ROTOR = 30.0e-3
RHO = 2.0e-3
R0 = R_ROTOR - RHO
TWO_PI = 2.0 * math.pi

# law name -> extra parameters used in these tests (dwells only matter for harmonic_dwell)
LAW_CASES = {
    "harmonic": dict(),
    "cycloidal": dict(),
    "harmonic_dwell": dict(bottom_dwell=0.2, top_dwell=0.3),
    "polynomial_345": dict(),
}


def law_call(name, lobes, theta, stroke=H, bottom_dwell=0.0, top_dwell=0.0):
    law = DISPLACEMENT_LAWS.code(name, "displacement_law")
    return np.array(displacement(theta, law, stroke, float(lobes), bottom_dwell, top_dwell))


def law_breakpoints(name, lobes, bottom_dwell=0.0, top_dwell=0.0):
    """Angles in one lobe [0, 2 pi/z] where a derivative of the law may jump."""
    lobe = TWO_PI / lobes
    if name == "harmonic":
        return np.array([])
    if name == "harmonic_dwell":
        rise = 0.5 * (lobe - bottom_dwell - top_dwell)
        b = 0.5 * bottom_dwell
        return np.array([0.0, b, b + rise, b + rise + top_dwell, b + 2 * rise + top_dwell, lobe])
    return np.array([0.0, 0.5 * lobe, lobe])


# ----------------------------------------------------------------------------------------------------------
# docs/model.md §2.3: the four displacement laws


def reference_law(name, lobes, theta, stroke=H, bottom_dwell=0.0, top_dwell=0.0):
    """Closed forms of docs/model.md §2.3 (and the standard 3-4-5 / dwell cam laws), written independently."""
    z, h = lobes, stroke
    if name == "harmonic":
        return np.array([h / 2 * (1 - math.cos(z * theta)), h / 2 * z * math.sin(z * theta),
                         h / 2 * z * z * math.cos(z * theta), -h / 2 * z ** 3 * math.sin(z * theta)])
    if name in ("cycloidal", "polynomial_345"):
        zeta = (z * theta) % TWO_PI
        rising = zeta <= math.pi
        x = zeta / math.pi if rising else (TWO_PI - zeta) / math.pi
        sign = 1.0 if rising else -1.0
        k = z / math.pi                                  # |dx/dtheta|
        if name == "cycloidal":
            f = [x - math.sin(2 * math.pi * x) / (2 * math.pi), 1 - math.cos(2 * math.pi * x),
                 2 * math.pi * math.sin(2 * math.pi * x), 4 * math.pi ** 2 * math.cos(2 * math.pi * x)]
        else:
            f = [10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5, 30 * x ** 2 - 60 * x ** 3 + 30 * x ** 4,
                 60 * x - 180 * x ** 2 + 120 * x ** 3, 60 - 360 * x + 360 * x ** 2]
        return np.array([h * f[0], sign * h * k * f[1], h * k * k * f[2], sign * h * k ** 3 * f[3]])
    # harmonic with dwells: bottom dwell centred on the valley, rise, top dwell, return
    lobe = TWO_PI / z
    phase = theta % lobe
    rise = 0.5 * (lobe - bottom_dwell - top_dwell)
    w = math.pi / rise
    b0 = 0.5 * bottom_dwell
    if phase < b0 or phase >= lobe - b0:
        return np.zeros(4)
    if phase < b0 + rise:
        a, sign = w * (phase - b0), 1.0
    elif phase < b0 + rise + top_dwell:
        return np.array([h, 0.0, 0.0, 0.0])
    else:
        a, sign = w * (lobe - b0 - phase), -1.0
    return np.array([h / 2 * (1 - math.cos(a)), sign * h / 2 * w * math.sin(a), h / 2 * w * w * math.cos(a),
                     -sign * h / 2 * w ** 3 * math.sin(a)])


def derivative_scales(lobes):
    """Natural magnitudes h z^k of s^(k), used to make the tolerances relative."""
    return H * np.array([1.0, lobes, lobes ** 2, lobes ** 3])


def away_from_breakpoints(name, lobes, theta, margin, **dwells):
    points = law_breakpoints(name, lobes, **dwells)
    if points.size == 0:
        return True
    phase = theta % (TWO_PI / lobes)
    return np.min(np.abs(phase - points)) > margin


@pytest.mark.parametrize("name", list(LAW_CASES))
@pytest.mark.parametrize("lobes", [3, 5])
def test_displacement_matches_closed_form(check, name, lobes):
    dwells = LAW_CASES[name]
    rng = np.random.default_rng(11)
    scale = derivative_scales(lobes)
    worst = 0.0
    for theta in rng.uniform(-2 * TWO_PI, 2 * TWO_PI, 400):
        if not away_from_breakpoints(name, lobes, theta, 1e-9, **dwells):
            continue
        got = law_call(name, lobes, theta, **dwells)
        expected = reference_law(name, lobes, theta, **dwells)
        worst = max(worst, np.max(np.abs(got - expected) / scale))
    check("law: s^(k) vs closed form / (h z^k)", worst, 1e-12)


@pytest.mark.parametrize("name", list(LAW_CASES))
@pytest.mark.parametrize("lobes", [3, 5])
def test_displacement_periodic_zero_at_valleys_stroke_at_mid_lobe(check, name, lobes):
    dwells = LAW_CASES[name]
    scale = derivative_scales(lobes)
    lobe = TWO_PI / lobes
    rng = np.random.default_rng(5)
    for theta in rng.uniform(-TWO_PI, TWO_PI, 100):
        if not away_from_breakpoints(name, lobes, theta, 1e-8, **dwells):
            continue
        for shift in (lobe, -lobe, 2 * lobe, TWO_PI):
            diff = law_call(name, lobes, theta + shift, **dwells) - law_call(name, lobes, theta, **dwells)
            check("law: periodicity / (h z^k)", np.max(np.abs(diff) / scale), 1e-9)
    for j in range(-lobes, 2 * lobes + 1):
        s, s1 = law_call(name, lobes, j * lobe, **dwells)[:2]
        check("law: |s|, |s'| at valleys / (h z^k)", max(abs(s) / H, abs(s1) / (H * lobes)), 1e-12)
        s, s1 = law_call(name, lobes, (j + 0.5) * lobe, **dwells)[:2]
        check("law: |s - h| at mid-lobe / h", abs(s - H) / H, 1e-12)
        check("law: |s'| at mid-lobe / (h z)", abs(s1) / (H * lobes), 1e-9)
    # the stroke is the maximum of s and s >= 0 everywhere
    values = np.array([law_call(name, lobes, th, **dwells)[0] for th in np.linspace(0, lobe, 2001)])
    assert values.min() >= -1e-15 and values.max() <= H * (1 + 1e-12)


@pytest.mark.parametrize("name", list(LAW_CASES))
@pytest.mark.parametrize("lobes", [3, 7])
def test_displacement_derivatives_against_finite_differences(check, name, lobes):
    """s', s'', s''' against 5-point central differences of s, s', s'' (step 1e-4 rad, away from the
    breakpoints)."""
    dwells = LAW_CASES[name]
    scale = derivative_scales(lobes)
    step = 1e-4
    rng = np.random.default_rng(2)
    worst = 0.0
    checked = 0
    for theta in rng.uniform(0, TWO_PI, 300):
        if not away_from_breakpoints(name, lobes, theta, 1e-3, **dwells):
            continue
        v = [law_call(name, lobes, theta + k * step, **dwells)[:3] for k in (-2, -1, 1, 2)]
        exact = law_call(name, lobes, theta, **dwells)
        numeric = (v[0] - 8 * v[1] + 8 * v[2] - v[3]) / (12 * step)
        worst = max(worst, np.max(np.abs(numeric - exact[1:]) / scale[1:]))
        checked += 1
    assert checked > 200
    check("law: s', s'', s''' vs 5-point FD / (h z^k)", worst, 1e-8)


@pytest.mark.parametrize("name", list(LAW_CASES))
def test_displacement_continuity_at_breakpoints(check, name):
    """s and s' are continuous for every law; s'' too, except for harmonic_dwell, which is only C1 by design:
    its s'' jumps by (h/2)(pi/beta_r)^2 at each end of a rise or return (docs/model.md §2.3 option 3)."""
    lobes = 3
    dwells = LAW_CASES[name]
    scale = derivative_scales(lobes)
    eps = 1e-10
    points = law_breakpoints(name, lobes, **dwells)
    if name == "harmonic_dwell":
        points = points[1:-1]          # the valley itself is inside the bottom dwell
    for point in points:
        left = law_call(name, lobes, point - eps, **dwells)
        right = law_call(name, lobes, point + eps, **dwells)
        jump = np.abs(right - left) / scale
        check("law: jump of s, s' at breakpoints / (h z^k)", max(jump[0], jump[1]), 1e-8)
        if name == "harmonic_dwell":
            beta_r = 0.5 * (TWO_PI / lobes - dwells["bottom_dwell"] - dwells["top_dwell"])
            expected_jump = 0.5 * H * (math.pi / beta_r) ** 2
            check("law: harmonic_dwell s'' jump vs (h/2)(pi/beta_r)^2, rel.",
                  abs(abs(right[2] - left[2]) - expected_jump) / expected_jump, 1e-6)
        else:
            check("law: jump of s'' at breakpoints (C2 laws) / (h z^2)", jump[2], 1e-6)
    # the 3-4-5 and cycloidal laws have zero acceleration at the valleys and the stroke top
    if name in ("cycloidal", "polynomial_345"):
        for point in law_breakpoints(name, lobes):
            assert abs(law_call(name, lobes, point)[2]) < 1e-9 * scale[2]


def test_cycloidal_peak_acceleration_ratio(check):
    """docs/model.md §2.3: the cycloidal peak acceleration is 4/pi = 1.27 times the harmonic one."""
    theta = np.linspace(0, TWO_PI / 3, 20001)
    harmonic = max(abs(law_call("harmonic", 3, t)[2]) for t in theta)
    cycloidal = max(abs(law_call("cycloidal", 3, t)[2]) for t in theta)
    check("law: cycloidal/harmonic peak s'' - 4/pi", abs(cycloidal / harmonic - 4 / math.pi), 1e-6)
    assert round(cycloidal / harmonic, 2) == 1.27


# ----------------------------------------------------------------------------------------------------------
# T1: pitch curve and stator envelope (docs/model.md §2.4, §2.5)


def params_for(name="harmonic", lobes=3, stator_clearance=0.0, **extra):
    return CompressorParameters(displacement_law=name, lobes=lobes, stator_clearance=stator_clearance,
                                **LAW_CASES[name], **extra)


def sample_parameters(name, lobes, count=97, margin=2e-3):
    u = np.linspace(0.0, TWO_PI, count, endpoint=False) + 0.0123
    keep = [x for x in u if away_from_breakpoints(name, lobes, x, margin, **LAW_CASES[name])]
    return np.array(keep)


CURVE_CASES = [("harmonic", z) for z in (3, 5, 7, 9)] + [(n, 3) for n in ("cycloidal", "harmonic_dwell",
                                                                            "polynomial_345")]


@pytest.mark.parametrize("name,lobes", CURVE_CASES)
def test_pitch_frame_normal_is_unit_and_orthogonal(check, name, lobes):
    p = params_for(name, lobes)
    args = law_arguments(p)
    worst_unit = worst_orth = worst_fd = 0.0
    step = 1e-4
    for u in sample_parameters(name, lobes):
        cx, cy, d1x, d1y, d2x, d2y = pitch_curve(u, *args)
        fx, fy, nx, ny, speed, kappa = pitch_frame(u, *args)
        assert (fx, fy) == pytest.approx((cx, cy), rel=0, abs=1e-15)
        worst_unit = max(worst_unit, abs(math.hypot(nx, ny) - 1.0))
        worst_orth = max(worst_orth, abs(nx * d1x + ny * d1y) / math.hypot(d1x, d1y))
        assert abs(speed - math.hypot(d1x, d1y)) < 1e-14
        # outward: n.C > 0; C' and C'' against central differences of C and C'
        assert nx * cx + ny * cy > 0
        v = [np.array(pitch_curve(u + k * step, *args)) for k in (-2, -1, 1, 2)]
        numeric = (v[0] - 8 * v[1] + 8 * v[2] - v[3]) / (12 * step)        # 5-point central differences
        worst_fd = max(worst_fd, np.max(np.abs(numeric[:4] - np.array([d1x, d1y, d2x, d2y]))) / R0)
        # curvature against the parametric formula with numeric derivatives
        kappa_fd = (numeric[0] * numeric[3] - numeric[1] * numeric[2]) / math.hypot(numeric[0], numeric[1]) ** 3
        check("T1 kappa_C vs FD curvature of C, rel. (floor 1/R0)",
              abs(kappa - kappa_fd) / max(abs(kappa), 1 / R0), 1e-6)
    check("T1 | |n| - 1 |", worst_unit, 1e-12)
    check("T1 |n.C'|/|C'|", worst_orth, 1e-12)
    check("T1 C', C'' vs 5-point FD / R0", worst_fd, 1e-8)


@pytest.mark.parametrize("name,lobes", CURVE_CASES)
@pytest.mark.parametrize("clearance", [0.0, 0.1e-3])
def test_stator_is_offset_curve(check, name, lobes, clearance):
    """|S - C| = d, S'.n = 0 (1e-10), S' against complex-step/central differences, kappa_S against finite
    differences of S (1e-5 relative, floor 1/R_r where kappa_S crosses zero)."""
    p = params_for(name, lobes, clearance)
    args = law_arguments(p)
    d = RHO + clearance
    assert p.envelope_offset == d
    step = 1e-4
    worst = dict(offset=0.0, orth=0.0, deriv=0.0, kappa=0.0)
    for u in sample_parameters(name, lobes):
        cx, cy, nx, ny, _, _ = pitch_frame(u, *args)
        sx, sy, dsx, dsy, kappa_s = stator_point(u, *args, d)
        worst["offset"] = max(worst["offset"], abs(math.hypot(sx - cx, sy - cy) - d) / d)
        worst["orth"] = max(worst["orth"], abs(dsx * nx + dsy * ny) / math.hypot(dsx, dsy))
        # 5-point stencils on S positions only
        pts = np.array([stator_point(u + k * step, *args, d)[:2] for k in (-2, -1, 0, 1, 2)])
        first = (pts[0] - 8 * pts[1] + 8 * pts[3] - pts[4]) / (12 * step)
        second = (-pts[0] + 16 * pts[1] - 30 * pts[2] + 16 * pts[3] - pts[4]) / (12 * step ** 2)
        worst["deriv"] = max(worst["deriv"], np.max(np.abs(first - (dsx, dsy))) / math.hypot(dsx, dsy))
        kappa_fd = (first[0] * second[1] - first[1] * second[0]) / math.hypot(*first) ** 3
        worst["kappa"] = max(worst["kappa"], abs(kappa_s - kappa_fd) / max(abs(kappa_fd), 1 / R_ROTOR))
    check("T1 | |S - C| - d | / d", worst["offset"], 1e-10)
    check("T1 |S'.n|/|S'|", worst["orth"], 1e-10)
    check("T1 S' vs 5-point FD of S, rel.", worst["deriv"], 1e-7)
    check("T1 kappa_S vs FD of S, rel. (floor 1/R_r)", worst["kappa"], 1e-5)


@pytest.mark.parametrize("clearance", [0.0, 0.1e-3])
@pytest.mark.parametrize("lobes", [3, 9])
def test_stator_against_independent_closed_form(check, reference, lobes, clearance):
    """S(u) and S'(u) equal the independent harmonic reference (S' by complex-step differentiation)."""
    p = params_for("harmonic", lobes, clearance)
    ref = reference.HarmonicPitch(R0, H, lobes)
    d = RHO + clearance
    u = np.linspace(0, TWO_PI, 301)
    expected = ref.stator(u, d)
    expected_derivative = ref.stator_derivative(u, d)
    got = np.array([stator_point(x, *law_arguments(p), d)[:4] for x in u]).T
    check("T1 S vs independent closed form [m]", np.max(np.abs(got[:2] - expected)), 1e-15)
    check("T1 S' vs complex-step derivative / R0", np.max(np.abs(got[2:] - expected_derivative)) / R0, 1e-13)
    kappa_c = ref.curvature(u)
    got_kappa = np.array([stator_point(x, *law_arguments(p), d)[4] for x in u])
    check("T1 kappa_S vs kappa_C/(1 + d kappa_C) (reference), rel. to max",
          np.max(np.abs(got_kappa - kappa_c / (1 + d * kappa_c))) / np.max(np.abs(kappa_c)), 1e-12)


# docs/model.md §2.5 table: z -> (min(1 + d kappa_C), smallest convex pitch radius [mm], max beta [deg], A_lobe [mm2])
MODEL_DOC_T1_TABLE = {3: (1.014, 19.62, 13.9, 168.81), 5: (0.912, 11.40, 22.4, 103.27),
              7: (0.759, 7.00, 29.9, 75.79), 9: (0.555, 4.62, 36.5, 60.95)}


@pytest.mark.parametrize("lobes", sorted(MODEL_DOC_T1_TABLE))
def test_regularity_matches_table(check, reference, lobes):
    expected = MODEL_DOC_T1_TABLE[lobes][0]
    p = params_for("harmonic", lobes)
    code_min, _ = stator_regularity(p)
    # independent: closed-form curvature on a dense grid, refined with a bounded scalar minimiser
    ref = reference.HarmonicPitch(R0, H, lobes)
    u = np.linspace(0, TWO_PI / lobes, 20001)
    values = 1 + RHO * ref.curvature(u)
    i = int(np.argmin(values))
    lo, hi = u[max(i - 1, 0)] - 1e-3, u[min(i + 1, u.size - 1)] + 1e-3
    refined = minimize_scalar(lambda x: 1 + RHO * ref.curvature(x), bounds=(lo, hi), method="bounded",
                              options=dict(xatol=1e-12)).fun
    independent = min(refined, values.min())
    check("T1 min(1 + d kappa_C): independent vs docs/model.md T1 table", abs(independent - expected), 0.002)
    check("T1 min(1 + d kappa_C): stator_regularity vs docs/model.md T1 table", abs(code_min - expected), 0.002)
    check("T1 min(1 + d kappa_C): stator_regularity vs independent", abs(code_min - independent), 1e-9)
    assert code_min > 0


@pytest.mark.parametrize("lobes", sorted(MODEL_DOC_T1_TABLE))
def test_pitch_radius_and_pressure_angle_match_table(check, lobes):
    """Smallest convex pitch radius 1/max(kappa_C) and max pressure angle beta = angle(n, e_r) (docs/model.md §2.5)."""
    _, radius_mm, beta_deg, _ = MODEL_DOC_T1_TABLE[lobes]
    args = law_arguments(params_for("harmonic", lobes))
    kappa_max = 0.0
    beta_max = 0.0
    for u in np.linspace(0, TWO_PI / lobes, 6001):
        cx, cy, nx, ny, _, kappa = pitch_frame(u, *args)
        kappa_max = max(kappa_max, kappa)
        beta_max = max(beta_max, abs(math.atan2(cx * ny - cy * nx, cx * nx + cy * ny)))
    check("T1 smallest convex pitch radius vs docs/model.md T1 table [mm]", abs(1e3 / kappa_max - radius_mm), 0.005 + 1e-9)
    check("T1 max pressure angle vs docs/model.md T1 table [deg]", abs(math.degrees(beta_max) - beta_deg), 0.05 + 1e-9)


@pytest.mark.parametrize("clearance", [0.0, 0.1e-3])
@pytest.mark.parametrize("lobes", sorted(MODEL_DOC_T1_TABLE))
def test_smallest_stator_radius_is_valley_gap(check, lobes, clearance):
    """min |S| = R_r + c_S (docs/model.md §2.5), to 1e-9 m: dense grid of |S| then a bounded minimiser."""
    p = params_for("harmonic", lobes, clearance)
    args = law_arguments(p)
    d = p.envelope_offset

    def radius(u):
        sx, sy = stator_point(u, *args, d)[:2]
        return math.hypot(sx, sy)

    u = np.linspace(-0.5 * TWO_PI / lobes, 0.5 * TWO_PI / lobes, 4001)
    values = np.array([radius(x) for x in u])
    i = int(np.argmin(values))
    best = minimize_scalar(radius, bounds=(u[i - 1], u[i + 1]), method="bounded", options=dict(xatol=1e-12))
    check("T1 min|S| - (R_r + c_S) [m]", abs(min(best.fun, values[i]) - (R_ROTOR + clearance)), 1e-9)


def independent_lobe_area(reference, lobes, clearance):
    """A_lobe = 1/2 int (S_x S'_y - S_y S'_x) du - 1/2 R_r^2 2 pi/z with scipy quad and complex-step S'."""
    ref = reference.HarmonicPitch(R0, H, lobes)
    d = RHO + clearance

    def integrand(u):
        s = ref.stator(u, d)
        ds = ref.stator_derivative(u, d)
        return s[0] * ds[1] - s[1] * ds[0]

    value, _ = integrate.quad(integrand, 0.0, TWO_PI / lobes, epsabs=1e-16, epsrel=1e-13, limit=200)
    return 0.5 * value - 0.5 * R_ROTOR ** 2 * TWO_PI / lobes


@pytest.mark.parametrize("lobes", sorted(MODEL_DOC_T1_TABLE))
def test_lobe_area_matches_table(check, reference, lobes):
    expected = MODEL_DOC_T1_TABLE[lobes][3] * 1e-6
    independent = independent_lobe_area(reference, lobes, 0.0)
    code = lobe_area(params_for("harmonic", lobes))
    check("T1 A_lobe independent vs docs/model.md T1 table, rel.", abs(independent / expected - 1), 1e-3)
    check("T1 A_lobe lobe_area() vs docs/model.md T1 table, rel.", abs(code / expected - 1), 1e-3)
    check("T1 A_lobe lobe_area() vs independent quad, rel.", abs(code / independent - 1), 1e-9)


def test_lobe_area_with_clearance(check, reference):
    independent = independent_lobe_area(reference, 3, 0.1e-3)
    code = lobe_area(params_for("harmonic", 3, 0.1e-3))
    check("T1 A_lobe lobe_area() vs independent quad, rel.", abs(code / independent - 1), 1e-9)
    assert code > lobe_area(params_for("harmonic", 3))


def regularity_closed_form(lobes, stroke, offset):
    """1 + d kappa_C at the harmonic valley (r = R0, r' = 0, r'' = h z^2/2): 1 + d/R0 - d h z^2/(2 R0^2)."""
    return 1 + offset / R0 - offset * stroke * lobes ** 2 / (2 * R0 ** 2)


def test_invalid_stator_raises():
    """z = 9 with a large stroke gives a cusp (1 + d kappa_C < 0 at the valley): ValueError naming 1 + d*kappa."""
    assert regularity_closed_form(9, 12e-3, RHO) < 0
    with pytest.raises(ValueError, match=r"1 \+ d\*kappa") as info:
        CompressorParameters(lobes=9, stroke=12e-3)
    assert "stroke" in str(info.value) and "allowed" in str(info.value)
    # the boundary moves with the clearance: d = rho is regular, d = rho + 0.1 mm is not (closed form)
    assert regularity_closed_form(9, 10e-3, RHO) > 0 > regularity_closed_form(9, 10e-3, RHO + 0.1e-3)
    CompressorParameters(lobes=9, stroke=10e-3)
    with pytest.raises(ValueError, match=r"1 \+ d\*kappa"):
        CompressorParameters(lobes=9, stroke=10e-3, stator_clearance=0.1e-3)


# ----------------------------------------------------------------------------------------------------------
# T1b: closest point of the pitch curve (docs/model.md §2.6)


def brute_force_closest(reference, lobes, targets, samples=20000, polish=False):
    """Global grid search of |T - C(u)| over one revolution, refined by scipy's bounded minimiser on the
    neighbouring cells (parametrised as an offset from the grid point so that xatol is absolute). The minimiser
    locates u* to ~1e-10 m only (|T - C|^2 is flat there); `polish` adds a bracketed root of the reference
    f(u) = (T - C).C' (brentq) next to it."""
    ref = reference.HarmonicPitch(R0, H, lobes)
    grid = np.linspace(0.0, TWO_PI, samples, endpoint=False)
    curve = ref.point(grid)
    du = TWO_PI / samples
    a, z = 0.5 * H, float(lobes)
    result = np.empty(len(targets))
    for start in range(0, len(targets), 500):
        chunk = targets[start:start + 500]
        dist2 = (chunk[:, 0:1] - curve[0][None, :]) ** 2 + (chunk[:, 1:2] - curve[1][None, :]) ** 2
        nearest = np.argmin(dist2, axis=1)
        for k, (tx, ty) in enumerate(chunk):
            u0 = grid[nearest[k]]

            def distance2(v, u0=u0, tx=tx, ty=ty):
                u = u0 + v
                r = R0 + a * (1 - math.cos(z * u))
                return (tx - r * math.cos(u)) ** 2 + (ty - r * math.sin(u)) ** 2

            best = minimize_scalar(distance2, bounds=(-2 * du, 2 * du), method="bounded",
                                   options=dict(xatol=1e-14, maxiter=500))
            result[start + k] = u0 + best.x
            if polish:   # root of d(distance^2)/du = -2 f(u) next to the minimiser's answer
                u1 = result[start + k]
                result[start + k] = brentq(lambda u, tx=tx, ty=ty: ref.residual(u, tx, ty), u1 - 1e-6, u1 + 1e-6,
                                           xtol=1e-15, rtol=8.9e-16)
    return result


def random_targets(reference, lobes, count, seed):
    """T = C(u) + an offset uniform in the +-1 mm square, u uniform over the revolution."""
    ref = reference.HarmonicPitch(R0, H, lobes)
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, TWO_PI, count)
    return ref.point(u).T + rng.uniform(-1e-3, 1e-3, (count, 2))


def point_error(reference, lobes, u_a, u_b):
    ref = reference.HarmonicPitch(R0, H, lobes)
    return np.hypot(*(ref.point(u_a) - ref.point(u_b)))


@pytest.mark.parametrize("lobes,count", [(3, 10000), (9, 2000)])
def test_closest_point_newton_against_brute_force(check, reference, lobes, count):
    """T1b: Newton u* from u0 = atan2(T) matches a dense brute-force search: the closest points agree to
    < 1e-9 m, the distances to < 1e-9 m, and Newton converges in <= 8 iterations."""
    targets = random_targets(reference, lobes, count, seed=lobes)
    args = law_arguments(params_for("harmonic", lobes))
    newton = np.empty(count)
    iterations = np.empty(count, dtype=int)
    for k, (tx, ty) in enumerate(targets):
        newton[k], iterations[k] = closest_pitch_parameter(tx, ty, math.atan2(ty, tx), *args)
    brute = brute_force_closest(reference, lobes, targets)
    polished = brute_force_closest(reference, lobes, targets[:2000], polish=True)
    ref = reference.HarmonicPitch(R0, H, lobes)
    distance_newton = np.hypot(*(targets.T - ref.point(newton)))
    distance_brute = np.hypot(*(targets.T - ref.point(brute)))
    assert np.all(iterations >= 1), "the Brent fallback should not be needed from atan2(T)"
    check("T1b Newton iterations from atan2(T)", iterations.max(), 8)
    check("T1b | |T - C(u_N)| - |T - C(u_brute)| | [m]", np.max(np.abs(distance_newton - distance_brute)), 1e-9)
    check("T1b |C(u_N) - C(u_brute)| [m]", np.max(point_error(reference, lobes, newton, brute)), 1e-9)
    check("T1b |C(u_N) - C(u_brute, polished)| [m]", np.max(point_error(reference, lobes, newton[:2000], polished)),
          1e-12)
    # Newton is never worse than the brute force beyond rounding
    assert np.all(distance_newton <= distance_brute + 1e-15)


def fallback_start(ref, tx, ty):
    """A start on the far side of the rotor where f'(u) = -|C'|^2 + (T - C).C'' >= 0 (reference formulas), so
    that Newton cannot be used there and the Brent safeguard of docs/model.md §2.6 must run."""
    for k in range(41):
        for sign in (1, -1):
            u = math.atan2(ty, tx) + math.pi + sign * 0.02 * k
            f_prime = -np.sum(ref.derivative(u) ** 2) + np.dot(np.array((tx, ty)) - ref.point(u),
                                                                ref.second_derivative(u))
            if f_prime > 0:
                return u
    raise AssertionError("no start with f' > 0 found")


@pytest.mark.parametrize("lobes", [3, 9])
def test_closest_point_brent_fallback(check, reference, lobes):
    """From a start with f'(u_start) >= 0 Newton is not usable: the Brent safeguard must run
    (iterations = -1) and still find the closest point."""
    ref = reference.HarmonicPitch(R0, H, lobes)
    args = law_arguments(params_for("harmonic", lobes))
    targets = random_targets(reference, lobes, 200, seed=100 + lobes)
    brute = brute_force_closest(reference, lobes, targets, polish=True)
    for (tx, ty), u_ref in zip(targets, brute):
        u_start = fallback_start(ref, tx, ty)
        u, iterations = closest_pitch_parameter(tx, ty, u_start, *args)
        assert iterations == -1
        check("T1b Brent fallback |C(u*) - C(u_brute, polished)| [m]", point_error(reference, lobes, u, u_ref), 1e-12)


@pytest.mark.skipif(not hasattr(stator, "closest_pitch_frame"), reason="no closest_pitch_frame in this version")
def test_closest_pitch_frame_against_brute_force(check, reference):
    """The time loop's fused closest-point + frame routine (if present) agrees with the brute force and the
    independent frame at u*."""
    lobes = 5
    ref = reference.HarmonicPitch(R0, H, lobes)
    args = law_arguments(params_for("harmonic", lobes))
    targets = random_targets(reference, lobes, 500, seed=77)
    brute = brute_force_closest(reference, lobes, targets, polish=True)
    for (tx, ty), u_ref in zip(targets, brute):
        for u_start in (math.atan2(ty, tx), fallback_start(ref, tx, ty)):
            u, cx, cy, nx, ny, _, kappa = stator.closest_pitch_frame(tx, ty, u_start, *args)
            check("T1b closest_pitch_frame |C(u*) - C(u_brute, polished)| [m]", point_error(reference, lobes, u, u_ref),
                  1e-12)
            assert np.allclose((cx, cy), ref.point(u), rtol=0, atol=1e-15)
            assert np.allclose((nx, ny), ref.normal(u), rtol=0, atol=1e-13)
            assert abs(kappa - ref.curvature(u)) < 1e-10 * abs(ref.curvature(u)) + 1e-12


# ----------------------------------------------------------------------------------------------------------
# T2: vane mass properties (docs/model.md §2.1)


def stadium_mass_properties(thickness, length, axial_length, density):
    """Area, centroid and polar second moment of the stadium-ended vane by scipy dblquad over the shape.
    Coordinates: xi along the axis from the tip-circle centre T, eta across."""
    rho = thickness / 2
    straight = length - rho
    opts = dict(epsabs=1e-22, epsrel=1e-13)

    def integrate_shape(f):
        rect = integrate.dblquad(lambda eta, xi: f(xi, eta), -straight, 0.0, -rho, rho, **opts)[0]
        def half_chord(xi):
            return math.sqrt(max(rho * rho - xi * xi, 0.0))

        disc = integrate.dblquad(lambda eta, xi: f(xi, eta), 0.0, rho, lambda xi: -half_chord(xi), half_chord,
                                 **opts)[0]
        return rect + disc

    area = integrate_shape(lambda xi, eta: 1.0)
    xi_g = integrate_shape(lambda xi, eta: xi) / area
    polar = integrate_shape(lambda xi, eta: (xi - xi_g) ** 2 + eta ** 2)
    return density * axial_length * area, density * axial_length * polar, xi_g


def test_default_vane_mass_properties_match_spec(check):
    p = CompressorParameters()
    mass, inertia, xi_g = vane_mass_properties(p.vane_thickness, p.vane_length, p.axial_length, p.vane_density)
    check("T2 m3 vs docs/model.md 30.345 g, rel.", abs(mass / 30.345e-3 - 1), 1e-3)
    check("T2 J3 vs docs/model.md 8.232e-7, rel.", abs(inertia / 8.232e-7 - 1), 1e-3)
    check("T2 xi_G vs docs/model.md -7.209 mm, rel.", abs(xi_g / -7.209e-3 - 1), 1e-3)
    m = machine_from_parameters(p)
    check("T2 xi_T vs docs/model.md 7.209 mm, rel.", abs(m.tip_centre / 7.209e-3 - 1), 1e-3)
    check("T2 xi_B vs docs/model.md -8.791 mm, rel.", abs(m.bottom_face / -8.791e-3 - 1), 1e-3)
    assert m.vane_mass == mass and m.vane_inertia == inertia


@pytest.mark.parametrize("thickness,length,axial,density", [
    (4.0e-3, 18.0e-3, 55.0e-3, 7850.0),       # docs/model.md §9
    (3.0e-3, 22.0e-3, 40.0e-3, 2700.0),
    (6.0e-3, 15.0e-3, 70.0e-3, 7850.0),
])
def test_vane_mass_properties_against_numerical_integration(check, thickness, length, axial, density):
    mass, inertia, xi_g = vane_mass_properties(thickness, length, axial, density)
    mass_q, inertia_q, xi_g_q = stadium_mass_properties(thickness, length, axial, density)
    check("T2 m3 vs dblquad, rel.", abs(mass / mass_q - 1), 1e-9)
    check("T2 J3 vs dblquad, rel.", abs(inertia / inertia_q - 1), 1e-9)
    check("T2 xi_G vs dblquad, rel.", abs(xi_g / xi_g_q - 1), 1e-9)


def test_far_start_that_converges_to_another_root_falls_back_to_brent():
    """From a start far from the tip centre Newton can converge to another root of f (the far side of the
    stator); the search must then bracket around atan2(T) and return the true closest point."""
    args = law_arguments(CompressorParameters(lobes=5))
    tip = (0.029665912101837076, -0.013543062329854234)
    u, iterations = closest_pitch_parameter(*tip, 2.713330493977539, *args)
    assert iterations == -1
    cx, cy = pitch_curve(u, *args)[:2]
    assert math.hypot(tip[0] - cx, tip[1] - cy) < 1e-3          # the true closest point is within 1 mm
    assert abs(u - math.atan2(tip[1], tip[0])) < 0.5 * math.pi / 5
