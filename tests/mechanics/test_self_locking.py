"""Friction self-locking of the vane in its slot, refused before any work (docs/model.md §5.5).

The machine: the defaults with six lobes and a 10 mm stroke (steep return strokes, the tip far beyond the slot
mouth). The bound on the friction coefficient is checked against the vane's static equilibrium solved here as a
linear system, independently of the closed form in mechanics/contact/self_locking.py."""
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.contact.self_locking import locking_margin

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
