"""AHRI 540 rating maps: the fit recovers a known polynomial, bad input is refused before work, and on a small real
grid of the detailed real-gas model the polynomial reproduces held-out points within 1 %."""
import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters
from rotary_vane.mechanics.reduced.periodic_map import MapSettings
from rotary_vane.mechanics.reduced.rating import (LBM_PER_KG, ahri_terms, evaluate_ahri, fahrenheit, fit_ahri,
                                                  fit_report, rating_map, rating_parameters)


def test_fit_recovers_a_known_cubic_exactly():
    known = np.array([120.0, 1.5, -0.8, 0.012, -0.004, 0.006, 3e-5, -2e-5, 1e-5, -4e-6])
    s, d = np.meshgrid(np.linspace(-5.0, 55.0, 5), np.linspace(80.0, 145.0, 6))
    values = evaluate_ahri(known, s, d)
    # the polynomial written out term by term, independently of ahri_terms
    s, d = s.ravel(), d.ravel()
    by_hand = (known[0] + known[1] * s + known[2] * d + known[3] * s ** 2 + known[4] * s * d + known[5] * d ** 2
               + known[6] * s ** 3 + known[7] * d * s ** 2 + known[8] * s * d ** 2 + known[9] * d ** 3)
    assert np.allclose(values, by_hand, rtol=1e-13)
    assert np.allclose(fit_ahri(s, d, by_hand), known, rtol=1e-7, atol=1e-12)


def test_fit_needs_ten_points_and_units_are_ahri():
    with pytest.raises(ValueError, match="9 points"):
        fit_ahri(np.arange(9.0), np.arange(9.0) + 50, np.ones(9))
    assert ahri_terms([1.0], [2.0]).shape == (1, 10)
    assert fahrenheit(273.15) == pytest.approx(32.0) and fahrenheit(373.15) == pytest.approx(212.0)
    assert LBM_PER_KG == pytest.approx(2.20462262, rel=1e-8)


def test_bad_rating_point_is_refused_naming_the_value():
    base = CompressorParameters()
    with pytest.raises(ValueError, match="'superheat' = -1"):
        rating_parameters(base, 263.15, 313.15, -1.0)
    with pytest.raises(ValueError, match="'condensing' = 250"):
        rating_map(base, [(263.15, 313.15), (263.15, 250.0)], 10.0, 1500.0)
    params = rating_parameters(base, 263.15, 313.15, 10.0)
    assert params.pressure_model == "real_gas" and params.suction_temperature == pytest.approx(273.15)
    assert params.discharge_pressure > params.suction_pressure


@pytest.mark.slow
def test_polynomial_reproduces_held_out_points_of_the_detailed_model():
    """4 x 4 fitted dew points, the 3 x 3 cell centres held out: within 1 % (AHRI's purpose)."""
    e = np.linspace(-10.0, 10.0, 4) + 273.15
    c = np.linspace(30.0, 55.0, 4) + 273.15
    fit = [(a, b) for a in e for b in c]
    held = [(a, b) for a in 0.5 * (e[1:] + e[:-1]) for b in 0.5 * (c[1:] + c[:-1])]
    settings = MapSettings(table_speed_rpm=1500.0, warmup_revolutions=2, averaged_revolutions=2)
    results = rating_map(CompressorParameters(), fit + held, 10.0, 1500.0, settings, workers=1)
    points, held_out = results[:len(fit)], results[len(fit):]
    for quantity in ("mass_flow", "power"):
        report = fit_report(points, held_out, quantity)
        assert report.held_out_error < 0.01, (quantity, report)
    # trends: more flow at a warmer evaporator, more power at a warmer condenser
    flow = np.array([p["mass_flow"] for p in points]).reshape(4, 4)
    power = np.array([p["power"] for p in points]).reshape(4, 4)
    assert np.all(np.diff(flow, axis=0) > 0) and np.all(np.diff(power, axis=1) > 0)



def run_example(folder, *options):
    """python -m rotary_vane.examples.rating_map as a user runs it."""
    return subprocess.run([sys.executable, "-m", "rotary_vane.examples.rating_map", "--out", str(folder / "out"),
                           *options], capture_output=True, text=True, timeout=900, cwd=folder)


def test_example_refuses_a_grid_too_small_to_fit(tmp_path):
    result = run_example(tmp_path, "--evaporating", "-10", "10", "3")
    assert result.returncode == 2
    assert "--evaporating COUNT = 3 is invalid: allowed a whole number >= 4" in result.stderr


@pytest.mark.slow
def test_example_writes_coefficients_points_and_figure(tmp_path):
    result = run_example(tmp_path, "--evaporating", "-10", "10", "4", "--condensing", "30", "55", "4",
                         "--workers", "2")
    assert result.returncode == 0, result.stderr[-2000:]
    out = tmp_path / "out"
    summary = json.loads((out / "coefficients.json").read_text())
    for quantity in ("mass_flow", "power"):
        assert set(summary[quantity]["coefficients"]) == {f"C{k}" for k in range(1, 11)}
        assert summary[quantity]["held_out_worst_error"] < 0.01
    rows = list(csv.DictReader(open(out / "points.csv")))
    assert len(rows) == 16 + 9 and {r["role"] for r in rows} == {"fitted", "held_out"}
    assert len(list(csv.reader(open(out / "coefficients.csv")))) == 3
    assert (out / "rating_map.png").stat().st_size > 20000
