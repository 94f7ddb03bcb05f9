"""thermo.operating_point: what a real-gas run takes from CoolProp, cached on disk (docs/model.md §7.1, §6.4, §7.4).

References are CoolProp itself, called here directly (PropsSI and AbstractState: the HmassP flash for the discharge
temperature, PT flashes for exact (h, T) pairs on the isobar), and the functions the point must agree with
(`envelope_for`, the messages of `Fluid` and `check_operating_point`). Every cache lives in a temporary folder; the
start-up test runs two fresh processes with `sys.executable`.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import CoolProp
import numpy as np
import pytest
from CoolProp.CoolProp import PropsSI

from rotary_vane.thermo.fluid import SUPERHEAT_MARGIN, Fluid, check_operating_point, typical_operating_point
from rotary_vane.thermo.operating_point import operating_point_for
from rotary_vane.thermo.property_table import envelope_for, property_table_for, property_table_path

REPO_ROOT = Path(__file__).resolve().parents[2]
FLUIDS = ("R134a", "Air", "CO2", "R410A", "R1234yf", "R290")
R134A = ("R134a", 0.2928e6, 283.15, 1.3179e6)                # docs/model.md §7.1
SMALL_GRID = (40, 40)


@pytest.fixture(scope="module")
def points(cache_dir):
    """name -> (p_s, T_s, p_d, point) at the fluid's typical operating point, computed on first use."""
    made = {}

    def point(name):
        if name not in made:
            operating = typical_operating_point(Fluid(name))
            made[name] = (*operating, operating_point_for(name, *operating, cache_dir=cache_dir))
        return made[name]
    return point


def dome_temperature(name, pressure):
    """T_dew(p) from CoolProp, T_crit at or above the critical pressure."""
    if pressure >= PropsSI("PCRIT", name):
        return PropsSI("TCRIT", name)
    return PropsSI("T", "P", pressure, "Q", 1.0, name)


def isobar_enthalpy(state, pressure, temperature):
    """h(p, T) exactly: CoolProp's PT flash leaves p(T, rho) off by up to 1e-8 relative, so its rho is refined by
    Newton steps on p(T, rho) = p with the explicit equation of state at (T, rho)."""
    state.update(CoolProp.PT_INPUTS, pressure, temperature)
    density = state.rhomass()
    for _ in range(3):
        state.update(CoolProp.DmassT_INPUTS, density, temperature)
        density -= (state.p() - pressure) / state.first_partial_deriv(CoolProp.iP, CoolProp.iDmass, CoolProp.iT)
    state.update(CoolProp.DmassT_INPUTS, density, temperature)
    assert abs(state.p() / pressure - 1.0) < 1e-13
    return state.hmass()


def same_point(first, second):
    for name, value in first._asdict().items():
        np.testing.assert_array_equal(value, getattr(second, name), err_msg=name)


# ---------------------------------------------------------------------------------------------------------------
# content

@pytest.mark.parametrize("name", ("R134a", "Air", "CO2"))
def test_point_agrees_with_coolprop(points, name, check):
    p_s, t_s, p_d, point = points(name)
    assert (point.fluid, point.suction_pressure, point.suction_temperature, point.discharge_pressure,
            point.superheat_margin) == (name, p_s, t_s, p_d, SUPERHEAT_MARGIN)
    assert point.coolprop_name == CoolProp.AbstractState("HEOS", name).fluid_param_string("name")
    density = PropsSI("D", "P", p_s, "T", t_s, name)
    entropy = PropsSI("S", "P", p_s, "T", t_s, name)
    # PropsSI evaluates h and s in the PT flash itself, the point at (T_s, rho_s) after it: round-off apart
    check(f"{name} suction density", abs(point.suction_density / density - 1.0), 1e-10)
    check(f"{name} suction enthalpy", abs(point.suction_enthalpy / PropsSI("H", "P", p_s, "T", t_s, name) - 1.0),
          1e-10)
    check(f"{name} suction entropy", abs(point.suction_entropy / entropy - 1.0), 1e-10)
    check(f"{name} h_2s", abs(point.isentropic_discharge_enthalpy / PropsSI("H", "P", p_d, "S", entropy, name) - 1.0),
          1e-9)
    gas_constant = 8.314462618 / PropsSI("M", name)                             # CODATA R over CoolProp's M
    check(f"{name} R", abs(point.gas_constant / gas_constant - 1.0), 1e-7)
    heat_capacity = PropsSI("CP0MASS", "P", p_s, "T", t_s, name)
    check(f"{name} ideal-gas k", abs(point.ideal_gas_exponent / (heat_capacity / (heat_capacity - gas_constant)) - 1.0),
          1e-6)
    assert point.critical_temperature == PropsSI("TCRIT", name)
    check(f"{name} superheat", abs(point.superheat - (t_s - dome_temperature(name, p_s))), 1e-6)
    assert point.envelope == envelope_for(Fluid(name), p_s, t_s, p_d)


@pytest.mark.parametrize("name", FLUIDS)
def test_discharge_temperature_agrees_with_coolprop_over_the_envelope(points, name, check):
    """T(p_d, h) within 1e-6 K of CoolProp's HmassP flash (whose own convergence error is up to 4e-7 K) at 2000
    enthalpies spanning the isobar p_d from max(T_min, T_dome(p_d) + 1 K) to T_max, and within 5e-8 K of exact
    (T, h) pairs of the isobar at 500 random T; NaN just outside that range (the ends are checked to the round-off
    of the dew temperature)."""
    _, _, p_d, point = points(name)
    low = max(point.envelope.temperature_min, dome_temperature(name, p_d) + SUPERHEAT_MARGIN)
    high = point.envelope.temperature_max
    h_low, h_high = (PropsSI("H", "P", p_d, "T", t, name) for t in (low, high))
    check(f"{name} lowest tabulated h", abs(point.discharge_enthalpies[0] / h_low - 1.0), 1e-9)
    check(f"{name} highest tabulated h", abs(point.discharge_enthalpies[-1] / h_high - 1.0), 1e-9)
    state = CoolProp.AbstractState("HEOS", name)
    rng = np.random.default_rng(3)
    worst_flash = worst_pairs = 0.0
    for enthalpy in np.linspace(h_low, h_high, 2000):
        state.update(CoolProp.HmassP_INPUTS, enthalpy, p_d)
        worst_flash = max(worst_flash, abs(point.discharge_temperature(enthalpy) - state.T()))
    for temperature in rng.uniform(low, high, 500):
        worst_pairs = max(worst_pairs, abs(point.discharge_temperature(isobar_enthalpy(state, p_d, temperature))
                                           - temperature))
    check(f"{name} T(p_d, h) vs HmassP flash", worst_flash, 1e-6)
    check(f"{name} T(p_d, h) vs exact isobar", worst_pairs, 5e-8)
    assert math.isnan(point.discharge_temperature(point.discharge_enthalpies[0] - 1.0))
    assert math.isnan(point.discharge_temperature(point.discharge_enthalpies[-1] + 1.0))


# ---------------------------------------------------------------------------------------------------------------
# validation: the checks and messages of Fluid and check_operating_point

BAD_POINTS = [
    ("R134x", 0.2928e6, 283.15, 1.3179e6),          # unknown fluid
    ("R32&R125", 1e6, 300.0, 2e6),                  # a mixture
    ("", 1e5, 300.0, 2e5),
    ("R134a", -0.2928e6, 283.15, 1.3179e6),
    ("R134a", 0.2928e6, 0.0, 1.3179e6),
    ("R134a", 0.2928e6, None, 1.3179e6),
    ("R134a", 0.2928e6, 283.15, float("nan")),
    ("R134a", 0.2928e6, 283.15, 0.2928e6),         # p_d = p_s
    ("R134a", 292803.0, 273.15, 1.3179e6),         # wet suction: at the dew point
    ("R134a", 0.2928e6, 283.15, 1e9),              # above the equation of state's p_max
    ("R134a", 0.2928e6, 600.0, 1.3179e6),          # above its T_max
    ("CO2", 8e6, 300.0, 12e6),                      # above p_crit and below T_crit + 1 K
]


@pytest.mark.parametrize("bad", BAD_POINTS, ids=lambda bad: repr(bad))
def test_bad_points_raise_the_messages_of_fluid_and_check_operating_point(tmp_path, bad):
    name, *numbers = bad
    with pytest.raises(ValueError) as expected:
        check_operating_point(Fluid(name), *numbers)
    with pytest.raises(ValueError) as raised:
        operating_point_for(name, *numbers, cache_dir=tmp_path)
    assert str(raised.value) == str(expected.value)
    assert type(raised.value) is type(expected.value)
    assert "allowed" in str(raised.value)
    assert list(tmp_path.iterdir()) == []                                   # only valid points are cached


# ---------------------------------------------------------------------------------------------------------------
# disk cache

def cached_files(folder):
    return sorted(folder.glob("*-operating-point-*.json"))


def file_identity(path):
    stat = os.stat(path)
    return stat.st_ino, stat.st_mtime_ns, stat.st_size


def test_point_is_cached_as_json_and_reloaded_identically(tmp_path):
    first = operating_point_for(*R134A, cache_dir=tmp_path)
    [path] = cached_files(tmp_path)
    assert path.name.startswith("R134a-operating-point-")
    stored = json.loads(path.read_text())
    assert stored["point"]["suction_density"] == first.suction_density
    before = file_identity(path)
    second = operating_point_for(*R134A, cache_dir=tmp_path)
    assert file_identity(path) == before
    same_point(first, second)
    same_point(first, operating_point_for(*R134A, cache_dir=tmp_path / "fresh"))
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name, "fresh"]        # no temporary files left


def test_key_holds_the_inputs_and_the_installed_coolprop_version(tmp_path, monkeypatch):
    # the version comes from the distribution's metadata: it must name the CoolProp that is imported
    from rotary_vane.thermo import fluid
    assert fluid.coolprop_version() == CoolProp.__version__
    operating_point_for(*R134A, cache_dir=tmp_path)
    operating_point_for("R134a", 0.2928e6, 283.15, 1.3179e6, superheat_margin=2.0, cache_dir=tmp_path)
    operating_point_for("R134a", 0.2928e6, 284.15, 1.3179e6, cache_dir=tmp_path)
    assert len(cached_files(tmp_path)) == 3
    monkeypatch.setattr("rotary_vane.thermo.operating_point.coolprop_version", lambda: "0.0.0-another")
    operating_point_for(*R134A, cache_dir=tmp_path)
    assert len(cached_files(tmp_path)) == 4


def test_another_name_of_the_same_fluid_gets_its_own_file_and_the_same_figures(tmp_path):
    short = operating_point_for("CO2", 3.5e6, 283.15, 10e6, cache_dir=tmp_path)
    canonical = operating_point_for("CarbonDioxide", 3.5e6, 283.15, 10e6, cache_dir=tmp_path)
    assert len(cached_files(tmp_path)) == 2
    assert (short.fluid, canonical.fluid, short.coolprop_name) == ("CO2", "CarbonDioxide", "CarbonDioxide")
    same_point(short._replace(fluid=""), canonical._replace(fluid=""))


def damage(path, how, other):
    stored = json.loads(path.read_text())
    if how == "garbage":
        path.write_bytes(b"not an operating point")
    elif how == "truncated":
        path.write_bytes(path.read_bytes()[:3000])
    elif how == "another point":
        shutil.copy(other, path)
    elif how == "a field of another type":
        stored["point"]["suction_density"] = str(stored["point"]["suction_density"])
        path.write_text(json.dumps(stored))
    elif how == "a missing field":
        del stored["point"]["isentropic_discharge_enthalpy"]
        path.write_text(json.dumps(stored))
    elif how == "a NaN":
        stored["point"]["envelope"]["temperature_max"] = float("nan")
        path.write_text(json.dumps(stored))
    elif how == "a table out of order":
        stored["point"]["discharge_enthalpies"].reverse()
        path.write_text(json.dumps(stored))


@pytest.mark.parametrize("how", ["garbage", "truncated", "another point", "a field of another type",
                                 "a missing field", "a NaN", "a table out of order"])
def test_damaged_or_foreign_file_is_rebuilt_with_a_warning(tmp_path, how):
    point = operating_point_for(*R134A, cache_dir=tmp_path)
    operating_point_for("Air", 101325.0, 293.15, 5e5, cache_dir=tmp_path / "other")
    [path], [other] = cached_files(tmp_path), cached_files(tmp_path / "other")
    damage(path, how, other)
    with pytest.warns(RuntimeWarning, match="operating point cache .* is unreadable"):
        rebuilt = operating_point_for(*R134A, cache_dir=tmp_path)
    same_point(rebuilt, point)
    repaired = file_identity(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        same_point(operating_point_for(*R134A, cache_dir=tmp_path), point)
    assert file_identity(path) == repaired


def test_unwritable_cache_folder_warns_and_the_point_is_still_computed(tmp_path):
    blocked = tmp_path / "a file"
    blocked.write_text("a file where the cache folder should be")
    with pytest.warns(RuntimeWarning, match="cannot write the operating point cache"):
        point = operating_point_for(*R134A, cache_dir=blocked)
    same_point(point, operating_point_for(*R134A, cache_dir=tmp_path / "cache"))


def test_property_table_of_a_point_loads_without_making_a_fluid(tmp_path, monkeypatch):
    """property_table_for(point, ...) names the same file as with the Fluid; once it is cached, no Fluid (and so no
    CoolProp) is made to load it."""
    point = operating_point_for(*R134A, cache_dir=tmp_path)
    fluid = Fluid("R134a")
    built = property_table_for(fluid, point.envelope, *SMALL_GRID, cache_dir=tmp_path)
    assert (property_table_path(point, point.envelope, *SMALL_GRID, cache_dir=tmp_path)
            == property_table_path(fluid, point.envelope, *SMALL_GRID, cache_dir=tmp_path))

    def no_fluid(self, name):
        raise AssertionError(f"Fluid({name!r}) was made for a cached table")
    monkeypatch.setattr(Fluid, "__init__", no_fluid)
    loaded = property_table_for(point, point.envelope, *SMALL_GRID, cache_dir=tmp_path)
    np.testing.assert_array_equal(loaded.nodes, built.nodes)
    with pytest.raises(AssertionError, match="was made"):                     # not cached: the table is built
        property_table_for(point, point.envelope, *SMALL_GRID, cache_dir=tmp_path / "empty")


# ---------------------------------------------------------------------------------------------------------------
# start-up of a fresh process

START_UP = """
import json, sys
from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
params = CompressorParameters(pressure_model="real_gas", slot_clearance=5e-5, stator_clearance=5e-5)
sim = Simulation(params, constant_speed(1500.0), keep_history=False)
sim.advance(1e-3)
print(json.dumps({"coolprop": "CoolProp" in sys.modules, "state": sim.state.tolist()}))
"""


@pytest.mark.slow
def test_second_process_runs_real_gas_without_importing_coolprop(tmp_path):
    """Two fresh processes build and advance the default real-gas Simulation with one cache folder: the first
    computes (CoolProp imported), the second loads the operating point and the property table and never imports
    CoolProp, with the same state after 1 ms."""
    results = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", START_UP], cwd=REPO_ROOT, capture_output=True, text=True,
                              env=dict(os.environ, ROTARY_VANE_CACHE_DIR=str(tmp_path)), timeout=900)
        assert done.returncode == 0, done.stderr
        results.append(json.loads(done.stdout.strip().splitlines()[-1]))
    assert [result["coolprop"] for result in results] == [True, False]
    assert results[0]["state"] == results[1]["state"]
    assert len(cached_files(tmp_path / "properties")) == 1
