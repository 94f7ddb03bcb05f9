"""Contact detection and contact laws: docs/model.md §11 T5 (normal force), T6 (friction), T7 (mirror symmetry),
T8 (clearance geometry), and the six-region detection against an independent docs/model.md §4 reference
(tests/reference_formulas.py)."""
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate
from scipy.integrate import solve_ivp

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.contact.detection import (EDGE_ON_ARC, EDGE_ON_FACE, NO_CANDIDATE, TIP_ON_WALL,
                                                     slot_bottom_contact, slot_floor_contact,
                                                     slot_mouth_contact, tip_contact)
from rotary_vane.mechanics.contact.contact_laws import (elastic_force, friction_coefficient_effective, hertz_stiffness,
                                                        normal_force)
from rotary_vane.mechanics.geometry.kinematics import pose_of
from rotary_vane.mechanics.loop.machine import machine_from_parameters
from rotary_vane.mechanics.contact.regions import MEMORY_SLOTS, REGION_COUNT

RPM = 2 * math.pi / 60
E_STAR_MODEL_DOC = 113.7e9        # docs/model.md §5.2 / §9


def e_star(params):
    return params.youngs_modulus / (2 * (1 - params.poisson_ratio ** 2))


def hertz_k(radius, params):
    """K = (4/3) E* sqrt(R*) (docs/model.md §5.2 option P)."""
    return 4 / 3 * e_star(params) * math.sqrt(radius)


# (vane curvature, other curvature, R*) of docs/model.md §5.2's table: edge on plane, tip on wall, edge vs arc,
# tip vs a concave stator (kappa_S = 40 1/m), tip vs a locally convex stator (kappa_S = -150 1/m)
RHO, R_E = 2e-3, 1e-3
CURVATURE_CASES = [(0.0, 1 / R_E), (1 / RHO, 0.0), (1 / RHO, 1 / R_E), (1 / RHO, -40.0), (1 / RHO, 150.0)]


# ----------------------------------------------------------------------------------------------------------
# T5: normal contact force


def test_hertz_stiffness_matches_spec(check):
    p = CompressorParameters()
    m = machine_from_parameters(p)
    check("T5 E* (formula) vs docs/model.md 113.7 GPa, rel.", abs(e_star(p) / E_STAR_MODEL_DOC - 1), 1e-3)
    assert abs(m.effective_modulus / e_star(p) - 1) < 1e-14
    k = hertz_stiffness(0.0, 1 / R_E, m.effective_modulus)
    # docs/model.md §5.2: K = 4.80e9 N/m^1.5 for r_e = 1 mm
    check("T5 K(r_e = 1 mm) vs docs/model.md 4.80e9, rel.", abs(k / 4.80e9 - 1), 2e-3)
    # docs/model.md §5.2: 300 N gives delta = 15.7 um and k = 1.5 F/delta = 2.9e7 N/m
    delta = (300 / k) ** (2 / 3)
    check("T5 delta(300 N) vs docs/model.md 15.7 um [m]", abs(delta - 15.7e-6), 0.1e-6)
    check("T5 1.5 F/delta vs docs/model.md 2.9e7 N/m, rel.", abs(1.5 * 300 / delta / 2.9e7 - 1), 0.02)
    for vane, other in CURVATURE_CASES:
        expected = hertz_k(1 / (vane + other), p)
        check("T5 hertz_stiffness vs (4/3) E* sqrt(R*), rel.",
              abs(hertz_stiffness(vane, other, m.effective_modulus) / expected - 1), 1e-14)


@pytest.mark.parametrize("vane,other", CURVATURE_CASES)
def test_static_force_is_hertz_and_energy_is_its_integral(check, vane, other):
    """F(delta, rate = 0) = K delta^1.5 and the stored energy equals int_0^delta F d delta (quadrature)."""
    p = CompressorParameters()
    m = machine_from_parameters(p)
    k = hertz_k(1 / (vane + other), p)
    for delta in (1e-9, 1e-7, 3e-6, 2e-5):
        elastic, energy, _ = elastic_force(delta, vane, other, m)
        check("T5 F(delta, rate 0) vs K delta^1.5, rel.", abs(elastic / (k * delta ** 1.5) - 1), 1e-13)
        for onset in (0.01, 0.3):
            assert normal_force(elastic, 0.0, onset, p.restitution) == elastic
        work, _ = integrate.quad(lambda x: elastic_force(x, vane, other, m)[0], 0.0, delta, epsabs=0, epsrel=1e-12)
        check("T5 option P energy vs quad of F, rel.", abs(energy / work - 1), 1e-9)
    assert elastic_force(0.0, vane, other, m)[0] == 0.0


def test_normal_force_damping_factor_and_no_adhesion(check):
    """F_n = F_el [1 + 3 (1 - c_e^2)/4 rate/v-], clamped at 0 (no adhesion): F >= 0 always."""
    rng = np.random.default_rng(0)
    for _ in range(2000):
        elastic = rng.uniform(0, 500)
        rate = rng.uniform(-20, 20)
        onset = rng.uniform(0.01, 2)
        restitution = rng.uniform(0.05, 1.0)
        force = normal_force(elastic, rate, onset, restitution)
        expected = elastic * (1 + 0.75 * (1 - restitution ** 2) * rate / onset)
        assert force >= 0
        check("T5 LN force vs formula, rel. to F_el", abs(force - max(expected, 0.0)) / elastic, 1e-13)
    assert normal_force(0.0, -5.0, 0.1, 0.9) == 0.0


def test_no_force_when_contacts_are_open(reference, kernel):
    """F(delta <= 0) = 0: a vane retracted from the stator and centred in a slot with clearance has all
    penetrations <= 0 (the bottom corners clear the slot bottom), zero normal and friction forces, contact mode 0 and
    no contact power."""
    p = CompressorParameters(slot_clearance=0.05e-3, stator_clearance=0.05e-3, pressure_model="ideal_gas_table")
    sim = Simulation(p, constant_speed(1500.0), initial_angle=0.0)
    xi_t = sim.machine.tip_centre
    ref = reference.HarmonicPitch(p.base_radius, p.stroke, p.lobes)
    for theta in np.linspace(0.0, 2 * math.pi, 13):
        time = theta / (1500.0 * RPM)
        er = np.array([math.cos(theta), math.sin(theta)])
        for gap in (1e-12, 5e-6):      # tip 1 pm and 5 um inside the stator
            tip = ref.point(theta) + (p.stator_clearance - gap) * ref.normal(theta)
            cg = tip - xi_t * er
            state = (*cg, theta, 1.0, -2.0, 150.0)
            status, dydt, out = kernel.evaluate_at(sim, time, state, onset=(0.1,) * MEMORY_SLOTS)
            assert abs(out["rotor_angle"] - theta) < 1e-12
            assert status == 0
            for k in range(1, REGION_COUNT + 1):
                # delta <= 0, or NaN where the region has no valid candidate (the tip's other quarter)
                assert not out[f"penetration_{k}"] > 0
                assert out[f"normal_force_{k}"] == 0 and out[f"friction_force_{k}"] == 0
            assert out["contact_mode"] == 0
            assert dydt[8] == 0 and dydt[9] == 0 and dydt[10] == 0 and out["contact_energy"] == 0
            assert out["stator_force_x"] == 0 and out["rotor_force_x"] == 0


def impact_restitution(v_minus, machine, vane_curvature, other_curvature):
    """1-DOF impact of the vane mass on a fixed body: m delta'' = -F_n(delta, delta'), from delta = 0 with
    delta' = v-, until delta returns to 0 (scipy DOP853, tight tolerances). Returns v+/v-."""
    mass = machine.vane_mass

    def rhs(_, y):
        delta, rate = y
        if delta <= 0.0:
            return [rate, 0.0]
        elastic = elastic_force(delta, vane_curvature, other_curvature, machine)[0]
        return [rate, -normal_force(elastic, rate, v_minus, machine.restitution) / mass]

    def separation(_, y):
        return y[0]

    separation.terminal = True
    separation.direction = -1
    solution = solve_ivp(rhs, (0.0, 2e-3), [0.0, v_minus], method="DOP853", rtol=1e-12, atol=[1e-16, 1e-12],
                         events=separation)
    assert solution.status == 1, "the impact did not end"
    return -solution.y_events[0][0][1] / v_minus


@pytest.mark.parametrize("v_minus", [0.1, 0.2, 0.5, 1.0])
def test_impact_restitution_option_p(check, v_minus):
    """T5: edge on plane (R* = r_e), option P: v+/v- = c_e +- 3 %."""
    p = CompressorParameters()
    m = machine_from_parameters(p)
    ratio = impact_restitution(v_minus, m, 0.0, 1 / p.edge_radius)
    check("T5 impact |v+/v- / c_e - 1|", abs(ratio / p.restitution - 1), 0.03)


# option L (Johnson line contact)


def johnson_penetration(force, vane_curvature, other_curvature, params):
    """delta(F) of docs/model.md §5.2 option L: b = sqrt(4 F R*/(pi L E*)),
    delta = F/(pi L) sum over curved bodies (1 - nu^2)/E (2 ln(4 R_k/b) - 1), flat bodies rigid."""
    radius = 1 / (vane_curvature + other_curvature)
    half_width = math.sqrt(4 * force * radius / (math.pi * params.axial_length * e_star(params)))
    compliance = (1 - params.poisson_ratio ** 2) / params.youngs_modulus
    total = 0.0
    for curvature in (vane_curvature, other_curvature):
        if curvature != 0.0:
            total += compliance * (2 * math.log(4 / abs(curvature) / half_width) - 1)
    return force / (math.pi * params.axial_length) * total


@pytest.mark.parametrize("vane,other", CURVATURE_CASES)
def test_line_contact_inverts_johnson_formula(check, vane, other):
    p = CompressorParameters(stiffness_model="johnson_line")
    m = machine_from_parameters(p)
    worst = 0.0
    for force in (0.1, 1.0, 10.0, 100.0, 300.0, 1000.0, 5000.0):
        delta = johnson_penetration(force, vane, other, p)
        got = elastic_force(delta, vane, other, m)[0]
        worst = max(worst, abs(got / force - 1))
    check("T5 option L F(delta(F)) round trip, rel.", worst, 1e-9)
    # monotonic in delta, and much stiffer than option P (docs/model.md §5.2: ~0.1-0.2 um at 300 N, not ~16 um)
    deltas = np.logspace(-11, -5.5, 300)
    forces = np.array([elastic_force(d, vane, other, m)[0] for d in deltas])
    assert np.all(np.diff(forces) > 0)
    assert 0.02e-6 < johnson_penetration(300.0, vane, other, p) < 0.5e-6


@pytest.mark.parametrize("vane,other", CURVATURE_CASES)
def test_line_contact_force_solves_the_law_to_rounding(check, vane, other):
    """docs/model.md §5.2 option L: the force found for delta inside the law's range satisfies F (A - B ln F) = delta
    to rounding (a converged Newton iterate is taken as the root, not bisected towards it to only ~1e-13)."""
    from rotary_vane.mechanics.contact.contact_laws import line_contact_constants, line_contact_limit
    m = machine_from_parameters(CompressorParameters(stiffness_model="johnson_line"))
    a, b = line_contact_constants(vane, other, m)
    worst = 0.0
    for delta in np.logspace(-11, math.log10(0.9 * line_contact_limit(a, b)[1]), 400):
        force = elastic_force(delta, vane, other, m)[0]
        worst = max(worst, abs(force * (a - b * math.log(force)) / delta - 1))
    check("T5 option L residual of delta(F) at the solved F, rel.", worst, 1e-14)


@pytest.mark.parametrize("vane,other", CURVATURE_CASES)
def test_line_contact_energy_is_integral_of_force(check, vane, other):
    p = CompressorParameters(stiffness_model="johnson_line")
    m = machine_from_parameters(p)
    for force in (1.0, 300.0, 2000.0):
        delta = johnson_penetration(force, vane, other, p)
        energy = elastic_force(delta, vane, other, m)[1]
        work, _ = integrate.quad(lambda x: elastic_force(x, vane, other, m)[0], 0.0, delta, epsabs=0,
                                 epsrel=1e-11, limit=200)
        check("T5 option L energy vs quad of F, rel.", abs(energy / work - 1), 1e-6)


# Curvature pairs of both signs of the other body: convex (> 0), flat (0), concave (< 0), and a nearly conformal
# concave pair whose curvature sum (1e-6 1/m) is far below any of the machine's
SIGNED_CURVATURES = CURVATURE_CASES + [(0.0, -40.0), (1 / RHO, -1 / RHO + 1e-6), (1 / R_E, -1 / RHO)]


@pytest.mark.parametrize("stiffness_model", ["hertz_point", "johnson_line"])
@pytest.mark.parametrize("vane,other", SIGNED_CURVATURES)
def test_every_force_law_is_defined_over_the_whole_penetration_range(check, stiffness_model, vane, other):
    """docs/model.md §5.2: for penetrations 1e-12 .. 1e-3 m and both curvature signs each elastic law gives a finite,
    strictly increasing force, a stored energy equal to int_0^delta F d delta (adaptive quadrature, split at the
    line law's validity limit) to 1e-9, and an excess that is 0 inside the law's range and delta - delta_s beyond."""
    from rotary_vane.mechanics.contact.contact_laws import line_contact_constants, line_contact_limit
    m = machine_from_parameters(CompressorParameters(stiffness_model=stiffness_model))
    deltas = np.logspace(-12, -3, 400)
    values = np.array([elastic_force(d, vane, other, m) for d in deltas])
    forces, energies, excess = values.T
    assert np.all(np.isfinite(values))
    assert np.all(np.diff(forces) > 0) and np.all(forces > 0)
    limit = math.inf
    if stiffness_model == "johnson_line":
        a, b = line_contact_constants(vane, other, m)
        limit = line_contact_limit(a, b)[1]
    expected_excess = np.maximum(deltas - limit, 0.0)
    check("T5 law excess vs max(delta - delta_s, 0) [m]", float(np.max(np.abs(excess - expected_excess))), 1e-18)
    # continuity at the validity limit: the tangent continues the law
    if math.isfinite(limit) and 1e-12 < limit < 1e-3:
        below, above = (elastic_force(limit * (1 + s), vane, other, m) for s in (-1e-12, 1e-12))
        check("T5 option L force jump at delta_s, rel.", abs(above[0] / below[0] - 1), 1e-9)
        check("T5 option L energy jump at delta_s, rel.", abs(above[1] / below[1] - 1), 1e-9)
    worst = 0.0
    for delta, energy in zip(deltas[::20], energies[::20]):
        points = [0.0] + ([limit] if limit < delta else []) + [delta]
        work = sum(integrate.quad(lambda x: elastic_force(x, vane, other, m)[0], lo, hi, epsabs=0, epsrel=1e-13,
                                  limit=400)[0] for lo, hi in zip(points[:-1], points[1:]))
        worst = max(worst, abs(energy / work - 1))
    check(f"T5 {stiffness_model} stored energy vs quad of F, rel.", worst, 1e-9)


# ----------------------------------------------------------------------------------------------------------
# T6: friction


def threlfall(slip, mu, v0):
    return mu * (1 - math.exp(-3 * slip / v0))


def test_threlfall_coefficient(check):
    p = CompressorParameters()
    m = machine_from_parameters(p)
    mu, v0 = p.friction_coefficient, p.friction_velocity
    assert friction_coefficient_effective(0.0, m) == 0.0
    worst = 0.0
    for slip in np.concatenate([np.logspace(-9, 1, 400), [v0, 10 * v0, 5.0]]):
        got = friction_coefficient_effective(slip, m)
        worst = max(worst, abs(got - threlfall(slip, mu, v0)) / mu)
        assert 0 <= got <= mu
        if slip >= 10 * v0:
            check("T6 Threlfall mu_eff/mu - 1 for |v_t| >= 10 v0", abs(got / mu - 1), 1e-6)
    check("T6 Threlfall mu_eff vs formula / mu", worst, 1e-14)
    # continuous and Lipschitz with slope 3 mu/v0 at most
    slips = np.linspace(0, 20 * v0, 20001)
    values = np.array([friction_coefficient_effective(s, m) for s in slips])
    assert np.max(np.abs(np.diff(values))) <= 3 * mu / v0 * (slips[1] - slips[0]) * (1 + 1e-9)


def test_ambrosio_coefficient(check):
    p = CompressorParameters(friction_model="ambrosio", friction_velocity=1e-4, friction_velocity_full=1e-3)
    m = machine_from_parameters(p)
    mu = p.friction_coefficient
    cases = {0.0: 0.0, 5e-5: 0.0, 0.99e-4: 0.0, 1e-4: 0.0, 2e-4: mu / 9, 5.5e-4: mu / 2, 1e-3: mu,
             1.0001e-3: mu, 0.5: mu}
    for slip, expected in cases.items():
        check("T6 Ambrosio mu_eff vs piecewise values", abs(friction_coefficient_effective(slip, m) - expected), 1e-14)
    slips = np.linspace(0, 2e-3, 20001)
    values = np.array([friction_coefficient_effective(s, m) for s in slips])
    assert np.max(np.abs(np.diff(values))) <= mu / 9e-4 * (slips[1] - slips[0]) * (1 + 1e-9)
    assert np.all(np.diff(values) >= 0)


@pytest.mark.parametrize("theta", [0.7, 1.6])         # rising flank (c6) and falling flank (c5) of lobe 1
def test_friction_force_in_the_kernel_is_odd_and_continuous(check, reference, kernel, theta):
    """Only the tip contact is closed (5 um), rate 0, pure sliding with slip speed v_t along the stator tangent:
    the friction force on the vane is -mu_eff(|v_t|) F_n v_t/|v_t|, odd in v_t, 0 at v_t = 0, continuous
    (slope <= 3 mu F_n/v_0), equal to mu F_n within 1e-6 for |v_t| >= 10 v_0."""
    p = CompressorParameters(slot_clearance=0.05e-3, stator_clearance=0.05e-3)
    sim = Simulation(p, constant_speed(1500.0), initial_angle=theta)
    ref = reference.HarmonicPitch(p.base_radius, p.stroke, p.lobes)
    n = ref.normal(theta)
    tangent = np.array([-n[1], n[0]])
    tip = ref.point(theta) + (p.stator_clearance + 5e-6) * n
    cg = tip - sim.machine.tip_centre * np.array([math.cos(theta), math.sin(theta)])
    region = 5 if np.dot(n, [-math.sin(theta), math.cos(theta)]) > 0 else 6
    mu, v0 = p.friction_coefficient, p.friction_velocity

    def tip_force(slip):
        velocity = slip * tangent
        _, _, out = kernel.evaluate_at(sim, 0.0, (*cg, theta, *velocity, 0.0))
        assert out["contact_mode"] == 1 << (region - 1)
        force = -np.array([out["stator_force_x"], out["stator_force_y"]])     # force on the vane
        return np.dot(force, -n), np.dot(force, tangent), out[f"normal_force_{region}"], \
            out[f"friction_force_{region}"]

    normal0, tangential0, reported_normal, reported_friction = tip_force(0.0)
    expected_normal = hertz_k(1 / (1 / p.tip_radius - ref.curvature(theta) / (1 + p.envelope_offset
                                                                                * ref.curvature(theta))), p) \
        * 5e-6 ** 1.5
    check("T6 kernel tip F_n vs K delta^1.5 (independent K), rel.", abs(normal0 / expected_normal - 1), 1e-9)
    assert reported_normal == pytest.approx(normal0, rel=1e-12)
    assert abs(tangential0) <= 1e-12 * normal0 and reported_friction == 0.0
    slips = np.concatenate([np.linspace(-20 * v0, 20 * v0, 801), [-2.0, -50 * v0, 50 * v0, 2.0]])
    results = {s: tip_force(s) for s in slips}
    for slip, (normal, tangential, _, reported) in results.items():
        assert abs(normal - normal0) <= 1e-12 * normal0                       # rate 0: F_n independent of v_t
        expected = -math.copysign(threlfall(abs(slip), mu, v0), slip) * normal0 if slip != 0 else 0.0
        check("T6 kernel F_t vs -mu_eff F_n v_t/|v_t|, rel. to F_n", abs(tangential - expected) / normal0, 1e-12)
        assert abs(reported - abs(tangential)) <= 1e-12 * normal0
        back = results.get(-slip)
        if back is not None:                                                  # odd in v_t
            check("T6 kernel F_t(v) + F_t(-v), rel. to F_n", abs(tangential + back[1]) / normal0, 1e-12)
        if abs(slip) >= 10 * v0:
            check("T6 kernel |F_t|/(mu F_n) - 1 for |v_t| >= 10 v0", abs(abs(tangential) / (mu * normal0) - 1), 1e-6)
    ordered = sorted(s for s in slips if abs(s) <= 20 * v0)
    values = np.array([results[s][1] for s in ordered])
    assert np.max(np.abs(np.diff(values))) <= 3 * mu * normal0 / v0 * np.max(np.diff(ordered)) * (1 + 1e-9)


# ----------------------------------------------------------------------------------------------------------
# Detection against the independent docs/model.md §4 reference

KIND_CODES = {"A": EDGE_ON_FACE, "B": EDGE_ON_ARC, "C": TIP_ON_WALL}


def machine_and_geometry(contact_reference, **overrides):
    p = CompressorParameters(**overrides)
    m = machine_from_parameters(p)
    return p, m, contact_reference.VaneGeometry(p, m.tip_centre)


def pose(theta, radial, lateral, tilt, params, xi_t):
    """Vane pose with the tip centre at radius R0 + radial along e_r(theta), lateral offset along e_theta and
    tilt phi - theta. Returns (G, phi)."""
    er = np.array([math.cos(theta), math.sin(theta)])
    et = np.array([-er[1], er[0]])
    phi = theta + tilt
    tip = (params.base_radius + radial) * er + lateral * et
    return tip - xi_t * np.array([math.cos(phi), math.sin(phi)]), phi


def code_regions(g, phi, theta, m):
    """The detectors' candidates of c1-c4 and the tip contact for a vane pose."""
    vane = pose_of(g[0], g[1], phi, theta, m)
    return ([slot_mouth_contact(1.0, vane, m), slot_mouth_contact(-1.0, vane, m),
             slot_bottom_contact(1.0, vane, m), slot_bottom_contact(-1.0, vane, m)],
            tip_contact(vane, 0.0, m))


def normal(candidate):
    return np.array([candidate.normal_x, candidate.normal_y])


def point(candidate):
    return np.array([candidate.point_x, candidate.point_y])


def contact_angle(tip):
    return math.atan2(tip.sin_contact_angle, tip.cos_contact_angle)


@pytest.mark.parametrize("clearance", [0.0, 0.05e-3, 0.2e-3])
def test_detection_matches_reference(check, contact_reference, clearance):
    """Random poses across the stroke (tip in the slot, at the mouth, out), lateral offsets and tilts: every
    region's delta, normal, point, R* and c1/c2 candidate type match docs/model.md §4.2-§4.4 evaluated independently."""
    p, m, v = machine_and_geometry(contact_reference, slot_clearance=clearance, stator_clearance=clearance)
    rng = np.random.default_rng(int(clearance * 1e6) + 1)
    kinds = set()
    worst = 0.0
    for k in range(600):
        theta = rng.uniform(0, 2 * math.pi)
        tilt = rng.uniform(-4e-3, 4e-3)
        if k < 400:
            radial = rng.uniform(-0.5e-3, p.stroke + 0.2e-3)
        else:  # tip centre within rho |tilt| below / (w/2) |tilt| above the mouth level: candidate B's band
            radial = v.mouth - p.base_radius + rng.uniform(-v.rho, 0.5 * v.w) * abs(tilt)
        g, phi = pose(theta, radial, rng.uniform(-0.1e-3, 0.1e-3), tilt, p, m.tip_centre)
        slots, tip = code_regions(g, phi, theta, m)
        refs, ref_tip = contact_reference.contacts(g, phi, theta, v)
        for k, got in enumerate(slots):
            expected = refs[k]
            if expected is None:
                assert got.penetration == -math.inf and got.kind == NO_CANDIDATE
                continue
            if k < 2:
                assert got.kind == KIND_CODES[expected["kind"]]
                kinds.add(expected["kind"])
            worst = max(worst, abs(got.penetration - expected["delta"]) / 1e-3)
            assert np.allclose(normal(got), expected["n"], rtol=0, atol=1e-12)
            assert np.allclose(point(got), expected["P"], rtol=0, atol=1e-15)
            assert abs(1 / (got.vane_curvature + got.other_curvature) / expected["radius"] - 1) < 1e-12
        candidate = tip.candidate
        worst = max(worst, abs(candidate.penetration - ref_tip["delta"]) / 1e-3)
        assert np.allclose(normal(candidate), ref_tip["n"], rtol=0, atol=1e-12)
        assert np.allclose(point(candidate), ref_tip["P"], rtol=0, atol=1e-15)
        assert abs(1 / (candidate.vane_curvature + candidate.other_curvature) / ref_tip["radius"] - 1) < 1e-10
    check("detection delta vs docs/model.md §4 reference [m] / 1 mm", worst, 1e-12)
    assert kinds == {"A", "B", "C"}


# ----------------------------------------------------------------------------------------------------------
# T7: mirror symmetry about the slot centreline


def reflect(point, theta):
    """Reflection about the line through O along e_r(theta)."""
    er = np.array([math.cos(theta), math.sin(theta)])
    return 2 * np.dot(point, er) * er - np.asarray(point)


MIRROR_POSES = [  # (radial position of T above R0, lateral offset of T, tilt)
    (-0.8e-3, 10e-6, 1.5e-3), (0.3e-3, -20e-6, -2e-3), (1.9e-3, 5e-6, 3e-3), (2.05e-3, 30e-6, -1e-3),
    (3.0e-3, -40e-6, 2.5e-3), (4.9e-3, 15e-6, -3e-3), (5.02e-3, 0.0, 0.0), (2.5e-3, 0.0, 1e-3),
]


@pytest.mark.parametrize("clearance", [0.0, 0.05e-3, 0.2e-3])
@pytest.mark.parametrize("radial,lateral,tilt", MIRROR_POSES)
def test_mirror_symmetry_of_slot_regions(check, radial, lateral, tilt, clearance):
    """T7: reflecting the vane about the slot centreline (eta -> -eta, tilt -> -tilt) swaps c1 <-> c2 and
    c3 <-> c4 with identical delta (1e-12 relative to 1 mm), mirrored normals and points, same candidate."""
    p = CompressorParameters(slot_clearance=clearance, stator_clearance=clearance)
    m = machine_from_parameters(p)
    for theta in (0.0, 0.4, 2.3, 4.0):
        g, phi = pose(theta, radial, lateral, tilt, p, m.tip_centre)
        g_mirror, phi_mirror = reflect(g, theta), 2 * theta - phi
        slots, _ = code_regions(g, phi, theta, m)
        mirrored, _ = code_regions(g_mirror, phi_mirror, theta, m)
        for k, partner in ((0, 1), (1, 0), (2, 3), (3, 2)):
            a, b = slots[k], mirrored[partner]
            if a.penetration == -math.inf:
                assert b.penetration == -math.inf
                continue
            check("T7 slot |delta - delta_mirror| [m] / 1 mm", abs(a.penetration - b.penetration) / 1e-3, 1e-12)
            assert np.allclose(reflect(normal(a), theta), normal(b), rtol=0, atol=1e-12)
            assert np.allclose(reflect(point(a), theta), point(b), rtol=0, atol=1e-15)
            assert (a.vane_curvature, a.other_curvature, a.radius, a.kind) == pytest.approx(
                (b.vane_curvature, b.other_curvature, b.radius, b.kind), rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("clearance", [0.0, 0.2e-3])
def test_slot_bottom_regions_match_reference_and_mirror(check, contact_reference, clearance):
    """c7/c8, the bottom corners on the slot bottom (docs/model.md §4.4b): with the vane pushed 2.4-2.6 mm into its
    slot (the corners clear the bottom by 2.5 mm at zero stroke), delta, normal, point and R* match the reference
    r_sb - B.e_r evaluated independently; reflecting the vane about the slot centreline swaps c7 <-> c8."""
    p, m, v = machine_and_geometry(contact_reference, slot_clearance=clearance, stator_clearance=clearance)
    rng = np.random.default_rng(7)
    worst = 0.0
    touching = 0
    for _ in range(200):
        theta = rng.uniform(0, 2 * math.pi)
        g, phi = pose(theta, rng.uniform(-2.6e-3, -2.4e-3), rng.uniform(-0.1e-3, 0.1e-3), rng.uniform(-4e-3, 4e-3),
                      p, m.tip_centre)
        refs, _ = contact_reference.contacts(g, phi, theta, v)
        vane = pose_of(g[0], g[1], phi, theta, m)
        mirror = pose_of(*reflect(g, theta), 2 * theta - phi, theta, m)
        for side, expected in ((1.0, refs[6]), (-1.0, refs[7])):
            got = slot_floor_contact(side, vane, m)
            touching += got.penetration > 0
            worst = max(worst, abs(got.penetration - expected["delta"]) / 1e-3)
            assert np.allclose(normal(got), expected["n"], rtol=0, atol=1e-12)
            assert np.allclose(point(got), expected["P"], rtol=0, atol=1e-15)
            assert abs(1 / (got.vane_curvature + got.other_curvature) / expected["radius"] - 1) < 1e-12
            partner = slot_floor_contact(-side, mirror, m)
            check("slot bottom |delta - delta_mirror| [m] / 1 mm", abs(got.penetration - partner.penetration) / 1e-3,
                  1e-12)
            assert np.allclose(reflect(point(got), theta), point(partner), rtol=0, atol=1e-15)
    check("slot bottom delta vs docs/model.md §4.4b reference [m] / 1 mm", worst, 1e-12)
    assert 50 < touching < 350


@pytest.mark.parametrize("lobes", [3, 5])
@pytest.mark.parametrize("clearance", [0.0, 0.1e-3])
def test_mirror_symmetry_of_tip_regions(check, reference, lobes, clearance):
    """T7 for c5 <-> c6: with the slot centreline on a symmetry axis of the stator (a valley or a lobe top), the
    mirrored vane has the same delta_S (1e-12 relative to 1 mm) and the opposite contact angle psi_c."""
    p = CompressorParameters(lobes=lobes, slot_clearance=clearance, stator_clearance=clearance)
    m = machine_from_parameters(p)
    ref = reference.HarmonicPitch(p.base_radius, p.stroke, lobes)
    for j in range(2 * lobes):
        theta = j * math.pi / lobes                    # valleys (j even) and lobe tops (j odd)
        s = ref.radius(theta)[0] - p.base_radius
        for lateral, tilt, radial in ((20e-6, 2e-3, 10e-6), (-35e-6, -1e-3, -5e-6), (0.0, 3e-3, 0.0),
                                      (50e-6, 0.0, 30e-6)):
            g, phi = pose(theta, s + clearance + radial, lateral, tilt, p, m.tip_centre)
            _, tip = code_regions(g, phi, theta, m)
            _, tip_mirror = code_regions(reflect(g, theta), 2 * theta - phi, theta, m)
            a, b = tip.candidate, tip_mirror.candidate
            check("T7 tip |delta - delta_mirror| [m] / 1 mm", abs(a.penetration - b.penetration) / 1e-3, 1e-12)
            psi, psi_mirror = contact_angle(tip), contact_angle(tip_mirror)
            check("T7 tip |psi_c + psi_c,mirror| [rad]", abs(psi + psi_mirror), 1e-12)
            assert np.allclose(reflect(normal(a), theta), normal(b), rtol=0, atol=1e-12)
            assert np.allclose(reflect(point(a), theta), point(b), rtol=0, atol=1e-15)
            assert abs(a.other_curvature - b.other_curvature) <= 1e-9 * abs(a.other_curvature) + 1e-9
            if abs(psi) > 1e-9:   # region index swaps: c5 (psi > 0) <-> c6 (psi < 0)
                assert (psi > 0) != (psi_mirror > 0)


# ----------------------------------------------------------------------------------------------------------
# T8: clearance geometry


@pytest.mark.parametrize("clearance", [0.0, 0.02e-3, 0.05e-3, 0.1e-3, 0.2e-3])
def test_centred_vane_has_half_clearance_in_every_slot_region(check, clearance):
    """T8: vane centred and untilted: delta_1..4 = -c_R/2 where candidate A (edge on face) or C (tip on wall)
    applies; the bottom corners always."""
    p = CompressorParameters(slot_clearance=clearance, stator_clearance=clearance)
    m = machine_from_parameters(p)
    seen = set()
    for theta in (0.0, 1.0, 3.5):
        for radial in np.linspace(-1.5e-3, p.stroke + clearance, 41):
            g, phi = pose(theta, radial, 0.0, 0.0, p, m.tip_centre)
            slots, _ = code_regions(g, phi, theta, m)
            for k in range(4):
                delta = slots[k].penetration
                if k >= 2 or slots[k].kind in (EDGE_ON_FACE, TIP_ON_WALL):
                    check("T8 |delta_1..4 + c_R/2| [m]", abs(delta + clearance / 2), 1e-15)
                    seen.add(int(slots[k].kind) if k < 2 else "corner")
    assert {EDGE_ON_FACE, TIP_ON_WALL, "corner"} <= seen


@pytest.mark.parametrize("lobes", [3, 9])
@pytest.mark.parametrize("clearance", [0.0, 0.05e-3, 0.2e-3])
def test_tip_on_nominal_path_has_stator_gap(check, reference, lobes, clearance):
    """T8: tip centre on the nominal pitch curve C(theta): delta_S = -c_S; more generally a tip centre at signed
    distance g from C along its normal has delta_S = g - c_S (any tilt)."""
    p = CompressorParameters(lobes=lobes, slot_clearance=clearance, stator_clearance=clearance)
    m = machine_from_parameters(p)
    ref = reference.HarmonicPitch(p.base_radius, p.stroke, lobes)
    rng = np.random.default_rng(lobes)
    worst = 0.0
    for theta in rng.uniform(0, 2 * math.pi, 60):
        for offset, tilt in ((0.0, 0.0), (0.0, rng.uniform(-5e-3, 5e-3)), (rng.uniform(-0.3e-3, 0.3e-3), 2e-3)):
            tip = ref.point(theta) + offset * ref.normal(theta)
            phi = theta + tilt
            g = tip - m.tip_centre * np.array([math.cos(phi), math.sin(phi)])
            result = tip_contact(pose_of(g[0], g[1], phi, theta, m), 0.0, m)
            worst = max(worst, abs(result.candidate.penetration - (offset - clearance)))
    check("T8 |delta_S - (g - c_S)| [m]", worst, 1e-15)


# docs/model.md §14.3, done to a copy of the project's packages: the recipe's two edits of
# mechanics/contact/contact_laws.py
RECIPE_EDITS = (
    ('FRICTION_MODELS = Choices("threlfall", "ambrosio")',
     'FRICTION_MODELS = Choices("threlfall", "ambrosio", "linear_ramp")'),
    ('THRELFALL, AMBROSIO = FRICTION_MODELS.codes("threlfall", "ambrosio")',
     'THRELFALL, AMBROSIO, LINEAR_RAMP = FRICTION_MODELS.codes("threlfall", "ambrosio", "linear_ramp")'),
    ('    if m.friction_model == THRELFALL:\n',
     '    if m.friction_model == LINEAR_RAMP:\n'
     '        return m.friction_coefficient * min(1.0, slip_speed / m.friction_velocity)\n'
     '    if m.friction_model == THRELFALL:\n'),
)
USE_THE_NEW_LAW = r'''
import dataclasses, math, sys
from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.contact.contact_laws import LINEAR_RAMP, friction_coefficient_effective
from rotary_vane.mechanics.loop.machine import machine_from_parameters
from rotary_vane.mechanics.parameters import markdown_table
from rotary_vane.fmu_src.variables import declared_parameter
assert __import__("rotary_vane.mechanics").mechanics.__file__.startswith(sys.argv[1])      # the copy, not the project
p = CompressorParameters(friction_model="linear_ramp", friction_velocity=0.02)
m = machine_from_parameters(p)
assert LINEAR_RAMP == 2 and m.friction_model == LINEAR_RAMP
for slip in (0.0, 0.005, 0.01, 0.02, 0.3):                 # mu min(1, v/v_0), written here
    expected = p.friction_coefficient * min(1.0, slip / 0.02)
    assert abs(friction_coefficient_effective(slip, m) - expected) <= 1e-15, (slip, expected)
threlfall = machine_from_parameters(CompressorParameters(friction_velocity=0.02))
assert friction_coefficient_effective(0.01, threlfall) == p.friction_coefficient * (1.0 - math.exp(-1.5))
try:
    CompressorParameters(friction_model="coulomb")
    raise AssertionError("an unknown friction model was accepted")
except ValueError as error:
    assert "'friction_model' = 'coulomb'" in str(error) and "threlfall, ambrosio, linear_ramp" in str(error)
assert "linear_ramp" in markdown_table()
declared = {f.name: f for f in dataclasses.fields(CompressorParameters)}["friction_model"]
assert "linear_ramp" in declared_parameter("friction_model", declared.metadata).description
if "run" in sys.argv:
    from rotary_vane.mechanics.performance import revolutions
    simulation = Simulation(p, constant_speed(1500.0))
    simulation.advance(2 * 0.04)
    last = revolutions(simulation)[-1]
    assert last.friction_power > 0.0 and abs(last.ledger_residual) < 1e-3, (last.friction_power, last.ledger_residual)
print("ok")
'''


def project_copy_with_a_new_friction_law(folder: Path) -> Path:
    """A copy of the packages (and pyproject.toml, which makes it a checkout) with RECIPE_EDITS applied."""
    project = Path(__file__).resolve().parents[2]
    for package in ("rotary_vane", "kernels", "thermo", "mechanics", "fmu_src"):
        shutil.copytree(project / package, folder / package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy2(project / "pyproject.toml", folder / "pyproject.toml")
    laws = folder / "mechanics" / "contact" / "contact_laws.py"
    source = laws.read_text()
    for old, new in RECIPE_EDITS:
        assert source.count(old) == 1, (f"docs/model.md §14.3 no longer matches mechanics/contact/contact_laws.py: "
                                        f"{old!r}")
        source = source.replace(old, new)
    laws.write_text(source)
    return folder


def run_with_a_new_friction_law(folder: Path, *arguments: str) -> subprocess.CompletedProcess:
    project = project_copy_with_a_new_friction_law(folder)
    environment = {**os.environ, "PYTHONPATH": str(project), "ROTARY_VANE_CACHE_DIR": str(folder / "cache")}
    return subprocess.run([sys.executable, "-c", USE_THE_NEW_LAW, str(project), *arguments], cwd=project,
                          env=environment, capture_output=True, text=True, timeout=1800)


def test_adding_a_friction_law_is_the_recipes_two_edits(tmp_path):
    """docs/model.md §14.3: a copy of the packages with a third friction law (mu min(1, |v_t|/v_0)) declared in
    FRICTION_MODELS and given its branch in friction_coefficient_effective, and no other edit, run in a fresh
    interpreter: the parameter accepts it (and names it among the allowed values when refusing another), the machine
    record carries its code, the compiled mu_eff follows it, Threlfall's law is unchanged, and the parameter table
    and the FMU parameter's description list it."""
    result = run_with_a_new_friction_law(tmp_path)
    assert result.returncode == 0 and result.stdout.strip().endswith("ok"), result.stderr[-3000:]


@pytest.mark.slow
def test_a_run_with_a_new_friction_law_closes_its_energy_ledger(tmp_path):
    """docs/model.md §14.3 step 3: two revolutions with the friction law the recipe added (every kernel compiled
    afresh for the copy) dissipate friction power and close the energy ledger within the issue bound."""
    result = run_with_a_new_friction_law(tmp_path, "run")
    assert result.returncode == 0 and result.stdout.strip().endswith("ok"), result.stderr[-3000:]
