"""The time loop's structure and limits (docs/model.md §8.2, §8.3): one loop for every method, a smallest step that is
the time resolution and not a setting, and the cost of a run said before it starts."""
import ast
import inspect
import logging
import math
import textwrap

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.loop import integrators
from rotary_vane.mechanics.loop.machine import machine_from_parameters
from rotary_vane.mechanics.loop.run_cost import revolution_cost

METHODS = ("dopri5", "abm4", "ark548")
HOOKS = ("begin", "bounded_step", "attempt", "after_rejection", "after_acceptance")


def names_in(function) -> set[str]:
    tree = ast.parse(textwrap.dedent(inspect.getsource(function.py_func if hasattr(function, "py_func")
                                                       else function)))
    return {node.id for node in ast.walk(tree) if isinstance(node, ast.Name)}


def parameters_of(function) -> list[str]:
    return list(inspect.signature(getattr(function, "py_func", function)).parameters)


def test_the_loop_names_no_method_and_every_method_has_every_hook():
    """A new method is its hooks and a line in each dispatcher (docs/model.md §14.5): the loop names no method, and
    every method's hook takes the dispatcher's arguments (the dispatcher passes them on unchanged)."""
    loop_names = names_in(integrators.advance)
    assert not {name for name in loop_names if any(m in name.lower() for m in METHODS)}, loop_names
    for hook in HOOKS:
        dispatcher = getattr(integrators, f"method_{hook}")
        for method in METHODS:
            assert parameters_of(getattr(integrators, f"{method}_{hook}")) == parameters_of(dispatcher)[1:], \
                (method, hook)
            assert f"{method}_{hook}" in names_in(dispatcher)


def test_the_smallest_step_is_the_time_resolution():
    """h_min = 16 eps max(|t|, T_c): a step that still changes t by a few units of rounding is allowed, one that
    does not is not; near t = 0 the contact period sets the scale."""
    m = machine_from_parameters(CompressorParameters())
    for t in (0.0, 1e-6, 0.04, 3600.0):
        floor = integrators.smallest_step(t, m)
        assert floor == pytest.approx(16.0 * np.finfo(float).eps * max(t, m.contact_period))
        assert t + floor != t
    assert integrators.smallest_step(0.04, m) < 1e-15          # 6 decades below the old h_min of 1 ns


def test_the_contact_period_is_that_of_the_vane_on_a_slot_edge():
    """2 pi sqrt(m3/k) with k = 1.5 F/delta of the Hertz law at the gas load (p_d - p_s) h L (docs/model.md §5.2,
    §8.3: about 0.2 ms for the default steel vane); the line law is stiffer, a softer vane slower."""
    p = CompressorParameters()
    m = machine_from_parameters(p)
    load = (p.discharge_pressure - p.suction_pressure) * p.stroke * p.axial_length
    hertz = 4.0 / 3.0 * m.effective_modulus * math.sqrt(p.edge_radius)
    penetration = (load / hertz) ** (2.0 / 3.0)
    assert m.contact_period == pytest.approx(2.0 * math.pi * math.sqrt(m.vane_mass / (1.5 * load / penetration)))
    assert 1.5e-4 < m.contact_period < 2.5e-4
    assert machine_from_parameters(p.replace(stiffness_model="johnson_line")).contact_period < m.contact_period / 5
    assert machine_from_parameters(p.replace(youngs_modulus=2e10)).contact_period > m.contact_period


@pytest.mark.parametrize("rpm, model", [(100.0, "real_gas"), (10.0, "ideal_gas_table")])
def test_a_slow_revolution_finishes_and_its_cost_was_said_up_front(rpm, model):
    """At 10 and 100 rpm one revolution at the defaults completes, in about the steps estimated before the run
    (within a factor 2, and never fewer than duration / max_step)."""
    params = CompressorParameters(pressure_model=model)
    cost = revolution_cost(params, rpm)
    simulation = Simulation(params, constant_speed(rpm), initial_angle=0.0, keep_history=False)
    simulation.advance(60.0 / rpm * 1.0001)
    steps = simulation.counters[integrators.ACCEPTED]
    assert simulation.last_revolution is not None
    assert cost.fewest_steps <= steps and 0.5 < cost.steps / steps < 2.0, (cost, steps)


def test_a_run_that_takes_long_says_so_before_any_work(caplog):
    """max_step = 10 ns at 15 rpm: 4e8 steps a revolution, logged when the simulation is built, with the figure."""
    params = CompressorParameters(pressure_model="polytropic", max_step=1e-8, initial_step=1e-8)
    with caplog.at_level(logging.WARNING, logger="rotary_vane.mechanics.simulation"):
        Simulation(params, constant_speed(15.0))
    assert len(caplog.records) == 1
    text = caplog.records[0].getMessage()
    assert "one revolution at 15 rpm" in text and "4e+08" in text and "max_step" in text, text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="rotary_vane.mechanics.simulation"):
        Simulation(CompressorParameters(pressure_model="polytropic"), constant_speed(1500.0))
    assert not caplog.records


@pytest.mark.parametrize("start_step", [1e-10, 1e-13])
def test_abm4_regains_its_step_from_a_collapsed_one(start_step):
    """ABM4's RK4 start steps carry the error of their embedded 3rd-order solution and grow the step by it (up to 5x
    a step, restarting the history at the new spacing; docs/model.md §8.2), so a step that collapsed (here forced
    below the declared h_0 through the control value) comes back within a few steps. Before, growth was only the
    doubling after 8 quiet PECE steps, and at steps of 1e-13 s the resting contact (c = 0) opens and closes every
    few steps, each change restarting ABM4 with RK4 steps that reset that count: 348 steps (from 1e-10 s) and
    1343 steps with 427 mode changes (from 1e-13 s) for these 0.2 ms, against 71 now."""
    simulation = Simulation(CompressorParameters(integrator="abm4", initial_step=1e-10), constant_speed(1500.0),
                            initial_angle=0.0, keep_history=True)
    simulation.control[integrators.CONTROL_STEP] = start_step
    simulation.advance(2e-4)
    steps = simulation.history["time"]
    assert len(steps) < 100
    assert np.median(np.diff(steps)[-10:]) > 2e-6
    assert simulation.counters[integrators.MODE_CHANGES] < 20


@pytest.mark.parametrize("setting, named", [(dict(onset_velocity_floor=1e-3, restitution=0.1), "onset_velocity_floor"),
                                            (dict(friction_velocity=1e-5), "friction_velocity"),
                                            (dict(max_step=1e-8, initial_step=1e-8), "max_step")])
def test_the_estimate_names_the_bound_behind_most_steps(setting, named):
    """docs/model.md §8.3: a 1 mm/s onset-velocity floor with little restitution makes the contact damper the stiff
    part, a 10 um/s friction regularisation the friction slope; each raises the estimate over the defaults' and the
    message names it."""
    params = CompressorParameters(pressure_model="polytropic")
    cost, default = revolution_cost(params.replace(**setting), 100.0), revolution_cost(params, 100.0)
    assert cost.steps > 3.0 * default.steps and cost.limit.startswith(named), (cost, default)
