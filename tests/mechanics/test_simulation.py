"""The Simulation object as the FMU and the studies use it: advancing in pieces under a held or interpolated
speed, save/restore, errors, and the alternative models (laws, contact and friction options, Level 0)."""
import json
import math

import numpy as np
import pytest

from rotary_vane.mechanics import (CompressorParameters, IntegrationError, Simulation, constant_speed, cycloidal_ramp,
                       linear_ramp)
from rotary_vane.mechanics.performance import revolutions
from rotary_vane.mechanics.contact.regions import REGION_COUNT
from rotary_vane.mechanics.loop.speed import RPM

REVOLUTION = 0.04          # s at 1500 rpm


def test_advancing_in_pieces_matches_one_advance():
    """An FMU advances once per communication step; the physics must not depend on the step."""
    params = CompressorParameters(slot_clearance=0.02e-3, stator_clearance=0.02e-3)
    whole = Simulation(params)
    whole.advance(3.2 * REVOLUTION)
    pieces = Simulation(params)
    for end in np.arange(1, 1281) * 1e-4:
        pieces.advance(float(end), speed_rpm=1500.0)
    assert pieces.time == pytest.approx(whole.time, abs=1e-15)
    reference, chunked = revolutions(whole)[-1], revolutions(pieces)[-1]
    for name in ("input_power", "output_power", "friction_power"):
        assert getattr(chunked, name) == pytest.approx(getattr(reference, name), rel=1e-3), name


def test_interpolated_speed_over_advances_is_a_linear_ramp():
    """advance(t, speed_rpm, interpolate=True) moves the speed linearly over the advance: piecewise it must
    reproduce the closed-form linear ramp (rotor angle exactly, work to integration accuracy)."""
    params = CompressorParameters(pressure_model="polytropic")      # a table that does not depend on speed
    ramp = Simulation(params, linear_ramp(1500.0, 0.1, start_rpm=500.0), initial_angle=0.0)
    ramp.advance(0.1)
    pieces = Simulation(params, constant_speed(500.0), initial_angle=0.0)
    for k in range(1, 11):
        pieces.advance(0.01 * k, speed_rpm=500.0 + 100.0 * k, interpolate=True)
    assert pieces.rotor_angle == pytest.approx(ramp.rotor_angle, rel=1e-12)
    assert pieces.rotor_speed == pytest.approx(1500.0 * RPM, rel=1e-12)
    assert pieces.outputs["work_in"] == pytest.approx(ramp.outputs["work_in"], rel=1e-3)


def test_held_speed_step_keeps_angle_continuous():
    """A held speed changes omega at the advance boundary; the rotor angle stays continuous."""
    sim = Simulation(CompressorParameters())
    sim.advance(0.01)
    angle = sim.rotor_angle
    sim.advance(0.01, speed_rpm=1000.0)       # zero-length advance: only sets the speed
    assert sim.rotor_angle == pytest.approx(angle, abs=1e-15)
    sim.advance(0.02)
    assert sim.rotor_angle == pytest.approx(angle + 1000.0 * RPM * 0.01, rel=1e-12)


def test_save_and_restore_reproduce_the_continuation_exactly():
    """get_state/set_state copy everything the loop depends on (integrator history, contact memory, ...)."""
    for integrator in ("dopri5", "abm4"):
        sim = Simulation(CompressorParameters(slot_clearance=0.05e-3, stator_clearance=0.05e-3,
                                              integrator=integrator))
        sim.advance(0.031)
        saved = sim.get_state()
        sim.advance(0.05)
        first = sim.state.copy(), sim.last_output.copy()
        sim.advance(0.07)                     # move on, then go back
        sim.set_state(saved)
        sim.advance(0.05)
        assert np.array_equal(sim.state, first[0])
        assert np.array_equal(sim.last_output, first[1], equal_nan=True)


def test_instances_are_independent():
    """Two simulations interleaved give the same result as each one alone."""
    params = CompressorParameters(slot_clearance=0.05e-3, stator_clearance=0.05e-3)
    alone = Simulation(params)
    for end in (0.01, 0.02, 0.03):
        alone.advance(end)
    a, b = Simulation(params), Simulation(params.replace(slot_clearance=0.0, stator_clearance=0.0))
    for end in (0.01, 0.02, 0.03):
        a.advance(end)
        b.advance(end)
    assert np.array_equal(a.state, alone.state)


def test_numerical_failure_raises_integration_error_with_time_and_state():
    """A run the model cannot carry (15000 rpm behind a 5 mm2 discharge port: the leading chamber over-compresses
    out of the fluid's property table, to 8 p_d at 1.1 ms) stops with IntegrationError carrying the time, the state
    and a message that names the port parameters."""
    params = CompressorParameters(slot_clearance=0.05e-3, stator_clearance=0.05e-3, discharge_port_area=5e-6)
    sim = Simulation(params, constant_speed(15000.0))
    with pytest.raises(IntegrationError) as failure:
        sim.advance(0.05)
    assert 0.0 < failure.value.time < 0.05
    assert failure.value.state.shape == sim.state.shape
    assert np.all(np.isfinite(failure.value.state))
    assert "discharge_port_area" in str(failure.value)


@pytest.mark.parametrize("bad", [dict(end_time=-1.0), dict(end_time=math.nan), dict(end_time=0.1, speed_rpm=-5.0),
                                 dict(end_time=0.1, speed_rpm=math.inf)])
def test_bad_advance_arguments_are_refused_before_any_work(bad):
    sim = Simulation(CompressorParameters())
    state = sim.state.copy()
    with pytest.raises(ValueError) as error:
        sim.advance(**bad)
    assert ("speed_rpm" in str(error.value)) or ("end_time" in str(error.value))
    assert "allowed" in str(error.value)
    assert np.array_equal(sim.state, state) and sim.time == 0.0


def test_ideal_gas_table_needs_an_operating_speed():
    with pytest.raises(ValueError, match="operating speed"):
        Simulation(CompressorParameters(pressure_model="ideal_gas_table"), constant_speed(0.0))


@pytest.mark.parametrize("changes", [
    dict(displacement_law="cycloidal"),
    dict(displacement_law="polynomial_345"),
    dict(displacement_law="harmonic_dwell", bottom_dwell=0.1, top_dwell=0.1),
    dict(stiffness_model="johnson_line"),
    dict(friction_model="ambrosio", friction_velocity=1e-4, friction_velocity_full=1e-3),
    dict(pressure_model="polytropic"),
    dict(lobes=5), dict(lobes=7), dict(lobes=9),
])
def test_alternative_models_run_and_conserve_energy(changes):
    """Every option runs two revolutions at c = 0.05 mm and closes the energy balance (docs/model.md §6.4)."""
    params = CompressorParameters(slot_clearance=0.05e-3, stator_clearance=0.05e-3, **changes)
    sim = Simulation(params)
    sim.advance(2.2 * REVOLUTION)
    summary = revolutions(sim)[-1]
    assert abs(summary.energy_residual) < 5e-3
    assert 0.3 < summary.mechanical_efficiency < 0.95


def test_start_up_ramp_end_is_an_event():
    """The cycloidal ramp ends exactly at t_r: a step lands there and omega is the target from then on."""
    sim = Simulation(CompressorParameters(), cycloidal_ramp(1500.0, 0.05), initial_angle=0.0)
    sim.advance(0.06)
    time = sim.history["time"]
    assert np.any(np.abs(time - 0.05) < 1e-15)
    assert sim.rotor_speed == pytest.approx(1500.0 * RPM, rel=1e-14)


def history_revolution(simulation, index):
    """Per-revolution figures computed independently of the time loop's accumulators, from the recorded rows:
    work differences between the rows at consecutive multiples of 2 pi, the largest normal force of the rows in
    between, and the dwell of each mode (each step's length to the mode at its end). The initial row (t = 0, on a
    boundary) precedes the recorded steps."""
    from rotary_vane.mechanics.simulation import History
    h = History(np.vstack([simulation.initial_output, simulation.history.rows]))
    angle, time = h["rotor_angle"], h["time"]
    boundaries = np.flatnonzero(np.abs(angle / (2 * math.pi) - np.round(angle / (2 * math.pi))) < 1e-9)
    first, last = boundaries[index], boundaries[index + 1]
    duration = time[last] - time[first]
    window = slice(first, last + 1)
    dwell = np.zeros(64)
    np.add.at(dwell, h["contact_mode"][first + 1:last + 1].astype(int), np.diff(time[window]))
    return dict(start_time=time[first], input_power=(h["work_in"][last] - h["work_in"][first]) / duration,
                max_normal_force=tuple(float(np.max(h[f"normal_force_{k}"][window])) for k in range(1, REGION_COUNT + 1)),
                distinct_modes=tuple(int(mask) for mask in np.flatnonzero(dwell >= simulation.params.mode_dwell_time)))


def test_loop_summaries_match_the_history():
    """The per-revolution figures the time loop accumulates (and an FMU reports) equal the ones computed afterwards
    from the full history, also when the run is advanced in small pieces (revolution boundaries fall inside the
    pieces), and the run-long dwell covers the whole run from the initial row at t = 0."""
    params = CompressorParameters(slot_clearance=0.05e-3, stator_clearance=0.05e-3)
    sim = Simulation(params, initial_angle=0.0)
    for end in np.arange(1, 1001) * 1.3e-4:
        sim.advance(float(end), speed_rpm=1500.0)
    summaries = revolutions(sim)
    assert len(summaries) == 3
    for index, summary in enumerate(summaries):
        expected = history_revolution(sim, index)
        assert summary.start_time == expected["start_time"]
        assert summary.input_power == pytest.approx(expected["input_power"], rel=1e-12)
        assert summary.max_normal_force == expected["max_normal_force"]
        assert summary.distinct_modes == expected["distinct_modes"]
    assert sim.last_revolution.start_time == summaries[-1].start_time
    assert sim.run_dwell.sum() == pytest.approx(sim.time, rel=1e-12)


def test_the_first_revolution_is_reported_from_a_boundary_start():
    """A run that starts on a revolution boundary (theta0 = 0, as the FMU does by default) has its first
    revolution [0, 2 pi] summarised as soon as it completes, also without keeping the history."""
    params = CompressorParameters()
    sim = Simulation(params, initial_angle=0.0, keep_history=False)
    sim.advance(1.5 * 60.0 / 1500.0)
    assert sim.last_revolution is not None
    assert sim.last_revolution.start_time == 0.0
    assert sim.last_revolution.end_time == pytest.approx(60.0 / 1500.0, rel=1e-12)


def test_integration_error_survives_pickling():
    """Process pools (studies, campaigns) send errors back pickled: reason, time and state survive."""
    import pickle

    from rotary_vane.mechanics import IntegrationError
    error = pickle.loads(pickle.dumps(IntegrationError("the step size fell below the time resolution", 0.25, np.arange(3.0))))
    assert (error.reason, error.time) == ("the step size fell below the time resolution", 0.25)
    assert np.array_equal(error.state, np.arange(3.0))
    assert "t = 0.25 s" in str(error)


def test_kernels_are_the_python_functions_without_numba_jit():
    """Under NUMBA_DISABLE_JIT=1 (debugging, stepping through the physics in a Python debugger) `@kernel` leaves the
    Python function, and the whole loop runs in pure Python: 2 ms of both pressure models (and of real gas with the
    implicit chamber states of ark548) give the compiled run's state (the same arithmetic; LLVM may contract or reorder a few operations, so to 1e-7 relative: measured 2e-9)."""
    import os
    import subprocess
    import sys
    script = ("import json, numpy as np\n"
              "from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed\n"
              "from rotary_vane.kernels.kernel import copy_values\n"
              "states = {}\n"
              "for model, method in (('ideal_gas_table', 'dopri5'), ('real_gas', 'dopri5'), ('real_gas', 'ark548')):\n"
              "    p = CompressorParameters(pressure_model=model, integrator=method, slot_clearance=5e-5,\n"
              "                             stator_clearance=5e-5)\n"
              "    s = Simulation(p, constant_speed(1500.0), keep_history=False)\n"
              "    s.advance(0.002)\n"
              "    states[model + ' ' + method] = s.state.tolist()\n"
              "print(json.dumps({'kernel': type(copy_values).__name__, 'states': states}))\n")
    runs = {}
    for jit in ("0", "1"):
        done = subprocess.run([sys.executable, "-c", script], env={**os.environ, "NUMBA_DISABLE_JIT": jit},
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-3000:]
        runs[jit] = json.loads(done.stdout.splitlines()[-1])
    assert runs["1"]["kernel"] == "function" and runs["0"]["kernel"] == "CPUDispatcher"
    for model, state in runs["0"]["states"].items():
        python_state = np.array(runs["1"]["states"][model])
        assert np.all(np.isfinite(python_state)), model
        np.testing.assert_allclose(python_state, state, rtol=1e-7, atol=1e-15, err_msg=model)
