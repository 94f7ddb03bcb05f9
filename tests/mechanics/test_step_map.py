"""The one-step map an iterating co-simulation master sees (issue 24 item 6, docs/model.md §8.2 "Events" and
"Step-grid replay"): from a restored state, one 1 ms advance at neighbouring held speeds must give a shaft torque
that changes smoothly with the speed. benchmarks/bench_step_map.py measures the full version (201 speeds, both
pressure models, two tolerances, and the boundary inputs)."""
import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.loop.integrators import ACCEPTED, CONTROL_STEP, CONTROL_STIFFNESS, STABILITY_LIMIT
from rotary_vane.mechanics.loop.layout import GAS_BLOCK, WORK_IN

STEP = 1e-3
SPEEDS = 1500.0 + np.linspace(-0.01, 0.01, 21)      # rpm, 1e-3 rpm apart


def level_half_run():
    params = CompressorParameters(stator_clearance=0.05e-3, rotor_inertia=0.0, pressure_model="ideal_gas_table")
    simulation = Simulation(params, keep_history=False)
    simulation.advance(0.05)
    return simulation


def torques_and_steps(simulation, saved, speeds):
    """shaft_torque_mean (as the FMU computes it) and accepted steps of one STEP advance per speed from `saved`."""
    torques, steps = [], []
    for speed in speeds:
        simulation.set_state(saved)
        work, angle, accepted = simulation.state[WORK_IN], simulation.rotor_angle, simulation.counters[ACCEPTED]
        simulation.advance(saved.time + STEP, speed_rpm=speed)
        torques.append((simulation.state[WORK_IN] - work) / (simulation.rotor_angle - angle))
        steps.append(simulation.counters[ACCEPTED] - accepted)
    return np.array(torques), steps


def test_the_torque_of_one_step_is_smooth_in_the_speed_from_restored_states():
    """Three consecutive states, 21 speeds in +-0.01 rpm: the torque's change between neighbours departs from its
    median (the map's slope, ~3e-6 N.m per 1e-3 rpm) by at most 1e-6 N.m, and every speed takes the same steps.
    Before the located contact events and the grid replay the first state jumped by 1.2e-5 N.m (a step more or
    less, and the impact velocity taken at whichever step first fell inside a contact)."""
    simulation = level_half_run()
    for _ in range(3):
        saved = simulation.get_state()
        torques, steps = torques_and_steps(simulation, saved, SPEEDS)
        changes = np.diff(torques)
        assert np.abs(changes - np.median(changes)).max() <= 1e-6, changes
        assert len(set(steps)) == 1, steps
        simulation.set_state(saved)
        simulation.advance(saved.time + STEP, speed_rpm=1500.0)


def test_the_real_gas_torque_of_one_step_is_smooth_in_the_speed_with_dormand_prince():
    """Real gas with the default Dormand-Prince at the default tolerances, ten consecutive states, 21 speeds in
    +-0.01 rpm: the torque's change between neighbours departs from its state's median by at most 1e-5 N.m (the
    benchmark's bound on the worst jump is 1e-4 N.m; measured 5e-10). The step control keeps h rho, rho the
    stiffness estimated along each step, inside Dormand-Prince's stability region (docs/model.md §8.2); without
    that cap the replayed explicit steps amplified round-off in the small leading chamber, and these states departed
    by up to 1.9e-4 N.m. The step count is not checked here: in one of these states (367-370 steps in 1 ms) a landed
    contact event crosses a recorded step end within the speed range, which adds a step without moving the torque."""
    params = CompressorParameters(stator_clearance=0.05e-3, rotor_inertia=0.0)
    simulation = Simulation(params, keep_history=False)
    simulation.advance(0.1)
    worst = 0.0
    for _ in range(10):
        saved = simulation.get_state()
        torques, _ = torques_and_steps(simulation, saved, SPEEDS)
        changes = np.diff(torques)
        worst = max(worst, np.abs(changes - np.median(changes)).max())
        simulation.set_state(saved)
        simulation.advance(saved.time + STEP, speed_rpm=1500.0)
    assert worst <= 1e-5, worst


@pytest.mark.parametrize("model, integrator, capped", [("real_gas", "dopri5", True),
                                                       ("ideal_gas_table", "dopri5", False),
                                                       ("real_gas", "ark548", False)])
def test_the_stability_cap_bounds_the_proposed_step_where_there_are_chamber_states(model, integrator, capped):
    """docs/model.md §8.2: after every advance of a real-gas Dormand-Prince run the proposed step keeps h rho within
    STABILITY_LIMIT, and over a revolution the cap binds (h rho at the limit) at some step ends; the pressure-table
    models and ark548 (the chamber states implicit) keep no stiffness estimate and no cap."""
    params = CompressorParameters(stator_clearance=0.05e-3, pressure_model=model, integrator=integrator)
    simulation = Simulation(params, keep_history=False)
    products = []
    for k in range(1, 201):                        # 40 ms, one revolution at 1500 rpm, in 0.2 ms advances
        simulation.advance(k * 2e-4)
        products.append(simulation.control[CONTROL_STEP] * simulation.control[CONTROL_STIFFNESS])
    if capped:
        assert max(products) <= STABILITY_LIMIT * (1.0 + 1e-12)
        assert sum(p >= STABILITY_LIMIT * (1.0 - 1e-9) for p in products) >= 1, max(products)
    else:
        assert max(products) == 0.0


def implicit_chambers_run():
    params = CompressorParameters(stator_clearance=0.05e-3, rotor_inertia=0.0, pressure_model="real_gas",
                                  integrator="ark548")
    simulation = Simulation(params, keep_history=False)
    simulation.advance(0.05)
    return simulation


def test_with_the_chamber_states_implicit_the_real_gas_map_is_smooth_too():
    """Real gas with ark548 (the chamber states implicit, docs/model.md §8.2): one state, 21 speeds in +-0.01 rpm,
    with no stability cap (the stiff chamber states are implicit): the change between neighbours departs from its
    median by at most 1e-5 N.m, the bound of the Dormand-Prince test above. Measured 1.8e-6 N.m at this state since
    the indicated and gap work are integrated states (one jump among 20 differences of 1.2e-6; the benchmark's 10
    states x 201 speeds show none above 3.5e-7); cause not located."""
    simulation = implicit_chambers_run()
    torques, steps = torques_and_steps(simulation, simulation.get_state(), SPEEDS)
    changes = np.diff(torques)
    assert np.abs(changes - np.median(changes)).max() <= 1e-5, changes
    assert len(set(steps)) == 1, steps


def test_with_the_chamber_states_implicit_a_replay_at_the_same_input_repeats_the_step_within_newton_tolerance():
    """ark548's Newton iterates depend on the Jacobian, the predictor and the contraction estimate carried from stage
    to stage, which the recorded advance's rejected attempts also update and the replay skips: so a replay at the
    same input repeats the step not bit for bit but within the Newton iteration's stopping tolerance (1e-2 of the
    step tolerance; measured 3e-8 relative), far below the one-step map's jumps (docs/model.md §8.2); so does the
    memory (its closest-point warm start follows the state; the contact modes and stored velocities are equal)."""
    simulation = implicit_chambers_run()
    saved = simulation.get_state()
    simulation.advance(saved.time + STEP, speed_rpm=1500.0)
    first = simulation.get_state()
    simulation.set_state(saved)
    simulation.advance(saved.time + STEP, speed_rpm=1500.0)
    np.testing.assert_allclose(simulation.state, first.state, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(simulation.memory, first.memory, rtol=1e-6, atol=1e-12)


def test_a_replayed_step_with_the_same_input_repeats_the_step_exactly():
    """The grid replay is invisible at the recorded input: state, memory and step control after the replay are
    those after the adaptive advance that recorded it, bit for bit (each step repeats the recorded size from the
    recorded start)."""
    simulation = level_half_run()
    saved = simulation.get_state()
    simulation.advance(saved.time + STEP, speed_rpm=1500.0)
    first = simulation.get_state()
    simulation.set_state(saved)
    simulation.advance(saved.time + STEP, speed_rpm=1500.0)
    for name in ("state", "memory", "control"):
        np.testing.assert_array_equal(getattr(simulation, name), getattr(first, name), err_msg=name)


@pytest.mark.parametrize("speed", [1400.0, 0.0])
def test_a_large_change_of_input_falls_back_to_the_step_control(speed):
    """A replayed grid is followed only while its steps' error stays below 10x the tolerance: a speed changed by
    100 rpm, or stopped, from the same state ends the replay and the step control takes over (counted in
    replay_fallbacks), with the same result as an advance without any recorded grid."""
    simulation = level_half_run()
    saved = simulation.get_state()
    fresh = Simulation(simulation.params, keep_history=False)
    fresh.set_state(saved)
    fresh.advance(saved.time + STEP, speed_rpm=speed)          # no grid recorded from this state: adaptive
    simulation.advance(saved.time + STEP, speed_rpm=1500.0)    # records the grid
    simulation.set_state(saved)
    simulation.advance(saved.time + STEP, speed_rpm=speed)     # replays it, until the error is too large
    assert simulation.replay_fallbacks == 1
    assert simulation.state[WORK_IN] == pytest.approx(fresh.state[WORK_IN], rel=1e-4)


@pytest.fixture(scope="module")
def real_gas_run():
    params = CompressorParameters(stator_clearance=0.05e-3, rotor_inertia=0.0)
    simulation = Simulation(params, keep_history=False)
    simulation.advance(0.02)
    return simulation


@pytest.mark.parametrize("name", ["suction_pressure", "discharge_pressure", "suction_enthalpy"])
def test_the_torque_of_one_step_is_smooth_in_each_boundary_input(real_gas_run, name):
    """Real gas, one state, 21 values of one boundary input in +-10 Pa (pressures) or +-10 J/kg (suction enthalpy),
    held over a 1 ms advance: the torque's change between neighbours departs from its median by at most 1e-6 N.m
    (the benchmark's bound on the worst jump is 1e-4 N.m) and every value takes the same steps."""
    simulation = real_gas_run
    saved = simulation.get_state()
    boundary = simulation.boundary
    held = {"suction_pressure": boundary.suction.pressure, "discharge_pressure": boundary.back.pressure,
            "suction_enthalpy": boundary.suction.enthalpy}
    torques, steps = [], []
    for offset in np.linspace(-10.0, 10.0, 21):
        simulation.set_state(saved)
        work, angle, accepted = simulation.state[WORK_IN], simulation.rotor_angle, simulation.counters[ACCEPTED]
        simulation.advance(saved.time + STEP, speed_rpm=1500.0, boundary={**held, name: held[name] + offset})
        torques.append((simulation.state[WORK_IN] - work) / (simulation.rotor_angle - angle))
        steps.append(simulation.counters[ACCEPTED] - accepted)
    simulation.set_state(saved)
    changes = np.diff(torques)
    print(f"\n{name}: median change {np.median(changes):.3g} N.m, worst departure "
          f"{np.abs(changes - np.median(changes)).max():.3g} N.m")
    assert np.abs(changes - np.median(changes)).max() <= 1e-6, changes
    assert len(set(steps)) == 1, steps


def chamber_jacobian_radius(simulation):
    """The largest |eigenvalue| of d(chamber rates)/d(chamber states) at the run's state, by central differences
    of Simulation.evaluate and numpy's eigenvalues (independent of the kernel's power iteration)."""
    chambers = range(GAS_BLOCK, GAS_BLOCK + 4)
    state = simulation.state.copy()
    jacobian = np.empty((4, 4))
    for column, i in enumerate(chambers):
        delta = 1e-6 * abs(state[i])
        rates = []
        for sign in (1.0, -1.0):
            moved = state.copy()
            moved[i] += sign * delta
            rates.append(simulation.evaluate(simulation.time, moved)[1][GAS_BLOCK:GAS_BLOCK + 4])
        jacobian[:, column] = (rates[0] - rates[1]) / (2.0 * delta)
    return np.abs(np.linalg.eigvals(jacobian)).max()


def test_the_stability_cap_takes_the_chambers_dominant_eigenvalue():
    """docs/model.md §8.2: the stiffness the cap uses is at least the dominant |eigenvalue| of the chamber-rate
    Jacobian at the state the next step starts from. The stages' estimate alone is a lower bound that fell to a
    quarter of it in the start-up (h rho 0.9 where h lambda = -3.4, outside the stability region: the iterative
    master's unconverged steps); checked at 470 rpm, the start-up's speed there, after every 0.5 ms for 10 ms."""
    simulation = Simulation(CompressorParameters(rotor_inertia=0.0), constant_speed(470.0), keep_history=False)
    simulation.advance(0.01)
    ratios = []
    for k in range(1, 21):
        simulation.advance(0.01 + k * 5e-4)
        ratios.append(simulation.control[CONTROL_STIFFNESS] / chamber_jacobian_radius(simulation))
    assert min(ratios) >= 0.99, ratios
