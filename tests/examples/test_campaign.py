"""Tests of the dask campaign runner examples/campaign.py (issue 6, "Campaigns that outgrow one machine").

The campaign test runs the command line in a subprocess on a local cluster of 2 worker processes: 6 points (two
clearances x three speeds) and one point the FMU refuses at initialization (discharge_pressure below
suction_pressure: inside its declared range, so only the FMU can tell). The run is killed with SIGKILL as soon as
the first row is in the store, then the same command resumes it, then `--retry-failed` reruns the refused point.
Each point is made slow enough to be killed mid-way (max_step = 0.5 us: about 0.2 s of work per point).
The workers load the numba kernels the FMU ships; anything else is cached in a temporary ROTARY_VANE_CACHE_DIR
for this module.

What is checked: every point is in the store exactly once, the rows written before the kill are kept unchanged
and not run again, the orphaned worker processes end; the refused point is failed with the FMU's message naming
the parameter; each stored point equals a fresh fmpy run of the same parameters (a worker's instance reused with
fmi2Reset carries nothing over); the rotor angle is the closed form 2 pi n t / 60, the last-revolution figures
are absent before a revolution and close the energy balance after two. Bad names and values are refused before
anything runs; the store survives a partial last line and admits one campaign at a time.
"""
from __future__ import annotations

import importlib.util
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

import fmu_helpers as H

CAMPAIGN_SCRIPT = H.PROJECT_DIR / "examples" / "campaign.py"
SPEEDS = (1000.0, 2000.0, 3000.0)                 # rpm: 0.83, 1.67 and 2.5 revolutions in STOP_TIME
CLEARANCES = (0.0, 5e-5)                          # m, slot = stator clearance
STOP_TIME = 0.05                                  # s
SLOW = {"max_step": 5e-7, "initial_step": 1e-7,   # s: about 0.2 s of work per point (an idle core)
        "pressure_model": "ideal_gas_table"}
BAD_POINT = {"shaft_speed": 1500.0, "discharge_pressure": 2e5}   # Pa, below suction_pressure = 2.928e5 Pa
GOOD_POINTS = [{"shaft_speed": n, "slot_clearance": c, "stator_clearance": c} for c in CLEARANCES for n in SPEEDS]
TIMEOUT = 300.0                                   # s per campaign process


def load_campaign():
    spec = importlib.util.spec_from_file_location("campaign", CAMPAIGN_SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules["campaign"] = module
    spec.loader.exec_module(module)
    return module


campaign = load_campaign()


@pytest.fixture(scope="module")
def fmu(built_fmus) -> Path:
    return built_fmus / "RotaryVaneCompressor.fmu"


@pytest.fixture(scope="module")
def space(fmu):
    return campaign.ParameterSpace(fmu)


# points, validation, store: no cluster ---------------------------------------------------------------------
def test_grid_is_the_product_of_its_axes_with_linked_names():
    points = campaign.grid({("slot_clearance", "stator_clearance"): [0.0, 5e-5], "shaft_speed": [1000, 1500, 2000]},
                           fixed={"stop_time": 0.5})
    assert len(points) == 6
    assert all(p["slot_clearance"] == p["stator_clearance"] and p["stop_time"] == 0.5 for p in points)
    assert {(p["slot_clearance"], p["shaft_speed"]) for p in points} == {
        (c, n) for c in (0.0, 5e-5) for n in (1000, 1500, 2000)}
    assert [p["shaft_speed"] for p in points[:3]] == [1000, 1500, 2000]     # the last axis runs fastest
    with pytest.raises(ValueError, match="shaft_speed"):
        campaign.grid({"shaft_speed": [1000]}, fixed={"shaft_speed": 1500})
    with pytest.raises(ValueError, match="no values"):
        campaign.grid({"lobes": []})
    # the command line's form of the same grid
    cli = campaign.campaign_points([(["slot_clearance", "stator_clearance"], "0,5e-5"),
                                    (["shaft_speed"], "1000,1500,2000")], [(["stop_time"], "0.5")], None)
    assert len(cli) == 6 and cli[1] == {"stop_time": "0.5", "slot_clearance": "0", "stator_clearance": "0",
                                        "shaft_speed": "1500"}


def test_point_id_depends_on_the_parameter_set_only(space):
    base = space.resolve({"shaft_speed": 1500, "slot_clearance": 5e-5, "stop_time": 0.1})
    same = [{"stop_time": "0.1", "slot_clearance": "5e-5", "shaft_speed": "1500"},        # order, text
            {"shaft_speed": 1500.0, "slot_clearance": 5e-5, "stop_time": 0.1, "lobes": 3},  # a default given
            {"shaft_speed": 1500, "slot_clearance": 5e-5, "stop_time": 0.1, "stator_clearance": -0.0}]
    assert {space.resolve(given).point_id for given in same} == {base.point_id}
    others = [{"shaft_speed": 1501, "slot_clearance": 5e-5, "stop_time": 0.1},
              {"shaft_speed": 1500, "slot_clearance": 5e-5, "stop_time": 0.2},
              {"shaft_speed": 1500, "slot_clearance": 5e-5, "stop_time": 0.1, "communication_step": 5e-4},
              {"shaft_speed": 1500, "slot_clearance": 5e-5, "stop_time": 0.1, "integrator": "abm4"}]
    assert len({space.resolve(given).point_id for given in others} | {base.point_id}) == 5


@pytest.mark.parametrize("points, message", [
    ([{"slot_clearence": 1e-5}], r"unknown parameter 'slot_clearence'.*did you mean slot_clearance"),
    ([{"stop_tme": 0.1}], r"unknown parameter 'stop_tme'.*stop_time"),
    ([{"shaft_speed": 1000}, {"stator_clearance": -1e-5}], r"point 1: parameter 'stator_clearance' = -1e-05 .*"
                                                            r"allowed \[0, 0.001\] m"),
    ([{"lobes": 4.5}], r"'lobes' = 4.5 .*an integer in \[2, 12\]"),
    ([{"shaft_speed": 40000}], r"'shaft_speed' = 40000 .*\[0, 30000\] rpm"),
    ([{"stop_time": 0}], r"'stop_time' = 0 .*> 0 s"),
    ([{"communication_step": float("nan")}], r"'communication_step' = nan"),
    ([{"slot_clearance": "wide"}], r"'slot_clearance' = 'wide'"),
    ([{"shaft_speed": 1000}, {"shaft_speed": 1000.0}], r"points 0 and 1 are the same parameter set"),
    ([], r"no points"),
])
def test_bad_points_are_refused_before_anything_runs(fmu, tmp_path, points, message):
    store = tmp_path / "store.csv"
    with pytest.raises(ValueError, match=message):
        campaign.run_campaign(fmu, points, store, workers=1)
    assert not store.exists()


def test_store_drops_a_partial_last_line_and_admits_one_campaign(tmp_path):
    columns = campaign.store_columns(["shaft_speed", "stop_time", "communication_step"])
    store = tmp_path / "store.csv"
    with campaign.ResultStore(store, columns) as results:
        results.append({"point_id": "a", "status": campaign.DONE, "shaft_speed": 1000.0, "error": "x, \"y\""})
        with pytest.raises(RuntimeError, match="in use by another campaign"):
            with campaign.ResultStore(store, columns):
                pass
    with store.open("a") as handle:
        handle.write("b,done,2000.0")             # a kill in the middle of a write
    with campaign.ResultStore(store, columns) as results:
        assert [row["point_id"] for row in results.rows] == ["a"]
        results.append({"point_id": "c", "status": campaign.FAILED})
    rows = campaign.read_store(store)
    assert [(r["point_id"], r["status"], r["shaft_speed"], r["error"]) for r in rows] == [
        ("a", "done", "1000.0", "x, \"y\""), ("c", "failed", "", "")]
    with pytest.raises(ValueError, match=r"parameters \['shaft_speed', 'stop_time', 'communication_step'\].*"
                                         r"\['shaft_speed', 'stop_time', 'communication_step', 'lobes'\]"):
        with campaign.ResultStore(store, campaign.store_columns(["shaft_speed", "stop_time", "communication_step",
                                                                 "lobes"])):
            pass


# the campaign, killed and resumed ----------------------------------------------------------------------------
def live_members(group: int) -> list[int]:
    """Processes of a process group that are not zombies."""
    members = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == group and fields[0] != "Z":
            members.append(int(stat.parent.name))
    return members


def wait_for(condition, timeout: float, interval: float = 0.02) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(interval)
    return condition()


@pytest.fixture(scope="module")
def runs(fmu, space, tmp_path_factory):
    """The campaign killed after its first row, resumed, then rerun with --retry-failed."""
    folder = tmp_path_factory.mktemp("campaign")
    env = H.host_environment(**{H.CACHE_ENVIRONMENT_VARIABLE: str(tmp_path_factory.mktemp("numba_cache"))})
    points_file = folder / "points.json"
    points_file.write_text(json.dumps([*GOOD_POINTS, BAD_POINT]))
    store = folder / "results.csv"
    command = [sys.executable, str(CAMPAIGN_SCRIPT), "--fmu", str(fmu), "--store", str(store),
               "--points", str(points_file), "--set", f"stop_time={STOP_TIME}", "--workers", "2", "--no-progress",
               *(argument for name, value in SLOW.items() for argument in ("--set", f"{name}={value}"))]
    with (folder / "killed.out").open("w") as out:
        killed = subprocess.Popen(command, cwd=folder, env=env, stdout=out, stderr=subprocess.STDOUT,
                                  start_new_session=True)
        try:
            first_row = wait_for(lambda: len(campaign.read_store(store)) >= 1 or killed.poll() is not None,
                                 TIMEOUT)
            killed.send_signal(signal.SIGKILL)
            killed.wait()
            at_kill = campaign.read_store(store)
            workers_ended = wait_for(lambda: not live_members(killed.pid), 60.0, 0.2)
        finally:
            for pid in live_members(killed.pid):
                os.kill(pid, signal.SIGKILL)
    assert first_row and killed.returncode == -signal.SIGKILL, (folder / "killed.out").read_text()[-3000:]
    resumed = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True, timeout=TIMEOUT)
    after_resume = campaign.read_store(store)
    retried = subprocess.run([*command, "--retry-failed", "--workers", "1"], cwd=folder, env=env,
                             capture_output=True, text=True, timeout=TIMEOUT)
    fixed = {"stop_time": STOP_TIME, **SLOW}
    return SimpleNamespace(at_kill=at_kill, workers_ended=workers_ended, resumed=resumed, retried=retried,
                           after_resume=after_resume, final=campaign.read_store(store), fmu=fmu, env=env,
                           good_ids=[space.resolve({**p, **fixed}).point_id for p in GOOD_POINTS],
                           bad_id=space.resolve({**BAD_POINT, **fixed}).point_id)


def test_killed_campaign_resumes_and_ends_with_every_point_once(runs):
    total = len(GOOD_POINTS) + 1
    assert 1 <= len(runs.at_kill) < total, f"the kill came too late to be mid-way: {len(runs.at_kill)} rows"
    assert runs.workers_ended, "worker processes of the killed campaign kept running"
    assert runs.resumed.returncode == 1, runs.resumed.stderr[-3000:]           # 1: a point is stored as failed
    assert (f"{total} points: {len(runs.at_kill)} already in" in runs.resumed.stderr
            and f"{total - len(runs.at_kill)} to run" in runs.resumed.stderr), runs.resumed.stderr[-3000:]
    assert runs.after_resume[:len(runs.at_kill)] == runs.at_kill      # finished rows kept as written, not rerun
    for rows in (runs.after_resume, runs.final):
        ids = [row["point_id"] for row in rows]
        assert sorted(ids) == sorted([*runs.good_ids, runs.bad_id])      # every point exactly once
        assert {row["point_id"] for row in rows if row["status"] == campaign.DONE} == set(runs.good_ids)


def test_refused_point_is_failed_with_the_fmu_message_and_retried_on_request(runs):
    bad = next(row for row in runs.final if row["point_id"] == runs.bad_id)
    assert bad["status"] == campaign.FAILED
    assert "'discharge_pressure' = 200000.0" in bad["error"] and "suction_pressure" in bad["error"], bad["error"]
    assert all(bad[name] == "" for name in campaign.RESULT_COLUMNS if name != "end_time")
    assert bad["end_time"] == "0.0"
    assert runs.retried.returncode == 1, runs.retried.stderr[-3000:]
    assert f"{len(GOOD_POINTS)} already in" in runs.retried.stderr and "1 to run" in runs.retried.stderr
    assert runs.final[:len(GOOD_POINTS)] == [row for row in runs.after_resume if row["point_id"] != runs.bad_id]


def test_rows_equal_fresh_fmu_runs(runs):
    """A worker's instance reused with fmi2Reset gives what a fresh instance gives (fmpy's simulate_fmu)."""
    done = [row for row in runs.final if row["status"] == campaign.DONE]
    workers = [row["worker"] for row in runs.after_resume if row["status"] == campaign.DONE
               and row not in runs.at_kill]
    assert max(workers.count(w) for w in workers) >= 2, "no worker ran two points after a reset"
    starts = [{name: float(row[name]) for name in ("shaft_speed", "slot_clearance", "stator_clearance")}
              for row in done]
    script = f"""
        import fmu_helpers as H
        from fmpy import simulate_fmu
        out = []
        for row in {starts!r}:
            result = simulate_fmu({str(runs.fmu)!r}, stop_time={STOP_TIME}, output_interval=1e-3,
                                  start_values={{**row, **{SLOW!r}}})
            out.append({{name: float(result[name][-1]) for name in ("time", "shaft_work", "shaft_angle",
                                                                     "input_power", "contact_mode_count")}})
        H.emit(out)
    """
    fresh = H.run_host(script, env=runs.env).check().result
    for row, reference in zip(done, fresh):
        assert math.isclose(reference["time"], STOP_TIME, rel_tol=1e-12)
        for name in ("shaft_work", "shaft_angle", "contact_mode_count"):
            assert math.isclose(float(row[name]), reference[name], rel_tol=1e-9), (name, row, reference)
        if row["input_power"]:
            assert math.isclose(float(row["input_power"]), reference["input_power"], rel_tol=1e-9)


def test_summary_figures_obey_the_kinematics_and_the_energy_balance(runs):
    done = [row for row in runs.final if row["status"] == campaign.DONE]
    for row in done:
        value = {name: float(row[name]) if row[name] else None for name in campaign.RESULT_COLUMNS}
        speed = float(row["shaft_speed"]) * 2.0 * math.pi / 60.0
        revolutions = value["shaft_angle"] / (2.0 * math.pi)
        assert value["end_time"] == STOP_TIME
        assert math.isclose(value["shaft_angle"], speed * STOP_TIME, rel_tol=1e-9)
        if revolutions < 1.0:               # no revolution completed: no last-revolution figures
            assert all(value[name] is None for name in campaign.REVOLUTION_OUTPUTS), row
        if revolutions >= 2.0:              # a full revolution lies between two multiples of 2 pi
            assert math.isclose(value["mechanical_efficiency"], value["output_power"] / value["input_power"],
                                rel_tol=1e-9)
            losses = value["output_power"] + value["friction_power"] + value["damping_power"]
            assert abs(value["input_power"] - losses) <= 1e-3 * value["input_power"], row
    assert sum(float(row["shaft_angle"]) >= 4.0 * math.pi for row in done) == len(CLEARANCES)
