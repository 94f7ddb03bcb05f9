"""Parameter declarations and validation (docs/model.md §9), speed-input validation and the Simulation's argument checks.

Every rejected value must raise ValueError whose message names the parameter, shows the bad value and says
what is allowed.
"""
import dataclasses
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed, cycloidal_ramp, declarations
from rotary_vane.mechanics.parameters import is_numeric


def assert_rejected(name, value, **overrides):
    overrides = overrides or {name: value}
    with pytest.raises(ValueError) as info:
        CompressorParameters(**overrides)
    message = str(info.value)
    assert name in message, message
    assert repr(value) in message or str(value) in message, message
    assert "allowed" in message, message
    return message


def test_defaults_match_spec_table():
    """docs/model.md §9 default parameter table."""
    p = CompressorParameters()
    expected = dict(lobes=3, displacement_law="harmonic", rotor_radius=30.0e-3, stroke=5.0e-3, vane_thickness=4.0e-3,
                    vane_length=18.0e-3, axial_length=55.0e-3, slot_bottom_radius=9.5e-3, edge_radius=1.0e-3,
                    slot_clearance=0.0, stator_clearance=0.0, vane_density=7850.0, rotor_inertia=5.5e-4,
                    youngs_modulus=207e9, poisson_ratio=0.30, restitution=0.9, onset_velocity_floor=0.01,
                    friction_coefficient=0.085, friction_velocity=1e-3, suction_pressure=0.2928e6,
                    suction_temperature=283.15, discharge_pressure=1.3179e6, polytropic_exponent=1.10,
                    suction_close_angle=math.radians(10.0), dead_volume=0.05e-6, discharge_port_area=20e-6,
                    discharge_port_coefficient=0.7, end_valley_leak_law="nozzle", end_valley_leak_coefficient=0.65,
                    start_valley_leak_law="nozzle", start_valley_leak_coefficient=0.65, tip_leak_law="nozzle",
                    tip_leak_coefficient=0.65, slot_leak_law="sealed", slot_leak_coefficient=0.65,
                    heat_capacity_ratio=1.10,
                    gas_constant=81.5, relative_tolerance=3e-5, initial_step=1e-6, max_step=2e-5,
                    mode_dwell_time=10e-6, stiffness_model="hertz_point",
                    friction_model="threlfall", pressure_model="real_gas", fluid="R134a")
    for name, value in expected.items():
        if isinstance(value, str):
            assert getattr(p, name) == value, name
        else:
            assert getattr(p, name) == pytest.approx(value, rel=1e-12), name
    # derived values (docs/model.md §2.1, §2.2, §2.3, §2.5)
    assert p.tip_radius == pytest.approx(2.0e-3)
    assert p.base_radius == pytest.approx(28.0e-3)
    assert p.slot_width == pytest.approx(4.0e-3)
    assert p.mouth_radius == pytest.approx(math.sqrt(30e-3 ** 2 - 2e-3 ** 2))
    assert p.envelope_offset == pytest.approx(2.0e-3)
    q = p.replace(slot_clearance=0.1e-3, stator_clearance=0.05e-3)
    assert q.slot_width == pytest.approx(4.1e-3) and q.envelope_offset == pytest.approx(2.05e-3)
    assert q.mouth_radius == pytest.approx(math.sqrt(30e-3 ** 2 - 2.05e-3 ** 2))


def test_parameters_are_frozen_and_declared():
    p = CompressorParameters()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.stroke = 1e-3
    names = [name for name, _, _ in declarations()]
    assert names == [f.name for f in dataclasses.fields(CompressorParameters)]
    for name, default, meta in declarations():
        assert "description" in meta and meta["description"]
        assert getattr(p, name) == default
        if is_numeric(meta):
            assert meta["min"] <= default <= meta["max"], name


@pytest.mark.parametrize("name", ["slot_clearance", "stator_clearance"])
def test_negative_clearance_rejected(name):
    assert_rejected(name, -1e-5)


@pytest.mark.parametrize("value", [1, 0, -3, 2.5, 3.5, True])
def test_lobes_must_be_an_integer_of_at_least_two(value):
    assert_rejected("lobes", value)


def test_numpy_scalars_accepted_and_stored_as_python_numbers():
    params = CompressorParameters(lobes=np.int64(5), stroke=np.float32(4e-3))
    assert params.lobes == 5 and type(params.lobes) is int
    assert params.stroke == pytest.approx(4e-3) and type(params.stroke) is float


def test_valid_lobe_counts():
    for z in (2, 3, 5, 7, 9):
        assert CompressorParameters(lobes=z).lobes == z
    assert CompressorParameters(lobes=4.0).lobes == 4           # an integral float is accepted


@pytest.mark.parametrize("name", ["stroke", "rotor_radius", "vane_thickness", "slot_clearance", "restitution",
                                  "friction_coefficient", "suction_pressure", "rotor_inertia", "relative_tolerance",
                                  "youngs_modulus"])
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_numbers_rejected(name, value):
    assert_rejected(name, value)


@pytest.mark.parametrize("name", ["stroke", "axial_length", "vane_density"])
def test_non_numbers_rejected(name):
    assert_rejected(name, "5")
    assert_rejected(name, None)


def test_vane_too_short_for_the_stroke():
    """At full stroke the vane must stay engaged in the slot (docs/model.md §2.1 l_v >= 13 mm engagement rationale)."""
    message = assert_rejected("vane_length", 8e-3)
    assert "stroke" in message
    CompressorParameters(vane_length=18e-3)
    assert_rejected("vane_length", 12e-3, stroke=9e-3, vane_length=12e-3)


def test_vane_bottom_must_clear_the_slot_bottom():
    assert_rejected("slot_bottom_radius", 15e-3)


@pytest.mark.parametrize("discharge", [0.2928e6, 0.2e6])
def test_discharge_pressure_must_exceed_suction(discharge):
    message = assert_rejected("discharge_pressure", discharge)
    assert "suction_pressure" in message


@pytest.mark.parametrize("name,value", [("displacement_law", "sinusoidal"), ("stiffness_model", "hertz"),
                                        ("friction_model", "coulomb"), ("integrator", "rk45"),
                                        ("pressure_model", "coolprop"), ("displacement_law", 1)])
def test_unknown_choice_rejected(name, value):
    message = assert_rejected(name, value)
    default = dict((n, d) for n, d, _ in declarations())[name]
    assert default in message          # the allowed values are listed


def test_out_of_range_values_rejected():
    assert_rejected("restitution", 0.05)
    assert_rejected("restitution", 1.5)
    assert_rejected("poisson_ratio", 0.6)
    assert_rejected("stroke", 0.0)
    assert_rejected("friction_velocity_full", 1e-4, friction_model="ambrosio", friction_velocity=1e-3,
                    friction_velocity_full=1e-4)
    # the suction port must close inside the lobe, 2 pi / z = 0.628 rad at z = 10 (the sweep found it refused
    # later, by the pressure table, without the parameter's name)
    message = assert_rejected("suction_close_angle", 0.8, lobes=10, suction_close_angle=0.8)
    assert "0.628319 rad" in message, message
    CompressorParameters(lobes=10, suction_close_angle=2 * math.pi / 10)


def test_contact_settings_that_stall_a_revolution_are_refused_before_any_work():
    """docs/model.md §13.4, §11.5: values the random sweep drew at the ends of the old ranges and stopped at the work
    bound (steps of 1e-9..1e-11 s): an onset-velocity floor of 2 um/s, 0.5 mm/s or 4.7 m/s, a friction
    regularisation velocity of 0.4 um/s, a vane of 234 kg/m3. Each is refused by name, with the allowed range, before
    a Simulation exists."""
    for name, value, unit in (("onset_velocity_floor", 2.12e-6, "m/s"), ("onset_velocity_floor", 5.0e-4, "m/s"),
                              ("onset_velocity_floor", 4.7, "m/s"), ("friction_velocity", 4.1e-7, "m/s"),
                              ("friction_velocity_full", 2.6e-7, "m/s"), ("vane_density", 234.0, "kg/m3")):
        message = assert_rejected(name, value)
        assert unit in message.split("allowed")[1], message
    CompressorParameters(onset_velocity_floor=2e-3, friction_velocity=2e-5, vane_density=1300.0)   # inside: runs


def test_replace_validates():
    p = CompressorParameters()
    with pytest.raises(ValueError, match="stator_clearance"):
        p.replace(stator_clearance=-1e-6)
    assert p.replace(stroke=4e-3).stroke == 4e-3


# ----------------------------------------------------------------------------------------------------------
# speed input


@pytest.mark.parametrize("rpm", [-1, -0.5, math.nan, math.inf, "1500", None])
def test_constant_speed_rejects_invalid_rpm(rpm):
    with pytest.raises(ValueError) as info:
        constant_speed(rpm)
    message = str(info.value)
    assert "target_rpm" in message and "allowed" in message and str(rpm) in message


@pytest.mark.parametrize("kwargs", [dict(rpm=-10.0), dict(rpm=1500.0, duration=0.0), dict(rpm=1500.0, duration=-1.0),
                                    dict(rpm=1500.0, duration=math.nan), dict(rpm=1500.0, start_rpm=-1.0)])
def test_ramp_rejects_invalid_arguments(kwargs):
    with pytest.raises(ValueError, match="allowed"):
        cycloidal_ramp(**kwargs)


def test_zero_speed_is_allowed():
    assert constant_speed(0.0).target_rpm == 0.0


def test_simulation_advance_rejects_negative_speed():
    sim = Simulation(CompressorParameters(), constant_speed(1500.0), keep_history=False)
    with pytest.raises(ValueError, match="speed_rpm") as info:
        sim.advance(1e-5, speed_rpm=-5)
    assert "-5" in str(info.value) and "allowed" in str(info.value)
    with pytest.raises(ValueError, match="speed_rpm"):
        sim.advance(1e-5, speed_rpm=math.nan)
    assert sim.time == 0.0                     # nothing was integrated


def test_simulation_rejects_invalid_arguments():
    with pytest.raises(ValueError, match="end_time"):
        Simulation(CompressorParameters(), constant_speed(1500.0), keep_history=False).advance(-1.0)
    with pytest.raises(ValueError, match="initial_angle"):
        Simulation(CompressorParameters(), constant_speed(1500.0), initial_angle=math.nan)
    with pytest.raises(ValueError, match="speed"):
        Simulation(CompressorParameters(), speed=1500.0)


@pytest.mark.parametrize("name", [n for n, _, meta in declarations() if "min" in meta])
def test_declared_bounds_are_inclusive(name):
    """FMI min and max are inclusive: the range check accepts a value exactly at either bound (the checks that
    relate several parameters are tested above)."""
    from rotary_vane.mechanics.parameters import _validate_declared_ranges
    meta = dict((n, m) for n, _, m in declarations())[name]
    for bound in (meta["min"], meta["max"]):
        candidate = object.__new__(CompressorParameters)          # the fields only, not yet validated
        for key, default, _ in declarations():
            object.__setattr__(candidate, key, bound if key == name else default)
        _validate_declared_ranges(candidate)


def test_a_relation_names_the_parameter_that_was_changed():
    """A vane too long for the default slot bottom is reported against vane_length with a bound it can meet (the
    vane bottom at zero stroke, R0 - (l_v - t/2), must stay above r_sb: l_v < R0 - r_sb + t/2 = 28 - 9.5 + 2 mm);
    a slot bottom too high for the default vane against slot_bottom_radius (r_sb < 28 - 16 = 12 mm)."""
    message = assert_rejected("vane_length", 0.03)
    assert "allowed < 0.0205 m" in message and "'slot_bottom_radius'" not in message, message
    message = assert_rejected("slot_bottom_radius", 0.02)
    assert "allowed < 0.012 m" in message, message
    # a stroke the default vane cannot follow: R0 + h - (l_v - t/2) <= R_m - t, R_m = sqrt(30^2 - 2^2) mm
    message = assert_rejected("stroke", 0.02)
    longest = (30e-3 ** 2 - 2e-3 ** 2) ** 0.5 - 4e-3 + 16e-3 - 28e-3
    assert f"allowed <= {longest:g} m" in message and "'vane_length'" not in message, message


def test_a_long_bad_value_is_echoed_cut_to_a_readable_length():
    with pytest.raises(ValueError) as info:
        CompressorParameters(displacement_law="x" * 100_000)
    message = str(info.value)
    assert len(message) < 300 and "(100002 characters)" in message and "'displacement_law'" in message, message
