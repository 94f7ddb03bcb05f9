"""thermo.property_table: the numba (T, ln rho) table of p, h, c_v, (dp/dT)_rho (docs/model.md §7.3) against CoolProp HEOS.

The reference is `Fluid.properties`, CoolProp HEOS with its own phase determination at the query point (the table
is built from the gas branch at the nodes only). Every table here lives in a temporary cache folder.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from rotary_vane.thermo.disk_cache import property_cache_dir
from rotary_vane.thermo.fluid import Fluid, typical_operating_point
from rotary_vane.thermo.property_table import (STATUS_DENSITY_ABOVE_TABLE, STATUS_DENSITY_BELOW_TABLE, STATUS_INACCURATE_CELL,
                                   STATUS_INVALID_STATE, STATUS_NEAR_SATURATION, STATUS_OK,
                                   STATUS_TEMPERATURE_ABOVE_TABLE, STATUS_TEMPERATURE_BELOW_TABLE, Envelope,
                                   build_property_table, describe_status, dome_log_density_limit, envelope_for,
                                   property_table_for, property_table_path,
                                   table_ideal_gas_exponent, table_properties, table_status)

REPO_ROOT = Path(__file__).resolve().parents[2]
ACCURACY = {"pressure": 1e-5, "enthalpy": 1e-5, "isochoric_heat_capacity": 1e-4,
            "pressure_temperature_derivative": 1e-4}
MAIN_FLUIDS = ("R134a", "Air", "CO2")
LIGHT_FLUIDS = ("R410A", "R1234yf", "R290")


@pytest.fixture(scope="module")
def tables(tables_for):
    """name -> (fluid, envelope, table), built on first use."""
    return tables_for(property_table_for, typical_operating_point)


def exact(fluid, temperature, density):
    e = fluid.properties(temperature, density)
    return np.array([e.pressure, e.enthalpy, e.isochoric_heat_capacity, e.pressure_temperature_derivative])


def random_states(envelope, count, rng):
    temperature = rng.uniform(envelope.temperature_min, envelope.temperature_max, count)
    density = np.exp(rng.uniform(math.log(envelope.density_min), math.log(envelope.density_max), count))
    return temperature, density


def states_near_the_limit(fluid, envelope, count, rng):
    """States just inside the accepted region: below the dome limit x_lim(T) or the top of the density range."""
    temperature = rng.uniform(envelope.temperature_min, envelope.temperature_max, count)
    top = np.array([min(dome_log_density_limit(fluid, t, envelope.superheat_margin), math.log(envelope.density_max))
                    for t in temperature])
    return temperature, np.exp(top - rng.uniform(0.0, 0.05, count))


def compare(fluid, envelope, table, temperature, density, check, label):
    """Worst relative error of each property over the accepted states; accepted states are superheated by at
    least the margin. Returns the number of accepted states."""
    worst = np.zeros(4)
    accepted = 0
    for t, rho in zip(temperature, density):
        *values, status = table_properties(t, rho, table)
        if status != STATUS_OK:
            assert all(math.isnan(v) for v in values)
            continue
        accepted += 1
        reference = exact(fluid, t, rho)
        worst = np.maximum(worst, np.abs(np.array(values) / reference - 1.0))
        assert fluid.superheat(t, reference[0]) >= envelope.superheat_margin - 1e-9, (t, rho)
    for name, error in zip(ACCURACY, worst):
        check(f"table vs HEOS {label} {fluid.name} {name}", error, ACCURACY[name])
    return accepted


@pytest.mark.parametrize("name", MAIN_FLUIDS)
def test_table_agrees_with_heos_over_the_envelope(tables, name, check):
    fluid, envelope, table = tables(name)
    rng = np.random.default_rng(7)
    assert compare(fluid, envelope, table, *random_states(envelope, 1500, rng), check, "uniform") > 700
    assert compare(fluid, envelope, table, *states_near_the_limit(fluid, envelope, 700, rng), check,
                   "near the dome/top") > 500


@pytest.mark.parametrize("name", LIGHT_FLUIDS)
def test_other_fluids_build_and_agree(tables, name, check):
    fluid, envelope, table = tables(name)
    rng = np.random.default_rng(11)
    assert compare(fluid, envelope, table, *random_states(envelope, 200, rng), check, "light") > 80


def test_refused_cells_near_the_critical_point_and_accurate_elsewhere(cache_dir, check):
    # a coarse table over CO2's near-critical region: the build check must refuse the cells it cannot represent
    co2 = Fluid("CO2")
    envelope = Envelope(co2.critical_temperature - 20.0, co2.critical_temperature + 60.0, 50.0, 800.0, 1.0)
    table = build_property_table(co2, envelope, 60, 60)
    rng = np.random.default_rng(3)
    temperature, density = random_states(envelope, 1500, rng)
    statuses = [table_status(t, rho, table) for t, rho in zip(temperature, density)]
    assert statuses.count(STATUS_INACCURATE_CELL) > 50
    assert compare(co2, envelope, table, temperature, density, check, "coarse near-critical") > 700
    refused = [(t, rho) for t, rho, s in zip(temperature, density, statuses) if s == STATUS_INACCURATE_CELL]
    assert min(abs(t - co2.critical_temperature) for t, _ in refused) < 5.0


def test_status_codes_inside_the_dome_and_outside_the_envelope(tables):
    fluid, envelope, table = tables("R134a")
    margin = envelope.superheat_margin
    for temperature in np.linspace(envelope.temperature_min + 2.0, fluid.critical_temperature - 5.0, 25):
        dew_density = fluid.dew_density(temperature)
        if dew_density < envelope.density_max:                   # two-phase: just inside the dome
            assert table_status(temperature, min(1.05 * dew_density, envelope.density_max), table) \
                == STATUS_NEAR_SATURATION
        # superheated by half the margin / by the margin plus 1 K
        for superheat, expected in ((0.5 * margin, STATUS_NEAR_SATURATION), (margin + 1.0, STATUS_OK)):
            density = fluid.density(temperature, fluid.dew_pressure(temperature - superheat))
            if density < envelope.density_max:
                assert table_status(temperature, density, table) == expected, (temperature, superheat)
    middle_t = 0.5 * (envelope.temperature_min + envelope.temperature_max)
    middle_rho = math.sqrt(envelope.density_min * envelope.density_max)
    cases = [((envelope.temperature_min - 0.5, middle_rho), STATUS_TEMPERATURE_BELOW_TABLE),
             ((envelope.temperature_max + 0.5, middle_rho), STATUS_TEMPERATURE_ABOVE_TABLE),
             ((middle_t, 0.99 * envelope.density_min), STATUS_DENSITY_BELOW_TABLE),
             ((envelope.temperature_max - 0.5, 1.01 * envelope.density_max), STATUS_DENSITY_ABOVE_TABLE),
             ((float("nan"), middle_rho), STATUS_INVALID_STATE), ((middle_t, 0.0), STATUS_INVALID_STATE),
             ((-middle_t, middle_rho), STATUS_INVALID_STATE), ((middle_t, float("nan")), STATUS_INVALID_STATE),
             ((envelope.temperature_max, envelope.density_max), STATUS_OK),
             ((envelope.temperature_max, envelope.density_min), STATUS_OK)]
    for (temperature, density), expected in cases:
        *values, status = table_properties(temperature, density, table)
        assert status == expected, (temperature, density)
        assert all(math.isnan(v) for v in values) == (status != STATUS_OK)


@pytest.mark.parametrize("name", MAIN_FLUIDS)
def test_envelope_holds_the_compressor_states(tables, name):
    """Suction, the isentropic discharge at p_d, over-compression to 1.5 p_d and 50 K above the isentrope, and
    re-expansion to 0.5 p_s: inside the table unless HEOS says the state is within 1 K + margin of the dome."""
    fluid, envelope, table = tables(name)
    suction_pressure, suction_temperature, discharge_pressure = typical_operating_point(fluid)
    entropy = fluid.properties(suction_temperature, fluid.density(suction_temperature, suction_pressure)).entropy
    discharge = fluid.state_at_pressure_entropy(discharge_pressure, entropy)
    over = fluid.state_at_pressure_entropy(1.5 * discharge_pressure, entropy)
    expanded = fluid.state_at_pressure_entropy(0.5 * suction_pressure, entropy)
    states = [(suction_temperature, fluid.density(suction_temperature, suction_pressure)),
              (discharge.temperature, discharge.density), (over.temperature, over.density),
              (over.temperature + 50.0, fluid.density(over.temperature + 50.0, 1.5 * discharge_pressure)),
              (expanded.temperature, expanded.density)]
    for temperature, density in states:
        vapour = fluid.vapour_quality(temperature, density) is None
        superheated = vapour and fluid.superheat(temperature, fluid.properties(temperature, density).pressure) \
            >= envelope.superheat_margin + 1.0
        assert table_status(temperature, density, table) == (STATUS_OK if superheated else STATUS_NEAR_SATURATION)


@pytest.mark.parametrize("name", MAIN_FLUIDS)
def test_table_is_thermodynamically_consistent(tables, name, check):
    """(dp/dT)_rho equals the T-derivative of the table's own p, and c_v = (dh/dT)_rho - (dp/dT)_rho / rho
    (h = u + p/rho), both by central differences of the interpolant."""
    fluid, envelope, table = tables(name)
    rng = np.random.default_rng(5)
    step = 1e-3 * (envelope.temperature_max - envelope.temperature_min) / 159
    worst_slope = worst_heat = 0.0
    for temperature, density in zip(*random_states(envelope, 500, rng)):
        above = table_properties(temperature + step, density, table)
        below = table_properties(temperature - step, density, table)
        here = table_properties(temperature, density, table)
        if above[4] or below[4] or here[4]:
            continue
        worst_slope = max(worst_slope, abs((above[0] - below[0]) / (2 * step) / here[3] - 1.0))
        heat = (above[1] - below[1]) / (2 * step) - here[3] / density
        worst_heat = max(worst_heat, abs(heat / here[2] - 1.0))
    check(f"table dp/dT vs its own p, {name}", worst_slope, 1e-5)
    check(f"table c_v vs its own h and p, {name}", worst_heat, 1e-4)


def test_ideal_gas_exponent_from_the_table(tables, check):
    fluid, envelope, table = tables("R134a")
    worst = max(abs(table_ideal_gas_exponent(t, table) / fluid.ideal_gas_exponent(t) - 1.0)
                for t in np.linspace(envelope.temperature_min, envelope.temperature_max, 97))
    check("table k vs HEOS c_p0", worst, 5e-6)
    assert math.isnan(table_ideal_gas_exponent(envelope.temperature_max + 1.0, table))


def test_status_messages_say_which_state_and_why(tables):
    fluid, envelope, table = tables("R134a")
    wet = (275.0, 1.5 * fluid.dew_density(275.0))
    message = describe_status(table_status(*wet, table), *wet, table, fluid, state="leading chamber")
    assert "leading chamber" in message and "275" in message and "two-phase dome" in message
    assert "vapour quality" in message
    close = (300.0, fluid.density(300.0, fluid.dew_pressure(299.6)))
    message = describe_status(table_status(*close, table), *close, table, fluid, state="trailing chamber")
    assert "superheat 0.4" in message and "trailing chamber" in message
    hot = (envelope.temperature_max + 10.0, 10.0)
    message = describe_status(table_status(*hot, table), *hot, table, state="idle chamber 2")
    assert "above the property table's range" in message and f"{envelope.temperature_max:.6g}" in message
    assert "not a physical state" in describe_status(STATUS_INVALID_STATE, float("nan"), 1.0, table)
    assert "critical point" in describe_status(STATUS_INACCURATE_CELL, 310.0, 400.0, table)


@pytest.mark.parametrize("name, suction_pressure, suction_temperature, discharge_pressure",
                         [("R134a", 0.2928e6, 283.15, 1.3179e6), ("Air", 565400.0, 591.9, 696900.0)])
def test_the_envelope_holds_every_chamber_state_up_to_four_discharge_pressures(name, suction_pressure,
                                                                              suction_temperature, discharge_pressure):
    """docs/model.md §7.3 (density bound): a chamber state has at least the suction entropy, so at pressure p it is
    no denser than the suction isentrope; every such state from p_d to 4 p_d (within the equation of state's
    range) lies within the per-point envelope's density and temperature bounds. The Air point is the machine of
    the sweep whose leading chamber was stopped by the former bound at 3.1 p_d."""
    fluid = Fluid(name)
    envelope = envelope_for(fluid, suction_pressure, suction_temperature, discharge_pressure)
    entropy = fluid.properties(suction_temperature, fluid.density(suction_temperature, suction_pressure)).entropy
    checked = 0
    for pressure in np.geomspace(discharge_pressure, 4.0 * discharge_pressure, 12):
        isentrope = fluid.state_at_pressure_entropy(pressure, entropy)
        if isentrope.temperature > fluid.maximum_temperature:
            continue                                         # beyond the equation of state: no table holds it
        assert isentrope.density <= envelope.density_max * (1.0 + 1e-12), (pressure, isentrope)
        assert envelope.temperature_min <= isentrope.temperature, (pressure, isentrope)
        checked += 1
    assert checked >= 6


def test_bad_inputs_name_the_variable(tables):
    fluid, envelope, _ = tables("R134a")
    with pytest.raises(ValueError, match=r"discharge_pressure=.*allowed: > suction_pressure"):
        envelope_for(fluid, 3e5, 283.15, 2e5)
    with pytest.raises(ValueError, match=r"suction_temperature=.*dew temperature"):
        envelope_for(fluid, 0.2928e6, 273.5, 1.3179e6)
    with pytest.raises(ValueError, match=r"temperature_nodes=3 .*integer >= 4"):
        build_property_table(fluid, envelope, 3, 40)
    with pytest.raises(ValueError, match=r"envelope temperature range .*validity range"):
        build_property_table(fluid, envelope._replace(temperature_max=fluid.maximum_temperature + 10.0), 8, 8)
    with pytest.raises(ValueError, match=r"envelope temperature range .*min < max"):
        build_property_table(fluid, envelope._replace(temperature_min=envelope.temperature_max), 8, 8)
    with pytest.raises(ValueError, match=r"envelope.density_min=-1.0 .*> 0"):
        build_property_table(fluid, envelope._replace(density_min=-1.0), 8, 8)
    with pytest.raises(ValueError, match=r"envelope.density_max=.*> envelope.density_min"):
        build_property_table(fluid, envelope._replace(density_max=envelope.density_min), 8, 8)
    with pytest.raises(ValueError, match=r"envelope=.*thermo.Envelope"):
        build_property_table(fluid, tuple(envelope), 8, 8)


# ---------------------------------------------------------------------------------------------------------------
# disk cache

SMALL_GRID = (40, 40)
SUBPROCESS_SCRIPT = """
import json, sys
import numpy as np
from rotary_vane.thermo.fluid import Fluid
from rotary_vane.thermo.property_table import envelope_for, property_table_for, property_table_path
fluid = Fluid("R134a")
envelope = envelope_for(fluid, 0.2928e6, 283.15, 1.3179e6)
cache_dir = sys.argv[1] if len(sys.argv) > 1 else None
table = property_table_for(fluid, envelope, 40, 40, cache_dir=cache_dir)
print(json.dumps({"path": str(property_table_path(fluid, envelope, 40, 40, cache_dir)),
                  "checksum": float(np.nansum(np.abs(table.nodes)))}))
"""


def run_script(arguments, environment):
    done = subprocess.run([sys.executable, "-c", SUBPROCESS_SCRIPT, *arguments], cwd=REPO_ROOT, env=environment,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def file_identity(path):
    stat = os.stat(path)
    return stat.st_ino, stat.st_mtime_ns, stat.st_size


def small_r134a_table(cache_dir):
    fluid = Fluid("R134a")
    envelope = envelope_for(fluid, 0.2928e6, 283.15, 1.3179e6)
    return fluid, envelope, property_table_for(fluid, envelope, *SMALL_GRID, cache_dir=cache_dir)


def test_second_process_loads_the_cached_table(tmp_path, monkeypatch):
    monkeypatch.setenv("ROTARY_VANE_CACHE_DIR", str(tmp_path))
    assert property_cache_dir() == tmp_path / "properties"
    fluid, envelope, table = small_r134a_table(None)
    path = property_table_path(fluid, envelope, *SMALL_GRID)
    assert path.parent == tmp_path / "properties" and path.exists()
    before = file_identity(path)
    result = run_script([], dict(os.environ, ROTARY_VANE_CACHE_DIR=str(tmp_path)))
    assert result["path"] == str(path)
    assert file_identity(path) == before                        # not rebuilt: same file, same inode, same mtime
    assert result["checksum"] == float(np.nansum(np.abs(table.nodes)))
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]     # no temporary files left


def test_table_is_reused_in_process_and_identical_to_a_fresh_build(tmp_path):
    fluid, envelope, first = small_r134a_table(tmp_path)
    path = property_table_path(fluid, envelope, *SMALL_GRID, cache_dir=tmp_path)
    before = file_identity(path)
    second = small_r134a_table(tmp_path)[2]
    assert file_identity(path) == before
    fresh = build_property_table(fluid, envelope, *SMALL_GRID)
    for name, value in first._asdict().items():
        np.testing.assert_array_equal(value, getattr(second, name), err_msg=name)
        np.testing.assert_array_equal(value, getattr(fresh, name), err_msg=name)


def test_other_grids_and_envelopes_get_their_own_files(tmp_path):
    fluid, envelope, _ = small_r134a_table(tmp_path)
    paths = {property_table_path(fluid, envelope, 40, 40, tmp_path),
             property_table_path(fluid, envelope, 40, 41, tmp_path),
             property_table_path(fluid, envelope._replace(temperature_max=envelope.temperature_max - 1.0), 40, 40,
                                 tmp_path),
             property_table_path(Fluid("CO2"), Envelope(250.0, 400.0, 10.0, 100.0, 1.0), 40, 40, tmp_path)}
    assert len(paths) == 4


@pytest.mark.parametrize("damage", ["garbage", "truncated", "another table"])
def test_damaged_cache_file_is_rebuilt(tmp_path, damage):
    fluid, envelope, table = small_r134a_table(tmp_path)
    path = property_table_path(fluid, envelope, *SMALL_GRID, cache_dir=tmp_path)
    if damage == "garbage":
        path.write_bytes(b"not a property table")
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:5000])
    else:
        air = Fluid("Air")
        air_envelope = envelope_for(air, 101325.0, 293.15, 5e5)
        property_table_for(air, air_envelope, *SMALL_GRID, cache_dir=tmp_path)
        shutil.copy(property_table_path(air, air_envelope, *SMALL_GRID, cache_dir=tmp_path), path)
    with pytest.warns(RuntimeWarning, match="unreadable"):
        rebuilt = property_table_for(fluid, envelope, *SMALL_GRID, cache_dir=tmp_path)
    np.testing.assert_array_equal(rebuilt.nodes, table.nodes)
    repaired = file_identity(path)
    property_table_for(fluid, envelope, *SMALL_GRID, cache_dir=tmp_path)          # now loads without a warning
    assert file_identity(path) == repaired


def test_concurrent_builders_leave_one_complete_file(tmp_path):
    environment = dict(os.environ)
    processes = [subprocess.Popen([sys.executable, "-c", SUBPROCESS_SCRIPT, str(tmp_path)], cwd=REPO_ROOT,
                                  env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                 for _ in range(2)]
    results = []
    for process in processes:
        out, err = process.communicate(timeout=300)
        assert process.returncode == 0, err
        results.append(json.loads(out.strip().splitlines()[-1]))
    assert results[0] == results[1]
    assert sorted(p.name for p in tmp_path.iterdir()) == [Path(results[0]["path"]).name]
    with warnings.catch_warnings():
        warnings.simplefilter("error")                     # a damaged file would warn and be rebuilt
        assert small_r134a_table(tmp_path)[2].nodes.shape == (*SMALL_GRID, 4, 4)
