"""The fmpy harnesses users copy (examples/standalone.py, startup.py, motor_coupling.py, coupling_convergence.py,
moving_inputs.py), each run as a user runs it: a subprocess in a short configuration, pointed with --fmu-dir at the
FMUs built once per session (conftest `built_fmus`) and with --out at a temporary folder, so nothing is written
into the repository. The numba kernels go to a private ROTARY_VANE_CACHE_DIR for this module
(fmu_helpers.host_environment), compiled by the first run.

What is checked:
* every harness writes its files and exits 0; bad input exits non-zero with the variable, value and range, and a
  run the FMU refuses fails loudly with the FMU's message (fmu_harness.simulate);
* standalone: the printed figures equal a direct fmpy run of the FMU done here with the same inputs, and the mean
  torque equals the shaft work over the last completed revolution / 2 pi from that run's cumulative outputs;
* startup: the rotor angle the FMU turned equals the closed-form angle of the docs/model.md §3.2 ramp (conftest's
  independent reference), which holds only if the harness feeds the end-of-step speed the FMU expects;
* motor_coupling --quick: Jacobi and Gauss-Seidel errors shrink with the communication step (about first order);
  the iterative master stays within 0.1 % of the reference where Gauss-Seidel is off by more than 1 %; no scheme
  diverges at these steps (see the note in test_iterative_coupling...); libcosim's fixed-step master equals fmpy's
  Jacobi master and ECCO agrees with the reference within 1 % in steady speed and shaft power; the sized motor
  starts, the undersized one stalls.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path
from string import Template

import numpy as np
import pytest

import fmu_helpers as H
from rotary_vane.mechanics.contact.regions import REGION_COUNT

EXAMPLES = H.PROJECT_DIR / "examples"
TIMEOUT = 600.0                                  # s per harness run on a busy machine (a cold compile included)
RPM = 2.0 * math.pi / 60.0


@pytest.fixture(scope="module")
def env(tmp_path_factory) -> dict:
    """Host environment with a private numba cache for this module; no bytecode written next to the examples."""
    return H.host_environment(**{H.CACHE_ENVIRONMENT_VARIABLE: str(tmp_path_factory.mktemp("numba_cache")),
                                 "PYTHONDONTWRITEBYTECODE": "1"})


def run_example(script: str, out: Path, fmus: Path, env: dict, *options: str) -> subprocess.CompletedProcess:
    """python examples/<script> --fmu-dir FMUS --out OUT OPTIONS..., from a temporary folder, with a temporary folder
    (TMPDIR) of its own that it must leave empty: an unpacked FMU is about 40 MB, and a harness a user runs in a loop
    must not fill the disk with them."""
    scratch = Path(tempfile.mkdtemp(prefix="tmpdir_", dir=out.parent))
    done = subprocess.run([sys.executable, str(EXAMPLES / script), "--fmu-dir", str(fmus), "--out", str(out),
                           *options], cwd=out.parent, env=dict(env, TMPDIR=str(scratch)), capture_output=True,
                          text=True, timeout=TIMEOUT)
    left = sorted(path.name for path in scratch.iterdir())
    assert not left, f"examples/{script} {' '.join(options)} left {left} in its temporary folder\n{done.stderr[-2000:]}"
    scratch.rmdir()
    return done


def succeeded(done: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert done.returncode == 0, f"exit status {done.returncode}\nstdout:\n{done.stdout[-4000:]}\n" \
                                 f"stderr:\n{done.stderr[-4000:]}"
    return done


def assert_files(folder: Path, names) -> None:
    for name in names:
        path = folder / name
        assert path.is_file() and path.stat().st_size > 0, f"{path} missing or empty"


# standalone -----------------------------------------------------------------------------------------------------
STANDALONE = dict(speed=1500.0, clearance=5e-5, lobes=3, duration=0.1, step=1e-3)   # 2.5 revolutions

DIRECT_RUN = """
import fmu_helpers as H
out = H.simulate($fmu, stop_time=$duration, output_interval=$step,
                 start_values={"shaft_speed": $speed, "slot_clearance": $clearance, "stator_clearance": $clearance,
                               "lobes": $lobes, "pressure_model": "real_gas"})
H.emit(out)
"""


@pytest.fixture(scope="module")
def standalone(built_fmus, env, tmp_path_factory):
    out = tmp_path_factory.mktemp("standalone") / "out"
    done = succeeded(run_example("standalone.py", out, built_fmus, env,
                                 *(f"--{name}={value}" for name, value in STANDALONE.items())))
    return done, out


def test_standalone_writes_its_files(standalone):
    _, out = standalone
    assert_files(out, ("result.csv", "summary.json", "torque_power.png", "kinematics.png", "contact_forces.png"))


def test_standalone_summary_equals_a_direct_fmpy_run(standalone, built_fmus, env):
    """Same FMU, same inputs, run here through fmpy directly: the harness's figures are the FMU's, and its mean
    torque is the shaft work over the last completed revolution / 2 pi. At 1500 rpm and 1 ms steps a revolution
    is exactly 40 steps, so the revolutions completed by t = 0.1 s are [0, 0.04] and [0.04, 0.08] s, which are
    communication points."""
    done, out = standalone
    summary = json.loads((out / "summary.json").read_text())
    fmu = built_fmus / "RotaryVaneCompressor.fmu"
    direct = H.run_host(Template(DIRECT_RUN).substitute(fmu=repr(str(fmu)), **{k: repr(v) for k, v in
                                                                               STANDALONE.items()}),
                        env=env).check().result
    c = {name: np.array(values) for name, values in direct["columns"].items()}
    assert c["time"][-1] == pytest.approx(STANDALONE["duration"])
    for name in ("input_power", "output_power", "friction_power", "damping_power", "mechanical_efficiency",
                 "max_contact_force", "discharge_mass_flow", "discharge_temperature"):
        assert summary[name] == pytest.approx(c[name][-1], rel=1e-12), name
    assert summary["contact_mode_count"] == c["contact_mode_count"][-1]
    begin, end = (int(np.argmin(np.abs(c["time"] - t))) for t in (0.04, 0.08))
    revolution_torque = (c["shaft_work"][end] - c["shaft_work"][begin]) / (c["shaft_angle"][end] - c["shaft_angle"][begin])
    assert c["shaft_angle"][end] - c["shaft_angle"][begin] == pytest.approx(2.0 * math.pi, rel=1e-9)
    assert summary["mean_shaft_torque"] == pytest.approx(revolution_torque, rel=1e-6)
    assert summary["mechanical_efficiency"] == pytest.approx(summary["output_power"] / summary["input_power"],
                                                             rel=1e-9)
    window = c["shaft_angle"] >= c["shaft_angle"][-1] - 2.0 * math.pi
    peaks = [float(np.max(c[f"contact_force_{k}"][window])) for k in range(1, REGION_COUNT + 1)]
    assert summary["sampled_peak_forces"] == pytest.approx(peaks, rel=1e-12)
    assert summary["sampled_peak_region"] == f"c{1 + int(np.argmax(peaks))}"
    gas = "discharge_mass_flow" in c
    for name in ("discharge_mass_flow", "discharge_temperature"):
        if gas:
            assert summary[name] == pytest.approx(c[name][-1], rel=1e-12)
        else:
            assert summary[name] is None
    assert ("n/a (needs the real-gas model)" in done.stdout) != gas
    assert f"{summary['input_power']:10.2f} W" in done.stdout


def test_standalone_refuses_bad_options_before_running(built_fmus, env, tmp_path):
    """Out-of-range options stop before any simulation, naming the option or parameter, value and range (ranges
    of FMU parameters from the FMU's modelDescription)."""
    out = tmp_path / "out"
    done = run_example("standalone.py", out, built_fmus, env, "--speed", "-5")
    assert done.returncode == 2 and "-5 rpm is out of range: allowed > 0 rpm" in done.stderr
    done = run_example("standalone.py", out, built_fmus, env, "--clearance", "0.5")
    assert done.returncode == 1
    assert "parameter 'slot_clearance' = 0.5 m is out of range: allowed [0, 0.001] m" in done.stderr
    done = run_example("standalone.py", out, built_fmus, env, "--lobes", "20")
    assert done.returncode == 1
    assert "parameter 'lobes' = 20 is out of range: allowed [2, 12]" in done.stderr
    done = run_example("standalone.py", out, built_fmus, env, "--duration", "0.05")
    assert done.returncode == 1 and "allowed >= 2 revolutions = 0.08 s" in done.stderr
    assert not (out / "result.csv").exists()


REFUSED_RUN = """
import sys
from pathlib import Path
import fmu_helpers as H
sys.path.insert(0, $examples)
import fmu_harness as harness
log = harness.FmuLog()
try:
    harness.simulate(Path($fmu), stop_time=0.01, step=1e-3, start_values={"stroke": 0.02}, log=log)
except harness.HarnessError as error:
    H.emit({"error": str(error)})
"""


def test_a_refused_run_fails_loudly_with_the_fmus_message(built_fmus, env):
    """A parameter set the FMU refuses at initialization (a stroke the default vane cannot follow; within the
    modelDescription's range, so only the FMU can tell): fmpy raises on fmi2Error; the harness turns it into its
    error with the FMU's message, which names the parameter the user set."""
    script = Template(REFUSED_RUN).substitute(examples=repr(str(EXAMPLES)),
                                              fmu=repr(str(built_fmus / "RotaryVaneCompressor.fmu")))
    run = H.run_host(script, env=env).check()
    message = run.result["error"]
    assert "fmi2ExitInitializationMode failed with status 3 (error)" in message
    assert "parameter 'stroke' = 0.02 is out of range: allowed <=" in message, message


# startup --------------------------------------------------------------------------------------------------------
STARTUP = dict(speed=1500.0, ramp=0.4, stop=0.45, step=1e-4)


@pytest.fixture(scope="module")
def startup(built_fmus, env, tmp_path_factory):
    out = tmp_path_factory.mktemp("startup") / "out"
    done = succeeded(run_example("startup.py", out, built_fmus, env, "--speed", str(STARTUP["speed"]),
                                 "--ramp-time", str(STARTUP["ramp"]), "--stop-time", str(STARTUP["stop"]),
                                 "--step", str(STARTUP["step"]), "--clearance", "0"))
    return done, out


def test_startup_writes_its_files(startup, built_fmus):
    _, out = startup
    assert_files(out, ("result.csv", "summary.json", "startup_0.0-0.5s.png", "startup_0.0-0.4s.png",
                       "startup_0.4-0.5s.png"))
    from fmpy import read_model_description
    names = {v.name for v in read_model_description(str(built_fmus / "RotaryVaneCompressor.fmu")).modelVariables}
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["missing_outputs"]) == {"vane_tangential_velocity", "vane_tangential_acceleration"} - names


def test_startup_follows_the_spec_ramp(startup, reference):
    """The FMU's rotor angle at every communication point equals the closed-form angle of the cycloidal ramp
    (docs/model.md §3.2; conftest's reference). Feeding the speed at the start of each step instead of its end would lag
    by omega h = 0.016 rad at full speed; the trapezoidal rule over 1e-4 s steps is exact to about 1e-6 rad."""
    from fmpy.util import read_csv
    _, out = startup
    result = read_csv(out / "result.csv")
    assert result["time"][-1] == pytest.approx(STARTUP["stop"])
    exact = np.array([reference.speed_law(t, "ramp", STARTUP["speed"] * RPM, STARTUP["ramp"])[0]
                      for t in result["time"]])
    assert np.max(np.abs(result["shaft_angle"] - exact)) < 1e-5


# motor coupling ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def coupling(built_fmus, env, tmp_path_factory):
    out = tmp_path_factory.mktemp("motor_coupling") / "out"
    done = succeeded(run_example("motor_coupling.py", out, built_fmus, env, "--quick"))
    return done, json.loads((out / "summary.json").read_text()), out


def test_motor_coupling_writes_its_files(coupling):
    _, summary, out = coupling
    assert_files(out, ("convergence.md", "convergence.png", "startup.png", "summary.json"))
    table = (out / "convergence.md").read_text().splitlines()
    assert len(table) == 2 + len(summary["steps"])


def study_errors(summary, scheme, key):
    """(steps, errors) of a scheme, without the reference run."""
    rows = [(float(h), entry[key]) for h, entry in summary["study"][scheme].items() if not entry["reference"]]
    return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])


@pytest.mark.parametrize("scheme", ["jacobi", "gauss_seidel"])
@pytest.mark.parametrize("key", ["speed_error", "energy_error"])
def test_explicit_coupling_error_shrinks_with_the_step(coupling, scheme, key):
    """An explicit master holds the other FMU's output over the step: a first-order error. It must fall with
    every refinement and by at least a quarter of the step ratio over the study (first order would be all)."""
    _, summary, _ = coupling
    steps, errors = study_errors(summary, scheme, key)
    assert np.all(np.isfinite(errors)), f"{scheme} diverged: {summary['study'][scheme]}"
    order = np.argsort(steps)
    steps, errors = steps[order], errors[order]
    assert np.all(np.diff(errors) > 0.0), f"{scheme} {key} not shrinking with the step: {errors}"
    assert errors[-1] / errors[0] > 0.25 * steps[-1] / steps[0]


def test_iterative_coupling_stays_at_the_reference_where_gauss_seidel_does_not(coupling):
    """No master diverges at the quick steps (nor up to 2e-2 s in the full study): with the motor integrating
    the shaft, the only lagged quantity is the compressor's load torque, whose sensitivity to the speed is far
    too small for instability. So instead of "where Gauss-Seidel has diverged" this checks the step where
    Gauss-Seidel is more than 1 % off: there the iterative master (state rollback) is within 0.1 % in speed and
    shaft energy, and at every step it is at least 5 times closer than Gauss-Seidel."""
    _, summary, _ = coupling
    study = summary["study"]
    for scheme in study:
        assert all(entry["status"] == "ok" for entry in study[scheme].values()), study[scheme]
    gs_speed = dict(zip(*study_errors(summary, "gauss_seidel", "speed_error")))
    candidates = [h for h, error in gs_speed.items() if error > 1e-2]
    assert candidates, f"Gauss-Seidel is within 1 % at every step: {gs_speed}"
    step = min(candidates)
    entry = study["iterative"][f"{step:g}"]
    assert entry["speed_error"] < 1e-3 and entry["energy_error"] < 1e-3, (step, entry)
    for key in ("speed_error", "energy_error"):
        steps, iterative = study_errors(summary, "iterative", key)
        gs = dict(zip(*study_errors(summary, "gauss_seidel", key)))
        for h, error in zip(steps, iterative):
            assert gs[h] > 5.0 * error, (key, h, gs[h], error)


def test_libcosim_agrees_with_the_fmpy_masters(coupling):
    """libcosim's fixed-step algorithm is Jacobi (all FMUs step, then the connections are updated): from the
    shipped OspSystemStructure.xml with this study's start values it equals fmpy's Jacobi master at the file's
    base step (far within the 1 % asked). ECCO varies the step; it agrees with the reference within 1 % in steady
    speed and shaft power. (Its electrical power and the cumulative shaft work differ by about 2 %: a torque held
    over steps whose length follows the ripple does not conserve energy; tests/fmu/test_fmu_coupling.py.)"""
    _, summary, _ = coupling
    libcosim = summary["libcosim"]
    assert set(libcosim) == {"fixed step", "ECCO"}
    for key, difference in libcosim["fixed step"]["vs_fmpy_jacobi"]["relative_difference"].items():
        assert abs(difference) < 1e-4, key
    for key in ("steady_speed", "steady_shaft_power"):
        assert abs(libcosim["ECCO"]["vs_reference"]["relative_difference"][key]) < 1e-2, key


def test_motor_sizing_figures(coupling):
    """The 1.5 kW motor (the DriveMotor defaults: rated 1440 rpm, synchronous 1500 rpm) starts the compressor:
    no stall, a start-up time inside the run, a steady speed between rated and synchronous speed (the mean load,
    about 2.6 N.m, is below the rated torque, 9.9 N.m), and an air-gap (electrical) power above the shaft power
    (the slip loss). The undersized motor stalls."""
    _, summary, _ = coupling
    motor, undersized = summary["sizing"]["motor"], summary["sizing"]["undersized"]
    assert motor["status"] == "ok" and not motor["stalled"]
    assert 0.0 < motor["startup_time_95"] < summary["stop_time"]
    assert 1440.0 < motor["steady_speed"] < 1500.0
    assert motor["steady_electrical_power"] > motor["steady_shaft_power"] > 0.0
    assert abs(motor["steady_drift"]) < 1e-3
    assert undersized["stalled"]


# moving inputs --------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_moving_inputs_reach_the_fixed_point_run_and_conserve_the_flows(built_fmus, env, tmp_path):
    """examples/moving_inputs.py, the issue's run (about 20 s of fmpy on an idle machine): from standstill at equal
    pressures to 1500 rpm and 0.2928 -> 1.3179 MPa; the final input power and discharge mass flow within 1 % of a
    run started there, the step means summing to the cumulative flows to 1e-9."""
    out = tmp_path / "moving_inputs"
    done = succeeded(run_example("moving_inputs.py", out, built_fmus, env))
    assert_files(out, ["moving_inputs.csv", "moving_inputs.png", "summary.json"])
    summary = json.loads((out / "summary.json").read_text())
    for name, (moving, reference, difference) in \
            summary["final_figures (moving, reference, relative difference)"].items():
        assert abs(moving / reference - 1.0) <= 0.01 and abs(difference) <= 0.01, (name, moving, reference)
    assert all(value <= 1e-9 for value in summary["conservation (relative)"].values()), summary
    assert "within 1% of the reference: True" in done.stdout


def test_the_iterative_master_converges_in_the_interface_speed_with_both_pressure_models(built_fmus, env, tmp_path):
    """examples/coupling_convergence.py over the first 50 ms from rest with the FMU's defaults and the master's
    default update (plain fixed point): with the real-gas chambers and with the Level 0.5 table every step reaches
    1e-6 rpm between two iterations (so at least two iterations each). Before Dormand-Prince's stability cap took
    the chambers' stiffness from their Jacobian (docs/model.md §8.2, "the cap in the start-up") the real-gas step
    at 20 ms cycled through 30 iterations between speeds up to 2.8e-4 rpm apart (README, "Coupling to a motor")."""
    out = tmp_path / "coupling_convergence"
    succeeded(run_example("coupling_convergence.py", out, built_fmus, env, "--stop-time", "0.05"))
    assert_files(out, ["convergence.md", "summary.json"])
    results = json.loads((out / "summary.json").read_text())["results"]
    assert [r["pressure_model"] for r in results] == ["real_gas", "ideal_gas_table"]
    for r in results:
        assert r["failure"] == "" and r["steps"] == r["of"] == 50, r
        assert r["unconverged"] == [] and r["iterations_median"] >= 2, r
        assert r["final_speed_rpm"] > 0.0, r
