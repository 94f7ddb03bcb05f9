"""Periodic-map tables: interpolation against closed forms, the exact torque integral against quadrature, and the
disk cache (a changed parameter or source gives a new table, never a stale one)."""
import math
import shutil

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters
from rotary_vane.mechanics.reduced.periodic_map import (CHANNELS, FIGURES, PROJECT_DIR, TORQUE, MapSettings, MapTable,
                                                        build_map, cache_key, chord_deviation,
                                                        curvature_refinement)
from rotary_vane.kernels.compile_cache import PROJECT_PACKAGES

SAMPLES = 720


def synthetic_table(torque_of, other_of, speeds=(500.0, 1000.0, 2000.0)):
    """A table whose torque nodes are at (k + 1/2) dtheta and other nodes at k dtheta, from closed forms."""
    step = 2.0 * math.pi / SAMPLES
    angles = step * np.arange(SAMPLES)
    channels = {name: np.array([other_of(angles, s) for s in speeds]) for name in CHANNELS}
    channels[TORQUE] = np.array([torque_of(angles + 0.5 * step, s) for s in speeds])
    figures = {name: np.array([2.0 * s for s in speeds]) for name in FIGURES}
    return MapTable(speeds, channels, figures)


def test_linear_in_speed_and_angle_reproduced_exactly():
    """a + b s is exact between speeds; node values are exact; between two nodes the chord; period 2 pi."""
    table = synthetic_table(lambda a, s: 1.0 + 0.001 * s + np.sin(a), lambda a, s: 3.0 + 0.002 * s + np.cos(a))
    step = 2.0 * math.pi / SAMPLES
    for speed in (500.0, 750.0, 1234.5, 2000.0):
        assert table.value("leading_pressure", 5 * step, speed) == pytest.approx(3.0 + 0.002 * speed
                                                                                 + math.cos(5 * step), rel=1e-12)
        chord = 0.5 * (math.cos(5 * step) + math.cos(6 * step))
        assert table.value("vane_tilt", 5.5 * step, speed) == pytest.approx(3.0 + 0.002 * speed + chord, rel=1e-12)
        assert table.value("vane_tilt", 5.5 * step + 4 * math.pi, speed) == pytest.approx(
            table.value("vane_tilt", 5.5 * step, speed), rel=1e-12)
        assert table.figure("input_power", speed) == pytest.approx(2.0 * speed, rel=1e-12)
    # torque nodes sit at cell centres
    assert table.value(TORQUE, 2.5 * step, 1000.0) == pytest.approx(1.0 + 1.0 + math.sin(2.5 * step), rel=1e-12)


def test_outside_the_speed_grid_the_end_speeds_hold():
    table = synthetic_table(lambda a, s: s + 0 * a, lambda a, s: s + np.sin(a))
    assert table.value("vane_tilt", 1.0, 100.0) == pytest.approx(table.value("vane_tilt", 1.0, 500.0), rel=1e-15)
    assert table.value("vane_tilt", 1.0, 5000.0) == pytest.approx(table.value("vane_tilt", 1.0, 2000.0), rel=1e-15)
    assert table.figure("output_power", 0.0) == pytest.approx(1000.0)


@pytest.mark.parametrize("start, end, speed", [(0.1, 0.2, 500.0), (-3.0, 11.0, 800.0), (1.0, 1.0 + 1e-5, 1999.0),
                                               (6.2, 6.4, 1500.0), (0.0, 2 * math.pi, 700.0)])
def test_torque_integral_is_the_quadrature_of_the_interpolant(start, end, speed):
    """Exact integral vs dense trapezoid over the interpolant sampled at every node and 20 points per cell."""
    rng = np.random.default_rng(3)
    noise = rng.normal(size=(3, SAMPLES))
    table = synthetic_table(lambda a, s: 2.0 + np.sin(3 * a) + 0.2 * noise[int(s > 600) + int(s > 1500)],
                            lambda a, s: 0 * a)
    grid = np.linspace(start, end, max(3, int(abs(end - start) / table.step * 20) + 2))
    nodes = (np.arange(math.floor(start / table.step) - 1, math.ceil(end / table.step) + 2) + 0.5) * table.step
    grid = np.union1d(grid, nodes[(nodes > start) & (nodes < end)])
    values = np.array([table.value(TORQUE, a, speed) for a in grid])
    quadrature = float(np.trapezoid(values, grid))       # exact for a piecewise-linear function with its kinks
    assert table.torque_integral(start, end, speed) == pytest.approx(quadrature, rel=1e-10, abs=1e-12)


def test_revolution_integral_is_the_sum_of_cell_means():
    """Over 2 pi the interpolant integrates to dtheta sum T_k: the work the cell means came from."""
    rng = np.random.default_rng(5)
    torque = rng.normal(size=(3, SAMPLES)) + 4.0
    table = synthetic_table(lambda a, s: torque[[500.0, 1000.0, 2000.0].index(s)], lambda a, s: 0 * a)
    for start in (0.0, 0.37, -10.0):
        assert table.torque_integral(start, start + 2 * math.pi, 1000.0) == pytest.approx(
            table.step * torque[1].sum(), rel=1e-12)


def test_curvature_refinement_adds_midpoints_only_where_it_curves():
    speeds = np.linspace(100.0, 800.0, 8)
    line = chord_deviation(speeds, 3.0 * speeds + 1.0, 1.0)
    assert np.allclose(line, 0.0, atol=1e-12) and curvature_refinement(speeds, line, 4, 1e-3).size == 0
    knee = np.minimum(speeds, 450.0)
    deviation = chord_deviation(speeds, knee, 1.0)
    assert deviation.tolist() == pytest.approx([0, 0, 25.0, 25.0, 0, 0], abs=1e-12)
    # waveforms: the RMS over the angle of the same chord error
    waves = np.outer(knee, np.ones(4)) * np.array([1.0, -1.0, 1.0, -1.0])
    assert chord_deviation(speeds, waves, 1.0) == pytest.approx(deviation, abs=1e-12)
    added = curvature_refinement(speeds, deviation, 4, 1.0)
    assert added.tolist() == [350.0, 450.0, 550.0]     # both nodes beside the knee (400, 500) deviate


def settings():
    return MapSettings(table_speed_rpm=1500.0, warmup_revolutions=1, averaged_revolutions=1)


def test_cache_key_changes_with_a_parameter_a_setting_and_a_source(tmp_path):
    base = CompressorParameters()
    key = cache_key(base, [1500.0], settings())
    assert key == cache_key(CompressorParameters(), [1500.0], settings())
    assert key != cache_key(CompressorParameters(slot_clearance=base.slot_clearance + 1e-6), [1500.0], settings())
    assert key != cache_key(base, [1500.0, 1600.0], settings())
    assert key != cache_key(base, [1500.0], MapSettings(table_speed_rpm=1500.0, warmup_revolutions=2,
                                                        averaged_revolutions=1))
    copy = tmp_path / "project"
    for package in PROJECT_PACKAGES:
        shutil.copytree(PROJECT_DIR / package, copy / package, ignore=shutil.ignore_patterns("__pycache__"))
    assert cache_key(base, [1500.0], settings(), copy) == key
    target = copy / "mechanics" / "contact" / "detection.py"
    target.write_text(target.read_text() + "\n# a changed source\n")
    assert cache_key(base, [1500.0], settings(), copy) != key


def test_built_table_is_cached_never_stale_and_carries_the_detailed_work(tmp_path):
    """Second call loads (same arrays); a changed parameter builds a new table; the table's work over a
    revolution is the detailed model's input power x period."""
    params = CompressorParameters()
    first = build_map(params, [1500.0], settings=settings(), workers=1, cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 1
    again = build_map(params, [1500.0], settings=settings(), workers=1, cache_dir=tmp_path)
    assert np.array_equal(again.channels[TORQUE], first.channels[TORQUE])
    changed = build_map(CompressorParameters(discharge_pressure=params.discharge_pressure * 1.1), [1500.0],
                        settings=settings(), workers=1, cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 2
    assert changed.figure("input_power", 1500.0) > 1.02 * first.figure("input_power", 1500.0)
    period = 2 * math.pi / (1500.0 * 2 * math.pi / 60)
    assert first.torque_integral(0.0, 2 * math.pi, 1500.0) == pytest.approx(
        first.figure("input_power", 1500.0) * period, rel=1e-6)
    assert first.samples >= 720


def test_vectorised_evaluation_is_the_single_channel_one():
    table = synthetic_table(lambda a, s: 1.0 + 0.001 * s + np.sin(a), lambda a, s: 3.0 + 0.002 * s + np.cos(2 * a))
    for angle, speed in ((0.3, 700.0), (-7.1, 1999.0), (100.0, 50.0)):
        values = table.values(angle, speed)
        assert values == {name: pytest.approx(table.value(name, angle, speed), rel=1e-13) for name in CHANNELS}
        assert table.figures_at(speed) == {name: pytest.approx(table.figure(name, speed)) for name in FIGURES}
