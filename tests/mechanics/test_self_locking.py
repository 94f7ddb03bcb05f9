"""Friction self-locking of the vane in its slot, refused before any work (docs/model.md §5.5).

The machine: the defaults with six lobes and a 10 mm stroke (steep return strokes, the tip far beyond the slot
mouth). The bound on the friction coefficient is checked against the vane's static equilibrium solved here as a
linear system, independently of the closed form in mechanics/contact/self_locking.py."""
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics import simulation as simulation_module
from rotary_vane.mechanics.contact.self_locking import locking_margin
from rotary_vane.mechanics.errors import IntegrationError

STEEP = dict(lobes=6, stroke=0.01)


def _axial_surplus(mu, beta, tip_beyond, engaged):
    """Inward axial force left over, per unit stator force, once the slot friction is paid: the stator's push at
    pressure angle beta with tip friction mu, reactions N_mouth at the slot mouth (tip_beyond from the tip) and
    N_corner at the bottom corner (engaged further in), from the transverse force and moment balance."""
    transverse = math.sin(beta) + mu * math.cos(beta)
    axial = math.cos(beta) - mu * math.sin(beta)
    # unknowns (N_mouth, N_corner): N_mouth - N_corner = transverse; moments about the tip
    matrix = np.array([[1.0, -1.0], [tip_beyond, -(tip_beyond + engaged)]])
    n_mouth, n_corner = np.linalg.solve(matrix, [transverse, 0.0])
    assert n_mouth > 0.0 and n_corner > 0.0
    return axial - mu * (n_mouth + n_corner)


def test_friction_bound_is_where_the_stator_push_no_longer_moves_the_vane():
    params = CompressorParameters(**STEEP)
    bound = locking_margin(params).largest_friction
    assert 0.0 < bound < 0.5
    at_bound = locking_margin(params.replace(friction_coefficient=bound))
    geometry = (at_bound.pressure_angle, at_bound.tip_beyond_mouth, at_bound.engaged_length)
    assert at_bound.index == pytest.approx(1.0, abs=1e-6)
    assert abs(_axial_surplus(bound, *geometry)) < 1e-6
    assert _axial_surplus(0.95 * bound, *geometry) > 0.0       # the push still slides the vane in
    assert _axial_surplus(1.05 * bound, *geometry) < 0.0       # the slot friction holds it: locked


def test_locking_vane_is_refused_at_construction_naming_friction_coefficient():
    params = CompressorParameters(**STEEP, friction_coefficient=0.4)
    with pytest.raises(ValueError) as error:
        Simulation(params, constant_speed(1500.0))
    text = str(error.value)
    assert "'friction_coefficient' = 0.4" in text and "allowed <" in text and "self-locks" in text
    assert "docs/model.md §5.5" in text


def test_same_machine_below_the_bound_is_built():
    params = CompressorParameters(**STEEP, friction_coefficient=0.25)
    assert locking_margin(params).index < 1.0
    Simulation(params, constant_speed(1500.0), keep_history=False)


def test_default_vane_is_far_from_locking():
    assert locking_margin(CompressorParameters()).index < 0.1


def _first_revolution_without_the_check(monkeypatch, friction_coefficient):
    """One revolution at 1500 rpm (Level 0) of the steep machine with the construction check bypassed, under a
    work bound of 10 000 step attempts per ms (50 times what valid runs at this speed need), advanced in 0.4 ms
    slices; returns the largest
    slot-contact force [N], or raises IntegrationError."""
    monkeypatch.setattr(simulation_module, "check_vane_not_self_locking", lambda params: None)
    params = CompressorParameters(**STEEP, pressure_model="polytropic", friction_coefficient=friction_coefficient)
    simulation = Simulation(params, constant_speed(1500.0), initial_angle=0.0, keep_history=True)
    simulation.work_per_ms = 1e4
    for k in range(1, 101):                     # 0.4 ms slices: the work bound applies to each
        simulation.advance(0.04 * k / 100)
    history = simulation.history
    return max(float(np.max(history[f"normal_force_{k}"])) for k in (1, 2, 3, 4))


def test_the_model_itself_jams_above_the_bound_and_runs_below_it(monkeypatch):
    """The bound (0.304 for this machine) is the model's own: at mu = 0.29 (J = 0.93) a revolution runs with the slot
    forces under 10 kN; at mu = 0.32 (J = 1.08) the vane wedges, the slot forces pass 100 kN and the steps collapse
    to the work bound (measured without the bound: 651 kN and 187 000 steps in the first 12 % of the revolution)."""
    assert locking_margin(CompressorParameters(**STEEP, friction_coefficient=0.29)).index < 1.0 \
        < locking_margin(CompressorParameters(**STEEP, friction_coefficient=0.32)).index
    assert _first_revolution_without_the_check(monkeypatch, 0.29) < 1e4
    with pytest.raises(IntegrationError, match="work bound"):
        _first_revolution_without_the_check(monkeypatch, 0.32)
