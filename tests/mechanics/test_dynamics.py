"""Dynamic runs: docs/model.md §11 T9-T18 (no-clearance kinematics, energy and torque balances, steady state, lobe
periodicity, clearance and speed trends, convergence, start-up, integrator agreement)."""
import functools
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed, cycloidal_ramp
from rotary_vane.mechanics.geometry.displacement import displacement
from rotary_vane.mechanics.geometry.stator import law_arguments
from rotary_vane.mechanics.loop.outputs import REAL_GAS_COLUMNS
from rotary_vane.mechanics.performance import lobes, revolutions
from rotary_vane.mechanics.contact.regions import REGION_COUNT

CLEARANCES = (0.0, 0.02e-3, 0.05e-3, 0.1e-3, 0.2e-3)
INTEGRATORS = ("dopri5", "abm4")


@functools.lru_cache(maxsize=None)
def run(clearance=0.0, rpm=1500.0, integrator="dopri5", relative_tolerance=1e-6, revolutions_=4.2, **overrides):
    """The §10 reference run: constant speed from theta0 = 0.02 rad, cR = cS = clearance, Level 0.5."""
    params = CompressorParameters(slot_clearance=clearance, stator_clearance=clearance, integrator=integrator,
                                  relative_tolerance=relative_tolerance,
                                  tolerance_scale=relative_tolerance / 1e-6, **overrides)
    simulation = Simulation(params, constant_speed(rpm), initial_angle=0.02)
    simulation.advance(revolutions_ * 60.0 / rpm)
    return simulation


def last_revolution_rows(simulation):
    """Index range of the last complete revolution in the history."""
    summary = revolutions(simulation)[-1]
    time = simulation.history["time"]
    return np.flatnonzero((time >= summary.start_time) & (time <= summary.end_time))


def time_rms(values, time):
    """Root mean square over time (adaptive steps cluster at transients: an unweighted mean would over-count them)."""
    return math.sqrt(np.trapezoid(values ** 2, time) / (time[-1] - time[0]))


def nominal(simulation, angle, omega, theta_ddot=0.0):
    """s, s' omega, s'' omega^2 + s' theta_ddot of the nominal law at rotor angles `angle` (docs/model.md §3.4)."""
    law = law_arguments(simulation.params)[:5]
    values = np.array([displacement(a, *law)[:3] for a in angle])
    return values[:, 0], values[:, 1] * omega, values[:, 2] * omega ** 2 + values[:, 1] * theta_ddot


def test_no_clearance_follows_the_nominal_law():
    """T9: at c = 0 the vane follows the displacement law closely and barely tilts."""
    simulation = run(0.0)
    rows = last_revolution_rows(simulation)
    h = simulation.history
    angle, omega = h["rotor_angle"][rows], h["rotor_speed"][rows]
    s, v, a = nominal(simulation, angle, omega)
    assert np.max(np.abs(h["vane_displacement"][rows] - s)) <= 20e-6
    assert np.max(np.abs(h["vane_radial_velocity"][rows] - v)) <= 0.05 * np.max(np.abs(v))
    error = h["vane_radial_acceleration"][rows] - a
    assert time_rms(error, h["time"][rows]) <= 0.20 * np.max(np.abs(a))
    assert np.max(np.abs(h["vane_tilt"][rows])) <= 2e-3


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("clearance", CLEARANCES)
def test_energy_balance_every_revolution(clearance, integrator):
    """T10: W_in - W_out - W_fric - W_damp - dKE - dPE - J2 int(omega theta_ddot) within 0.5 % of W_in."""
    for summary in revolutions(run(clearance, integrator=integrator)):
        assert abs(summary.energy_residual) <= 5e-3


def test_energy_balance_during_start_up():
    """T10 during the speed ramp, where J2 omega theta_ddot is not zero."""
    simulation = start_up(0.05e-3)
    summaries = revolutions(simulation)
    assert len(summaries) >= 10
    for summary in summaries:
        assert abs(summary.energy_residual) <= 5e-3


def test_torque_balance_at_zero_clearance():
    """T11 as stated: |<T_d> - <lambda3 + M_gas,stator>| <= 2 % of <T_d>."""
    assert revolutions(run(0.0))[-1].torque_balance_error <= 0.02


@pytest.mark.parametrize("clearance", CLEARANCES)
def test_torque_balance_with_gap_moments(clearance):
    """T11 at every clearance, with the pressure moment on the tip, valley and mouth gaps that no body carries."""
    summary = revolutions(run(clearance))[-1]
    assert summary.torque_balance_error_with_gaps <= 0.02
    assert summary.torque_balance_error_with_gaps < summary.torque_balance_error or clearance == 0.0


def test_steady_state_reached():
    """T12: <P_in> of revolutions 2 and 3 differ by less than 1 %."""
    first, second = revolutions(run(0.0))[:2]
    assert abs(first.input_power - second.input_power) < 0.01 * first.input_power


@pytest.mark.parametrize("lobe_count", (3, 5))
def test_lobes_are_alike(lobe_count):
    """T13: at steady state the z per-lobe means of P_in agree within 2 %, per-lobe max F_n within 5 %."""
    simulation = run(0.0, lobes=lobe_count)
    per_lobe = lobes(simulation)[-lobe_count:]
    powers = np.array([lobe.input_power for lobe in per_lobe])
    peaks = np.array([max(lobe.max_normal_force) for lobe in per_lobe])
    assert np.ptp(powers) <= 0.02 * np.mean(powers)
    assert np.ptp(peaks) <= 0.05 * np.mean(peaks)


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_clearance_trends(integrator):
    """T14 (Level 0.5): efficiency, input and output power fall, friction power does not, peak force and tilt rise
    as clearance grows from 0 to 0.2 mm, and no clearance has fewer distinct modes than c = 0. (Since the impact
    velocity is taken at the located onset, docs/model.md §5.1, the slot corners at c = 0 lift off for 12-80 us a few
    times per revolution under DOPRI5: 9 modes at c = 0 as at 0.05 and 0.1 mm, against 11 and 12 at 0.02 and
    0.2 mm; the earlier rule gave 5 at c = 0.)"""
    results = [revolutions(run(c, integrator=integrator))[-1] for c in CLEARANCES]
    efficiency = [r.mechanical_efficiency for r in results]
    power_in = [r.input_power for r in results]
    power_out = [r.output_power for r in results]
    friction = [r.friction_power for r in results]
    tilt = [r.max_tilt for r in results]
    assert all(np.diff(efficiency) < 0), efficiency
    assert all(np.diff(power_in) < 0), power_in
    assert all(np.diff(power_out) < 0), power_out
    assert all(np.diff(friction) >= 0), friction
    assert all(len(r.distinct_modes) >= len(results[0].distinct_modes) for r in results[1:])
    assert max(results[-1].max_normal_force) > max(results[0].max_normal_force)
    assert all(np.diff(tilt) > 0), tilt


def test_speed_trends():
    """T15: at c = 0, input, output and friction power rise with speed; efficiency spread < 2 points."""
    results = [revolutions(run(0.0, rpm=rpm))[-1] for rpm in (1000.0, 1500.0, 2000.0)]
    for name in ("input_power", "output_power", "friction_power"):
        values = [getattr(r, name) for r in results]
        assert all(np.diff(values) > 0), (name, values)
    efficiency = [r.mechanical_efficiency for r in results]
    assert max(efficiency) - min(efficiency) < 0.02


@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("clearance", (0.0, 0.05e-3))
def test_convergence_under_tolerance_refinement(clearance, integrator):
    """T16: halving rtol and atol changes P_in, P_out, eta by < 0.5 % and the global max F_n by < 3 %."""
    coarse = revolutions(run(clearance, integrator=integrator))[-1]
    fine = revolutions(run(clearance, integrator=integrator, relative_tolerance=0.5e-6))[-1]
    for name in ("input_power", "output_power", "mechanical_efficiency"):
        assert getattr(fine, name) == pytest.approx(getattr(coarse, name), rel=5e-3), name
    assert max(fine.max_normal_force) == pytest.approx(max(coarse.max_normal_force), rel=0.03)


@functools.lru_cache(maxsize=None)
def start_up(clearance):
    """The thesis's start-up: cycloidal ramp 0 -> 1500 rpm over 0.4 s from rest at theta0 = 0, run to 1.2 s."""
    params = CompressorParameters(slot_clearance=clearance, stator_clearance=clearance)
    simulation = Simulation(params, cycloidal_ramp(1500.0, 0.4), initial_angle=0.0)
    simulation.advance(1.2)
    return simulation


@pytest.mark.parametrize("clearance", (0.0, 0.05e-3))
def test_start_up(clearance):
    """T17: no NaN, every penetration below 50 um, the contact angle inside the tip arc, the vane never
    bottoms (the run would stop), and the acceleration is noisier at the start than at steady speed."""
    simulation = start_up(clearance)
    h = simulation.history
    assert simulation.time == 1.2
    regions = range(1, REGION_COUNT + 1)
    penetrations = [f"penetration_{k}" for k in regions] + [f"penetration_rate_{k}" for k in regions]
    for name in h.names:
        if name not in penetrations and name not in REAL_GAS_COLUMNS:   # NaN: not applicable/modelled
            assert np.all(np.isfinite(h[name])), name
    for region in regions:
        assert np.nanmax(h[f"penetration_{region}"]) < 50e-6
    assert np.max(np.abs(h["contact_angle"])) < math.pi / 2
    angle, omega, theta_ddot = h["rotor_angle"], h["rotor_speed"], h["rotor_acceleration"]
    _, _, nominal_acceleration = nominal(simulation, angle, omega, theta_ddot)
    deviation = h["vane_radial_acceleration"] - nominal_acceleration
    time = h["time"]
    early = time <= 0.1
    late = np.arange(len(h)) >= last_revolution_rows(simulation)[0]
    assert early.sum() > 100

    def noise(selection):
        return (time_rms(deviation[selection], time[selection]),
                time_rms(nominal_acceleration[selection], time[selection]))

    (early_deviation, early_signal), (late_deviation, late_signal) = noise(early), noise(late)
    # relative to the signal the start is far noisier at every clearance ("unstable" in the thesis)
    assert early_deviation / early_signal > 10.0 * late_deviation / late_signal
    if clearance == 0.0:
        # T17 as stated, in absolute terms; with clearance the steady-state rattle in the slot is larger
        assert early_deviation > late_deviation


def test_abm4_agrees_with_a_tight_reference():
    """T18: ABM4 (docs/model.md §8.2) and Dormand-Prince at rtol 1e-9 give run(0.05) powers within 0.5 %; after the
    dwell filter their mode sets differ by at most one mode."""
    abm4 = revolutions(run(0.05e-3, integrator="abm4"))[-1]
    reference = revolutions(run(0.05e-3, integrator="dopri5", relative_tolerance=1e-9))[-1]
    for name in ("input_power", "output_power", "friction_power"):
        assert getattr(abm4, name) == pytest.approx(getattr(reference, name), rel=5e-3), name
    assert len(set(abm4.distinct_modes) ^ set(reference.distinct_modes)) <= 1
