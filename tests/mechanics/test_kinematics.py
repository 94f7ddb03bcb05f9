"""Kinematics and the equations of motion: speed input (docs/model.md §3.2), reported kinematics (docs/model.md §11 T3) and the
constraint consistency of the reduced form (T4), with the generalized forces recomputed independently from
docs/model.md §4-§6.2 (tests/reference_formulas.py)."""
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed, cycloidal_ramp, linear_ramp
from rotary_vane.mechanics.geometry.kinematics import pose_of, reported_kinematics
from rotary_vane.mechanics.loop.machine import machine_from_parameters
from rotary_vane.mechanics.contact.regions import MEMORY_SLOTS
from rotary_vane.mechanics.loop.speed import rotor_motion

RPM = 2 * math.pi / 60


def harmonic(theta, stroke, lobes):
    """s, s', s'' of docs/model.md §2.3 option 1."""
    a = 0.5 * stroke
    return (a * (1 - math.cos(lobes * theta)), a * lobes * math.sin(lobes * theta),
            a * lobes ** 2 * math.cos(lobes * theta))


# ----------------------------------------------------------------------------------------------------------
# docs/model.md §3.2: speed input


@pytest.mark.parametrize("theta0", [0.0, 0.02])
def test_speed_laws_match_closed_form(check, reference, theta0):
    omega_ss = 1500 * RPM
    constant = constant_speed(1500.0).segment(0.0, theta0)
    ramp = cycloidal_ramp(1500.0, 0.4).segment(0.0, theta0)
    worst = 0.0
    for t in np.concatenate([np.linspace(0, 0.8, 801), [0.4 - 1e-12, 0.4, 0.4 + 1e-12]]):
        for law, shape in ((constant, "constant"), (ramp, "ramp")):
            got = np.array(rotor_motion(t, law))
            expected = np.array(reference.speed_law(t, shape, omega_ss, 0.4, theta0))
            scale = np.array([omega_ss * 0.8 + 1, omega_ss, omega_ss / 0.4 * 2])
            worst = max(worst, np.max(np.abs(got - expected) / scale))
    check("speed law vs docs/model.md §3.2 closed form, rel.", worst, 1e-13)
    # theta_dot = omega and omega_dot = theta_ddot (central differences), continuous at the ramp end
    step = 1e-7
    for t in (0.05, 0.2, 0.33, 0.5):
        minus, centre, plus = (np.array(rotor_motion(t + k * step, ramp)) for k in (-1, 0, 1))
        assert abs((plus[0] - minus[0]) / (2 * step) - centre[1]) < 1e-6 * omega_ss
        assert abs((plus[1] - minus[1]) / (2 * step) - centre[2]) < 1e-6 * omega_ss / 0.4
    before, after = rotor_motion(0.4 - 1e-12, ramp), rotor_motion(0.4 + 1e-12, ramp)
    assert abs(before[0] - after[0]) < 1e-9 and abs(before[1] - after[1]) < 1e-6


def test_linear_ramp():
    law = linear_ramp(1200.0, 0.3, start_rpm=300.0).segment(0.1, 0.5)
    w0, w1 = 300 * RPM, 1200 * RPM
    for x in (0.0, 0.1, 0.25, 0.3, 0.45):
        theta, omega, acc = rotor_motion(0.1 + x, law)
        if x < 0.3:
            a = (w1 - w0) / 0.3
            expected = (0.5 + w0 * x + 0.5 * a * x * x, w0 + a * x, a)
        else:
            expected = (0.5 + w0 * 0.3 + 0.5 * (w1 - w0) * 0.3 + w1 * (x - 0.3), w1, 0.0)
        assert np.allclose((theta, omega, acc), expected, rtol=1e-13, atol=1e-12)


# ----------------------------------------------------------------------------------------------------------
# T3: the reported kinematics of docs/model.md §3.4 on the exact nominal trajectory


def nominal_motion(theta, omega, theta_ddot, stroke, lobes, base_radius, xi_g):
    """Exact nominal T, v_T, a_T, v_G, a_G (tilt 0, T on C(theta)), from r = R0 + s(theta) by the chain rule."""
    s, s1, s2 = harmonic(theta, stroke, lobes)
    r = base_radius + s
    er = np.array([math.cos(theta), math.sin(theta)])
    et = np.array([-er[1], er[0]])
    r_dot = s1 * omega
    r_ddot = s2 * omega ** 2 + s1 * theta_ddot

    def polar(radius):
        return (radius * er, r_dot * er + radius * omega * et,
                (r_ddot - radius * omega ** 2) * er + (2 * r_dot * omega + radius * theta_ddot) * et)

    tip = polar(r)
    cg = polar(r + xi_g)
    expected = (s, s1 * omega, s2 * omega ** 2 + s1 * theta_ddot, (r + xi_g) * omega,
                (r + xi_g) * theta_ddot + 2 * s1 * omega ** 2)
    return tip, cg, expected


def reported_along(times, shape, lobes, rpm=1500.0, reference=None, theta0=0.02):
    """The kernel's reported kinematics of the exact nominal motion (untilted vane, phi = theta, the CG at
    xi_G = -xi_T behind the tip centre) against the closed forms."""
    p = CompressorParameters(lobes=lobes)
    m = machine_from_parameters(p)
    got, expected = [], []
    for t in times:
        theta, omega, theta_ddot = reference.speed_law(t, shape, rpm * RPM, 0.4, theta0)
        _, (cg, v_cg, a_cg), nominal = nominal_motion(theta, omega, theta_ddot, p.stroke, lobes, p.base_radius,
                                                      -m.tip_centre)
        vane = pose_of(*cg, theta, theta, m, *v_cg, omega, omega, theta_ddot)
        got.append(reported_kinematics(vane, *a_cg, theta_ddot, m))
        expected.append(nominal)
    return np.array(got), np.array(expected)


@pytest.mark.parametrize("shape", ["constant", "ramp"])
@pytest.mark.parametrize("lobes", [3, 7])
def test_reported_kinematics_on_nominal_trajectory(check, reference, shape, lobes):
    """s_r, v_r, a_r, v_theta, a_theta equal s, s' w, s'' w^2 + s' theta_ddot, r_G w, r_G theta_ddot + 2 s' w^2
    (1e-9 relative to each quantity's peak over the samples), at constant speed and through the cycloidal ramp."""
    times = np.linspace(0.0, 0.04, 1001) if shape == "constant" else np.linspace(1e-3, 0.6, 3001)
    got, expected = reported_along(times, shape, lobes, reference=reference)
    peaks = np.max(np.abs(expected), axis=0)
    worst = np.max(np.abs(got - expected) / peaks)
    check("T3 reported kinematics vs nominal, rel. to peak", worst, 1e-9)
    if shape == "ramp":
        assert np.max(np.abs(expected[:, 4])) > 0          # theta_ddot really entered a_theta


def test_reported_kinematics_peaks_1500rpm(check, reference):
    """docs/model.md §11 T3: 1500 rpm, z = 3: max s = 5 mm, max v_r = 1.178 m/s, max a_r = 555.2 m/s^2."""
    period = 2 * math.pi / (1500 * RPM)
    # 12000 intervals per revolution from theta0 = 0 include the peaks of s, v_r and a_r (theta = k pi/6)
    got, _ = reported_along(np.linspace(0, period, 12001), "constant", 3, reference=reference, theta0=0.0)
    check("T3 max s_r - 5 mm [m]", abs(got[:, 0].max() - 5e-3), 1e-12)
    check("T3 max v_r - 1.178 m/s", abs(got[:, 1].max() - 1.178), 0.0005)
    check("T3 max a_r - 555.2 m/s2", abs(got[:, 2].max() - 555.2), 0.05)


def test_reported_kinematics_are_time_derivatives(check, reference):
    """Off the nominal path (lateral and radial wobble of T, theta_ddot != 0): v_r and a_r are the first and second
    time derivatives of s_r = T.e_r(theta) - R0 (5-point central differences along the trajectory)."""
    p = CompressorParameters()
    m = machine_from_parameters(p)
    omega_ss = 1500 * RPM

    def motion(t):
        theta, omega, theta_ddot = reference.speed_law(t, "ramp", omega_ss, 0.4, 0.0)
        er = np.array([math.cos(theta), math.sin(theta)])
        et = np.array([-er[1], er[0]])
        radial = p.base_radius + harmonic(theta, p.stroke, p.lobes)[0] + 20e-6 * math.sin(900 * t)
        return radial * er + 30e-6 * math.cos(1300 * t) * et, (theta, omega, theta_ddot)

    def derivatives(f, t, step):
        v = [np.asarray(f(t + k * step)) for k in (-2, -1, 0, 1, 2)]
        first = (v[0] - 8 * v[1] + 8 * v[3] - v[4]) / (12 * step)
        second = (-v[0] + 16 * v[1] - 30 * v[2] + 16 * v[3] - v[4]) / (12 * step ** 2)
        return v[2], first, second

    def reported(t, step=2e-6):
        """The kernel's s_r, v_r, a_r of a vane translating with its tip centre T (phi = 0, no rotation)."""
        tip, v_tip, a_tip = derivatives(lambda x: motion(x)[0], t, step)
        theta, omega, theta_ddot = motion(t)[1]
        vane = pose_of(tip[0] - m.tip_centre, tip[1], 0.0, theta, m, *v_tip, 0.0, omega, theta_ddot)
        return reported_kinematics(vane, *a_tip, 0.0, m)

    worst_v = worst_a = 0.0
    for t in np.linspace(0.05, 0.35, 25):
        s_r, v_r, a_r = reported(t)[:3]
        _, ds, dds = derivatives(lambda x: reported(x)[0], t, 2e-6)
        worst_v = max(worst_v, abs(v_r - ds) / 1.2)           # peaks: v_r ~ 1.2 m/s, a_r ~ 600 m/s^2
        worst_a = max(worst_a, abs(a_r - dds) / 600.0)
    check("T3 v_r vs d s_r/dt (FD), rel. to peak", worst_v, 1e-6)
    check("T3 a_r vs d2 s_r/dt2 (FD), rel. to peak", worst_a, 1e-6)


@pytest.mark.parametrize("shape", ["constant", "ramp"])
def test_evaluate_reports_nominal_kinematics(check, reference, kernel, shape):
    """The kernel maps a nominal state (untilted, T on C, nominal velocity) to the nominal s_r, v_r, v_theta and
    tilt 0 (1e-9 relative to the peaks)."""
    p = CompressorParameters()
    speed = constant_speed(1500.0) if shape == "constant" else cycloidal_ramp(1500.0, 0.4)
    sim = Simulation(p, speed, initial_angle=0.02)
    xi_t = sim.machine.tip_centre
    rows = []
    for t in (np.linspace(0, 0.04, 97) if shape == "constant" else np.linspace(0.01, 0.5, 97)):
        theta, omega, theta_ddot = reference.speed_law(t, shape, 1500 * RPM, 0.4, 0.02)
        (tip, v_tip, _), (cg, v_cg, _), nominal = nominal_motion(theta, omega, theta_ddot, p.stroke, p.lobes,
                                                                 p.base_radius, -xi_t)
        state = (*cg, theta, *v_cg, omega)
        _, _, out = kernel.evaluate_at(sim, t, state)
        rows.append(([out["vane_displacement"], out["vane_radial_velocity"], out["vane_tangential_velocity"],
                      out["vane_tilt"], out["rotor_angle"]], [nominal[0], nominal[1], nominal[3], 0.0, theta]))
    got = np.array([r[0] for r in rows])
    expected = np.array([r[1] for r in rows])
    peaks = np.maximum(np.max(np.abs(expected), axis=0), [1e-3, 1.0, 1.0, 1e-3, 1.0])
    check("T3 kernel outputs s_r, v_r, v_theta, tilt at nominal state, rel.",
          np.max(np.abs(got - expected) / peaks), 1e-9)


# ----------------------------------------------------------------------------------------------------------
# T4: augmented 15x15 system vs the reduced form, with independently recomputed generalized forces

PARAMETER_CASES = {    # with the Level 0.5 pressure table, whose pressures the independent reference reads
    "clearance_0.05mm": dict(slot_clearance=0.05e-3, stator_clearance=0.05e-3, pressure_model="ideal_gas_table"),
    "no_clearance": dict(pressure_model="ideal_gas_table"),
    "z5_ambrosio": dict(lobes=5, slot_clearance=0.1e-3, stator_clearance=0.1e-3, friction_model="ambrosio",
                        friction_velocity=1e-4, friction_velocity_full=1e-3, pressure_model="ideal_gas_table"),
}


def random_states(sim, count, seed, reference):
    """Random small perturbations of the nominal pose (tip offset along e_r and e_theta, tilt) with random
    velocities, at random times of the cycloidal ramp (theta_ddot > 0); a third of them near a valley, where the
    tip sits in the slot mouth (candidates B/C)."""
    p = sim.params
    rng = np.random.default_rng(seed)
    xi_t = sim.machine.tip_centre
    half_gap = 0.5 * p.slot_clearance
    states = []
    for k in range(count):
        t = rng.uniform(0.02, 0.38)
        theta, omega, theta_ddot = reference.speed_law(t, "ramp", 1500 * RPM, 0.4, 0.0)
        if k % 3 == 0:    # move the time so that theta is close to a valley
            lobe = 2 * math.pi / p.lobes
            target = round(theta / lobe) * lobe + rng.uniform(-0.15, 0.15)
            lo, hi = 0.01, 0.39
            for _ in range(100):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if reference.speed_law(mid, "ramp", 1500 * RPM, 0.4, 0.0)[0] < target else (lo, mid)
            t = hi
            theta, omega, theta_ddot = reference.speed_law(t, "ramp", 1500 * RPM, 0.4, 0.0)
        s, s1, _ = harmonic(theta, p.stroke, p.lobes)
        tilt = rng.uniform(-1e-3, 1e-3)
        phi = theta + tilt
        er = np.array([math.cos(theta), math.sin(theta)])
        et = np.array([-er[1], er[0]])
        tip = ((p.base_radius + s + p.stator_clearance + rng.uniform(-10e-6, 20e-6)) * er
               + rng.uniform(-half_gap - 15e-6, half_gap + 15e-6) * et)
        cg = tip - xi_t * np.array([math.cos(phi), math.sin(phi)])
        r_g = p.base_radius + s - xi_t
        velocity = s1 * omega * er + r_g * omega * et + rng.uniform(-0.05, 0.05, 2)
        onset = np.where(rng.uniform(size=MEMORY_SLOTS) < 0.5, 0.0, rng.uniform(0.02, 0.5, MEMORY_SLOTS))
        states.append((t, theta, omega, theta_ddot, np.array([*cg, phi, *velocity, omega + rng.uniform(-5, 5)]),
                       onset))
    return states


def augmented_solution(masses, q, gamma_theta):
    """Solve [M Phi_q^T; Phi_q 0][q_ddot; lambda] = [Q; gamma] (docs/model.md §3.1) with numpy."""
    m1, j1, m2, j2, m3, j3 = masses
    mass = np.diag([m1, m1, j1, m2, m2, j2, m3, m3, j3])
    jacobian = np.zeros((6, 9))
    jacobian[:, :6] = np.eye(6)
    system = np.zeros((15, 15))
    system[:9, :9] = mass
    system[:9, 9:] = jacobian.T
    system[9:, :9] = jacobian
    rhs = np.concatenate([q, [0, 0, 0, 0, 0, gamma_theta]])
    solution = np.linalg.solve(system, rhs)
    return solution[:9], solution[9:]


@pytest.mark.parametrize("case", list(PARAMETER_CASES))
def test_augmented_system_equals_reduced_form(check, reference, contact_reference, kernel, case):
    """T4: at random perturbed states during the ramp (theta_ddot != 0), the applied forces Q1, Q2, Q3 recomputed
    independently from docs/model.md §4-§6.2 and put through the 15x15 augmented solve give the kernel's q_ddot3
    (dydt[3:6]) and lambda (stator reactions = stator_force_x/y, stator_contact_moment; rotor pin reactions =
    rotor_force_x/y, lambda6 = -driving_torque), to 1e-10 relative."""
    p = CompressorParameters(**PARAMETER_CASES[case])
    sim = Simulation(p, cycloidal_ramp(1500.0, 0.4), initial_angle=0.0)
    m = sim.machine
    masses = (7.5, 0.04, 1.22, p.rotor_inertia, m.vane_mass, m.vane_inertia)   # stator/rotor mass arbitrary
    regions_seen = set()
    worst_q3 = worst_lambda = worst_tip_moment = worst_power = worst_self = 0.0
    for t, theta, omega, theta_ddot, state, onset in random_states(sim, 60, seed=len(case), reference=reference):
        status, dydt, out = kernel.evaluate_at(sim, t, state, onset)
        assert status == 0
        assert abs(out["rotor_angle"] - theta) < 1e-12 and abs(out["rotor_acceleration"] - theta_ddot) < 1e-9
        pressures = (out["leading_pressure"], out["trailing_pressure"], p.discharge_pressure)
        ref = contact_reference.forces(p, m.tip_centre, state, theta, omega, onset, pressures)
        regions_seen.update(d["region"] for d in ref.details if d is not None)
        q = np.concatenate([ref.q1, ref.q2, ref.q3])
        q_ddot, lam = augmented_solution(masses, q, theta_ddot)
        # bodies 1 and 2 follow their constraints exactly
        assert np.allclose(q_ddot[:6], [0, 0, 0, 0, 0, theta_ddot], rtol=0, atol=1e-12 * abs(theta_ddot))
        assert theta_ddot > 0
        # tolerances relative to the applied forces (sum of their magnitudes F_s) and moments F_s l_v
        force_scale = ref.force_scale
        moment_scale = force_scale * p.vane_length
        inertia = np.array([m.vane_mass, m.vane_mass, m.vane_inertia])
        scale = np.array([force_scale, force_scale, moment_scale])
        worst_q3 = max(worst_q3, np.max(np.abs(q_ddot[6:] - np.array(dydt[3:6])) * inertia / scale))
        kernel_lambda = np.array([out["stator_force_x"], out["stator_force_y"], out["stator_contact_moment"],
                                  out["rotor_force_x"], out["rotor_force_y"], -out["driving_torque"]])
        scale = np.array([force_scale, force_scale, moment_scale, force_scale, force_scale, moment_scale])
        worst_lambda = max(worst_lambda, np.max(np.abs(lam - kernel_lambda) / scale))
        # lambda3 = moment about O of minus the tip contact force (the only stator contact)
        tip = [d for d in ref.details if d is not None and d["region"] >= 4]
        expected_moment = -contact_reference.cross(tip[0]["P"], tip[0]["force"]) if tip else 0.0
        worst_tip_moment = max(worst_tip_moment, abs(out["stator_contact_moment"] - expected_moment)
                               / max(abs(expected_moment), 1e-3))
        # powers of docs/model.md §6.4 and the stator gas moment
        powers = np.array([dydt[7], dydt[8], dydt[9], out["stator_gas_moment"]])
        expected_powers = np.array([-ref.gas_power, ref.friction_power, ref.damping_power, ref.stator_gas_moment])
        power_scale = np.array([abs(ref.gas_power), ref.friction_power, abs(ref.damping_power),
                                abs(ref.stator_gas_moment)]) + [1e-3, 1e-3, 1e-3, 1e-6]
        worst_power = max(worst_power, np.max(np.abs(powers - expected_powers) / power_scale))
        # the same solve fed with the kernel's own generalized forces (Q3 = M3 dydt[3:6], Q1 = stator outputs,
        # Q2 = rotor outputs with Q2phi = J2 theta_ddot - T_d) reproduces its q_ddot3 and lambda
        q_kernel = np.concatenate([kernel_lambda[:3], kernel_lambda[3:5],
                                   [p.rotor_inertia * theta_ddot - out["driving_torque"]], inertia * dydt[3:6]])
        q_ddot_k, lam_k = augmented_solution(masses, q_kernel, theta_ddot)
        worst_self = max(worst_self, np.max(np.abs(q_ddot_k[6:] - dydt[3:6]) * inertia / scale[:3]),
                         np.max(np.abs(lam_k - kernel_lambda) / scale))
        # input power = T_d omega
        assert abs(dydt[6] - out["driving_torque"] * omega) <= 1e-12 * abs(dydt[6]) + 1e-12
    check("T4 q_ddot3 augmented (independent Q) vs kernel, rel. to sum|F|", worst_q3, 1e-10)
    check("T4 lambda augmented (independent Q) vs kernel outputs, rel. to sum|F|", worst_lambda, 1e-10)
    check("T4 augmented solve with the kernel's own Q vs reduced form, rel. to sum|F|", worst_self, 1e-10)
    check("T4 lambda3 vs moment of -F_tip (recomputed), rel.", worst_tip_moment, 1e-10)
    check("T4 P_out, P_fric, P_damp, M_gas,stator vs independent, rel.", worst_power, 1e-10)
    # the random states exercised every region (and the tip on both quarters where the geometry allows)
    assert {0, 1, 2, 3} <= regions_seen
    assert regions_seen & {4, 5}
