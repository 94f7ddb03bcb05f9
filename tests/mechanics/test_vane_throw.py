"""A vane thrown off its profile and its impact, as the cost estimate sees them (docs/model.md §8.3,
mechanics/loop/vane_throw.py): the lift ratio against the harmonic law's closed form, the impact against the
energy balance of the Hertz law (§5.1), and the estimate that names the throw."""
import math

import pytest

from rotary_vane.mechanics import CompressorParameters
from rotary_vane.mechanics.contact.contact_laws import hertz_stiffness
from rotary_vane.mechanics.loop.machine import effective_modulus, vane_mass_properties
from rotary_vane.mechanics.loop.run_cost import revolution_cost
from rotary_vane.mechanics.loop.vane_throw import vane_throw

# the air machine of tests/mechanics/test_vane_jump.py (z = 5 cycloidal, cast-iron vane, 1 -> 8 bar)
AIR_MACHINE = dict(lobes=5, displacement_law="cycloidal", vane_density=7200.0, youngs_modulus=110e9,
                   pressure_model="ideal_gas_table", heat_capacity_ratio=1.4, gas_constant=287.0,
                   suction_pressure=1e5, suction_temperature=293.0, discharge_pressure=8e5)


def test_lift_ratio_of_the_harmonic_law_without_gas_push():
    """s = h/2 (1 - cos z theta): the largest s'' / (R0 + s) is h z^2 / (2 R0), at the valley, at every speed."""
    params = CompressorParameters(lobes=4, stroke=0.006,
                                  discharge_pressure=1.0000001 * CompressorParameters().suction_pressure)
    expected = params.stroke * params.lobes ** 2 / (2.0 * params.base_radius)
    for rpm in (500.0, 5000.0):
        assert vane_throw(params, rpm).lift_ratio == pytest.approx(expected, rel=1e-4)
    assert vane_throw(params, 5000.0).radial_speed == pytest.approx(
        params.stroke * params.lobes / 2.0 * 5000.0 * math.pi / 30.0, rel=1e-6)


def test_impact_stores_the_vane_kinetic_energy_in_the_corner_contact():
    params = CompressorParameters(**AIR_MACHINE)
    throw = vane_throw(params, 6000.0)
    mass = vane_mass_properties(params.vane_thickness, params.vane_length, params.axial_length,
                                params.vane_density).mass
    stiffness = hertz_stiffness(1.0 / params.edge_radius, 0.0, effective_modulus(params.youngs_modulus,
                                                                                 params.poisson_ratio))
    penetration = (throw.impact_force / stiffness) ** (2.0 / 3.0)
    assert stiffness * penetration ** 2.5 / 2.5 == pytest.approx(0.5 * mass * throw.radial_speed ** 2, rel=1e-9)
    assert throw.impact_time == pytest.approx(2.94 * penetration / throw.radial_speed, rel=1e-9)


def test_a_thrown_vane_with_a_steep_friction_law_is_estimated_dear_and_named():
    """At 6000 rpm the vane leaves its profile (lift ratio > 1); with v_0 = 10 um/s each landing is spent at the
    friction slope under the impact force and the estimate names the throw; at 2800 rpm (lift ratio < 1, the gas
    push counted at its largest) or with v_0 = 1 mm/s it stays cheap."""
    steep = CompressorParameters(**AIR_MACHINE, friction_velocity=1e-5)
    thrown = revolution_cost(steep, 6000.0)
    assert vane_throw(steep, 6000.0).lift_ratio > 1.0 > vane_throw(steep, 2800.0).lift_ratio
    assert thrown.limit.startswith("the vane thrown off its profile"), thrown
    assert thrown.seconds > 20.0 * revolution_cost(steep.replace(friction_velocity=1e-3), 6000.0).seconds
    assert not revolution_cost(steep, 2800.0).limit.startswith("the vane thrown")
