"""Suction and discharge conditions that move during a run (mechanics.gas.boundary, Simulation.set_boundary):
refused by name before anything changes, held by the chamber model from the current time on, saved and restored
with the state; the pressure-table models take only their parameters' boundary."""
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.loop.layout import GAS_BLOCK, VANE_STATE_SIZE, WORK_IN
from rotary_vane.thermo.chamber_state import LEADING_MASS, LEADING_TEMPERATURE
from rotary_vane.thermo.fluid import Fluid

DEFAULT = dict(suction_pressure=0.2928e6, discharge_pressure=1.3179e6, suction_temperature=283.15)


@pytest.fixture(scope="module")
def fluid():
    return Fluid("R134a")


def real_gas_run():
    return Simulation(CompressorParameters(), constant_speed(1500.0), keep_history=False)


@pytest.mark.parametrize("name, value, allowed", [
    ("suction_pressure", -1e5, "a finite number > 0"), ("discharge_pressure", math.nan, "a finite number > 0"),
    ("suction_pressure", 1e4, "[51209, 2.11683e+06] Pa"), ("discharge_pressure", 30e6, "(0, 2.11683e+06] Pa"),
    ("suction_temperature", 240.0, "a state inside the R134a property table"),
    ("suction_temperature", 400.0, "<= 323.15 K"),
])
def test_a_boundary_the_tables_cannot_hold_is_refused_by_name(name, value, allowed):
    run = real_gas_run()
    before = run.boundary
    with pytest.raises(ValueError, match=rf"input '{name}' = .* is out of range: allowed") as error:
        run.set_boundary(**{**DEFAULT, name: value})
    assert allowed in str(error.value)
    assert run.boundary == before


def test_at_the_start_the_chambers_fill_with_the_new_suction_gas(fluid):
    run = real_gas_run()
    run.set_boundary(0.6e6, 0.6e6, suction_temperature=304.72)
    density = fluid.density(304.72, 0.6e6)
    assert run.boundary.suction.density == pytest.approx(density, rel=1e-7)
    assert run.boundary.back.pressure == 0.6e6
    assert run.boundary.back.temperature == pytest.approx(304.72, abs=1e-6)     # p_d = p_s: the suction state
    assert run.state[GAS_BLOCK + LEADING_TEMPERATURE] == 304.72
    leading_volume = run.outputs["leading_volume"]
    assert run.state[GAS_BLOCK + LEADING_MASS] == pytest.approx(density * leading_volume, rel=1e-7)


def test_a_moved_boundary_is_held_and_restored_with_the_state():
    run = real_gas_run()
    run.advance(0.004)
    saved = run.get_state()
    run.set_boundary(0.25e6, 1.4e6, suction_temperature=280.0)
    moved = run.boundary
    run.advance(0.006)
    assert run.boundary == moved
    assert run.outputs["trailing_pressure"] < 0.2928e6           # the chamber now fills from 0.25 MPa
    run.set_state(saved)
    assert run.boundary.suction.pressure == DEFAULT["suction_pressure"]
    assert np.array_equal(run.get_state().boundary_nodes, saved.boundary_nodes)


def test_a_wet_suction_state_by_enthalpy(fluid):
    run = real_gas_run()
    saturation = fluid.saturation_temperature(0.2928e6)
    enthalpy = fluid.saturated_state(saturation, 0.95).hmass()
    run.set_boundary(0.2928e6, 1.3179e6, suction_enthalpy=enthalpy)
    assert run.boundary.suction.temperature == pytest.approx(saturation, abs=1e-5)
    assert run.boundary.suction.enthalpy == enthalpy


def test_the_pressure_table_models_take_only_their_parameters_boundary():
    run = Simulation(CompressorParameters(pressure_model="polytropic"), constant_speed(1500.0), keep_history=False)
    run.set_boundary(**DEFAULT)                                 # the parameters' own: accepted, nothing changes
    with pytest.raises(ValueError, match=r"input 'discharge_pressure' = 1400000.0 Pa is out of range: allowed "
                                         r"1317900.0 \(the parameter's value\): the pressure table"):
        run.set_boundary(**{**DEFAULT, "discharge_pressure": 1.4e6})


@pytest.fixture(scope="module")
def run_at_4_ms():
    run = real_gas_run()
    run.advance(0.004)
    return run, run.get_state()


def work_after(run_and_state, plan, interpolate=False):
    """The shaft work [J] at 5 ms from the state at 4 ms, advancing through `plan` [(end time, boundary)]."""
    run, saved = run_and_state
    run.set_state(saved)
    for end_time, boundary in plan:
        run.advance(end_time, boundary=boundary, interpolate=interpolate)
    return run.state[WORK_IN]


def test_an_interpolated_boundary_is_the_limit_of_many_held_steps(run_at_4_ms):
    """p_d ramped by 50 kPa over one 1 ms advance (interpolate=True) is what n held advances with p_d stepped at
    each converge to: the error shrinks about as 1/n, and differs from one held step by far more."""
    low, high = DEFAULT["discharge_pressure"], DEFAULT["discharge_pressure"] + 5e4

    def at(fraction):
        return {**DEFAULT, "discharge_pressure": low + (high - low) * fraction}
    ramped = work_after(run_at_4_ms, [(0.005, at(1.0))], interpolate=True)
    errors = [abs(work_after(run_at_4_ms, [(0.004 + 1e-3 * k / n, at(k / n)) for k in range(1, n + 1)]) - ramped)
              for n in (1, 2, 4, 8)]
    print(f"\nshaft work, p_d ramped over 1 ms: {ramped!r} J; |held steps - ramp| for 1, 2, 4, 8 steps: {errors}")
    assert errors[0] > 1e3 * run_at_4_ms[0].machine.atol_work
    for coarse, fine in zip(errors, errors[1:]):
        assert 0.3 < fine / coarse < 0.7


def test_a_state_saved_after_a_ramp_continues_held_whatever_ramp_followed(run_at_4_ms):
    """A ramp ends with its advance: restored after a later ramp, the state continues with its own boundary held."""
    run, _ = run_at_4_ms
    moved, further = ({**DEFAULT, "discharge_pressure": p_d} for p_d in (1.35e6, 1.4e6))
    work_after(run_at_4_ms, [(0.005, moved)], interpolate=True)
    saved = run.get_state()
    run.advance(0.006)
    held = run.state[WORK_IN]
    run.set_state(saved)
    run.advance(0.006, boundary=further, interpolate=True)
    assert run.state[WORK_IN] != held
    run.set_state(saved)
    run.advance(0.006)
    assert run.state[WORK_IN] == held
    assert run.boundary.back.pressure == 1.35e6


def test_the_vane_sees_a_moved_discharge_pressure_in_its_back_chamber():
    """A run whose p_d was moved to 1.4 MPa has the right-hand side of a run built at 1.4 MPa: the vane's
    back-chamber pressure is the boundary's of the moment, not the parameters' (which it was before the boundary
    followed the inputs into the vane loads)."""
    moved = real_gas_run()
    moved.set_boundary(**{**DEFAULT, "discharge_pressure": 1.4e6})
    built = Simulation(CompressorParameters(discharge_pressure=1.4e6), constant_speed(1500.0), keep_history=False)
    np.testing.assert_allclose(moved.state, built.state, rtol=1e-9)
    rates = [run.evaluate(0.0, run.state)[1][:VANE_STATE_SIZE] for run in (moved, built)]
    np.testing.assert_allclose(rates[0], rates[1], rtol=1e-7, atol=1e-9 * np.abs(rates[1]).max())
