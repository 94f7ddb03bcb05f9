"""Periodic map over the fluid inputs (speed x p_s x p_d): multilinear interpolation against closed forms, the
conservative rates' exact integrals (step sums equal totals; a revolution is the sum of the cell means), the box
refused by name, the suction-state correction, the disk format, the FMU's map run on a table; and the table
against the detailed model at an off-grid point."""
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters
from rotary_vane.mechanics.reduced.fluid_map import (ENTHALPY_OFFSETS, MASS_RATES, RATES, FluidMapSettings,
                                                     FluidMapTable, _run_point, build_fluid_map)
from rotary_vane.mechanics.reduced.periodic_map import CHANNELS, FIGURES, TORQUE

SAMPLES = 720
STEP = 2.0 * math.pi / SAMPLES
GRID = ((500.0, 1000.0, 2000.0), (2.0e5, 3.0e5, 5.0e5), (4.0e5, 8.0e5, 1.2e6))


def linear(angles, s, p, d):
    """Per angle, linear in speed and each pressure (multilinear interpolation reproduces it exactly)."""
    return 1.0 + 1e-3 * s + 2e-6 * p - 1e-6 * d + np.sin(angles) * (1.0 + 1e-7 * d)


def synthetic_table(rate_of=linear, suction=None):
    angles = STEP * np.arange(SAMPLES)
    points = [(s, p, d) for s in GRID[0] for p in GRID[1] for d in GRID[2]]
    shape = tuple(len(axis) for axis in GRID)
    channel = np.array([linear(angles + (0.5 * STEP), *point) for point in points]).reshape(*shape, SAMPLES)
    node = np.array([linear(angles, *point) for point in points]).reshape(*shape, SAMPLES)
    channels = {name: node for name in CHANNELS}
    channels[TORQUE] = channel
    rates = {name: np.array([rate_of(angles + 0.5 * STEP, *point) for point in points]).reshape(*shape, SAMPLES)
             for name in RATES}
    figures = {name: np.array([s + p + d for s, p, d in points]).reshape(shape) for name in FIGURES}
    suction = suction or dict(temperature=np.full(3, 270.0), enthalpy=np.full(3, 4.0e5), density=np.full(3, 10.0),
                              density_grid=np.tile(10.0 * (1.0 - ENTHALPY_OFFSETS / 2e5), (3, 1)),
                              gas_heat_capacity=np.full(3, 900.0))
    return FluidMapTable(GRID, channels, rates, figures, suction)


def test_multilinear_in_speed_and_pressures_reproduced_exactly():
    table = synthetic_table()
    for point in ((700.0, 2.5e5, 6.1e5), (1999.0, 4.9e5, 4.0e5), (1000.0, 3.0e5, 8.0e5)):
        values = table.values(1.234, *point)
        assert values["leading_pressure"] == pytest.approx(linear(1.234, *point), rel=1e-4)   # chord in angle
        assert table.figures_at(*point)["input_power"] == pytest.approx(sum(point), rel=1e-12)


def test_speeds_outside_the_grid_hold_the_end_speed():
    table = synthetic_table()
    assert table.figures_at(100.0, 3e5, 8e5)["input_power"] == pytest.approx(500.0 + 3e5 + 8e5, rel=1e-12)
    assert table.figures_at(5000.0, 3e5, 8e5)["input_power"] == pytest.approx(2000.0 + 3e5 + 8e5, rel=1e-12)


@pytest.mark.parametrize("name, value", [("suction_pressure", 1.9e5), ("suction_pressure", 5.2e5),
                                         ("discharge_pressure", 3.0e5), ("discharge_pressure", math.nan)])
def test_pressures_outside_the_box_are_refused_by_name(name, value):
    table = synthetic_table()
    point = {"suction_pressure": 3e5, "discharge_pressure": 8e5, name: value}
    with pytest.raises(ValueError, match=rf"input '{name}' = .*outside the periodic map's box.*200000, 500000.*"
                                         rf"400000, 1.2e\+06"):
        table.rate_integrals(0.0, 1.0, 1000.0, point["suction_pressure"], point["discharge_pressure"])


def test_revolution_integral_is_the_sum_of_the_cell_means():
    """Over a whole revolution the interpolant's integral is dtheta sum_k r_k: the detailed model's total."""
    rng = np.random.default_rng(1)
    cells = rng.normal(size=SAMPLES)
    table = synthetic_table(rate_of=lambda angles, s, p, d: cells * (1.0 + 1e-4 * s))
    total = table.rate_integrals(0.3, 0.3 + 2.0 * math.pi, 1000.0, 3e5, 8e5)["delivered_mass"]
    assert total == pytest.approx(STEP * cells.sum() * 1.1, rel=1e-12, abs=1e-12)


def test_step_sums_equal_the_totals():
    """Integrals over arbitrary consecutive angle steps add up to the integral over their union (1e-9)."""
    table = synthetic_table()
    rng = np.random.default_rng(2)
    edges = np.concatenate(([0.1], 0.1 + np.cumsum(rng.uniform(0.001, 0.7, 400))))
    point = (1234.0, 3.3e5, 9.1e5)
    steps = [table.rate_integrals(a, b, *point) for a, b in zip(edges[:-1], edges[1:])]
    whole = table.rate_integrals(edges[0], edges[-1], *point)
    for name in RATES:
        assert sum(s[name] for s in steps) == pytest.approx(whole[name], rel=1e-9)


def test_suction_state_scales_the_mass_by_density_and_shifts_the_enthalpy():
    table = synthetic_table()
    point = (1000.0, 3e5, 8e5)
    plain = table.rate_integrals(0.0, 1.0, *point)
    assert table.rate_integrals(0.0, 1.0, *point, suction_enthalpy=4.0e5) == pytest.approx(plain, rel=1e-12)
    shifted = table.rate_integrals(0.0, 1.0, *point, suction_enthalpy=4.0e5 - 2e4)      # density x 1.1
    for mass, enthalpy in MASS_RATES.items():
        assert shifted[mass] == pytest.approx(1.1 * plain[mass], rel=1e-12)
        assert shifted[enthalpy] == pytest.approx(1.1 * (plain[enthalpy] - 2e4 * plain[mass]), rel=1e-12)
    assert shifted["shaft_work"] == plain["shaft_work"]
    with pytest.raises(ValueError, match=r"input 'suction_enthalpy' = 300000.0 J/kg is outside"):
        table.rate_integrals(0.0, 1.0, *point, suction_enthalpy=3.0e5)


def test_saved_table_loads_the_same(tmp_path):
    table = synthetic_table()
    loaded = FluidMapTable.load(table.save(tmp_path, "key"))
    point = (900.0, 2.2e5, 1.1e6)
    assert loaded.rate_integrals(0.2, 5.0, *point) == table.rate_integrals(0.2, 5.0, *point)
    assert loaded.values(0.7, *point) == table.values(0.7, *point)


@pytest.mark.slow
def test_table_matches_the_detailed_model_between_its_nodes(tmp_path):
    """(slow: 80 s on 2 cores, nine detailed real-gas points) A 2 x 2 x 2 grid around the refrigeration system's steady point (one averaged revolution after two of
    warm-up: a few seconds); at the cell centre the per-revolution integrals against a detailed run there: mass and
    enthalpies within 0.2 %, shaft work within 1 % (measured with 3 + 2 revolutions: -0.52 %, mass -9e-5, drawn
    enthalpy 7e-5, delivered enthalpy -5e-4, docs/model.md §12.4)."""
    from CoolProp.CoolProp import PropsSI
    params = CompressorParameters(rotor_inertia=0.0)
    settings = FluidMapSettings(speeds=(1400.0, 1600.0), suction_pressures=(250e3, 300e3),
                                discharge_pressures=(1.0e6, 1.3e6), suction_superheat=5.7, warmup_revolutions=2,
                                averaged_revolutions=1)
    table = build_fluid_map(params, settings, workers=1, cache_dir=tmp_path)
    point = (1500.0, 275e3, 1.15e6)
    temperature = PropsSI("T", "P", point[1], "Q", 1.0, params.fluid) + 5.7
    detailed = _run_point(params, point[0], dict(suction_pressure=point[1], discharge_pressure=point[2],
                                                  suction_temperature=temperature), settings)
    mapped = table.rate_integrals(0.0, 2.0 * math.pi, *point)
    for name in RATES:
        exact = detailed["mean"][name].sum() * STEP
        assert mapped[name] == pytest.approx(exact, rel=1e-2 if name == "shaft_work" else 2e-3), name


# the FMU's periodic-map run on the table (fmu_src.periodic_map_mode) -----------------------------------------
@pytest.fixture
def fluid_run(monkeypatch):
    from rotary_vane.fmu_src import periodic_map_mode
    table = synthetic_table()
    monkeypatch.setattr(periodic_map_mode, "fluid_map_table_for", lambda params, rpm: table)
    boundary = dict(suction_pressure=3e5, discharge_pressure=8e5, suction_enthalpy=4.0e5)
    run = periodic_map_mode.PeriodicMapRun(CompressorParameters(rotor_inertia=0.0), 1500.0, 1200.0, 0.0, boundary)
    return run, table, boundary


def test_map_run_cumulative_flows_are_the_integral_over_the_angle_turned(fluid_run):
    """At constant inputs, 300 steps of 1 ms sum to the exact integral over the whole angle (1e-9)."""
    run, table, boundary = fluid_run
    for _ in range(300):
        run.advance(1e-3, 1200.0, True, boundary)
    whole = table.rate_integrals(0.0, run.angle, 1200.0, 3e5, 8e5, suction_enthalpy=4.0e5)
    assert run.angle == pytest.approx(300 * 1e-3 * 1200.0 * 2.0 * math.pi / 60.0, rel=1e-12)
    for name in MASS_RATES.items():
        for flow in name:
            assert run.flows[flow] == pytest.approx(whole[flow], rel=1e-9)
    assert run.work == pytest.approx(whole["shaft_work"], rel=1e-9)


@pytest.mark.parametrize("name, value", [("suction_pressure", 6e5), ("discharge_pressure", 1.3e6),
                                         ("suction_enthalpy", 3.0e5)])
def test_map_run_refuses_an_input_outside_the_table_and_keeps_its_state(fluid_run, name, value):
    run, _, boundary = fluid_run
    run.advance(1e-3, 1200.0, True, boundary)
    before = run.get_state()
    with pytest.raises(ValueError, match=rf"input '{name}' = {value!r}"):
        run.advance(1e-3, 1200.0, True, {**boundary, name: value})
    assert run.get_state() == before
