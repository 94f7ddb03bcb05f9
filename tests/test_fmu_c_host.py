"""The compressor FMU in a host that is not a Python program: a small C host (tests/c_host/fmu_host.c, compiled here
with gcc) dlopens the FMU binary and runs it through the plain FMI 2 C API, as OMSimulator, Simulink or Dymola do.

The FMU binary (pythonfmu 0.7.0) does not link libpython, so the host runs with LD_PRELOAD of the running
interpreter's libpython; PYTHONHOME is the interpreter's installation and PYTHONPATH its site-packages, so that the
embedded interpreter finds numpy and numba (the project's own code is bundled inside the FMU). The result is
compared with the same run through fmpy, in a subprocess too.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import signal
import site
import subprocess
import sys
import sysconfig
import textwrap
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import pytest

PROJECT = Path(__file__).resolve().parent.parent
HOST_SOURCE = Path(__file__).resolve().parent / "c_host" / "fmu_host.c"
MODEL = "RotaryVaneCompressor"
SPEED_RPM = 1500.0
STEPS, STEP_SIZE = 200, 1e-3


def shared_libpython() -> Path | None:
    """The running interpreter's shared libpython (LIBDIR + INSTSONAME or LDLIBRARY), or None for a static one."""
    if not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        return None
    directory = sysconfig.get_config_var("LIBDIR") or ""
    for name in (sysconfig.get_config_var("INSTSONAME"), sysconfig.get_config_var("LDLIBRARY")):
        if name and ".so" in name and (Path(directory) / name).is_file():
            return Path(directory) / name
    return None


def host_environment(libpython: Path) -> dict[str, str]:
    """Environment of the C host: libpython preloaded, the interpreter's prefix and site-packages."""
    env = {key: value for key, value in os.environ.items() if not key.startswith("PYTHON")}
    env["LD_PRELOAD"] = str(libpython)
    # pythonfmu initializes Python with the program name "./PythonFMU": the prefix would come from libpython's
    # build-time setting. PYTHONHOME makes it the running interpreter's (also for a relocated installation).
    home = sys.base_prefix if sys.base_prefix == sys.base_exec_prefix else \
        f"{sys.base_prefix}{os.pathsep}{sys.base_exec_prefix}"
    env["PYTHONHOME"] = home
    # the site-packages of the running interpreter (a virtual environment's too): numpy, numba, scipy
    paths = [p for p in site.getsitepackages() if Path(p).is_dir()]
    if site.ENABLE_USER_SITE and Path(site.getusersitepackages()).is_dir():
        paths.append(site.getusersitepackages())
    env["PYTHONPATH"] = os.pathsep.join(paths)
    return env


@pytest.fixture(scope="session")
def c_host_fmu(built_fmus, tmp_path_factory):
    """The FMU built once per session, unzipped in Python, and its modelDescription facts."""
    fmu = built_fmus / f"{MODEL}.fmu"
    unzipdir = tmp_path_factory.mktemp("c_host_fmu") / "unzipped"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unzipdir)
    root = ElementTree.parse(unzipdir / "modelDescription.xml").getroot()
    references = {v.get("name"): int(v.get("valueReference")) for v in root.iter("ScalarVariable")}
    return {"fmu": fmu, "dir": unzipdir, "guid": root.get("guid"),
            "identifier": root.find("CoSimulation").get("modelIdentifier"), "vr": references}


@pytest.fixture(scope="session")
def c_host(tmp_path_factory):
    """The host binary, compiled with gcc."""
    gcc = shutil.which("gcc")
    if gcc is None:
        pytest.skip("gcc is not installed")
    binary = tmp_path_factory.mktemp("c_host") / "fmu_host"
    compiled = subprocess.run([gcc, "-std=c99", "-O1", "-Wall", "-Wextra", "-o", str(binary), str(HOST_SOURCE),
                               "-ldl"], capture_output=True, text=True, timeout=120)
    assert compiled.returncode == 0, compiled.stderr
    assert "warning" not in compiled.stderr, compiled.stderr
    return binary


@pytest.fixture(scope="session")
def libpython():
    library = shared_libpython()
    if library is None:
        pytest.skip(f"this interpreter has no shared libpython (Py_ENABLE_SHARED = "
                    f"{sysconfig.get_config_var('Py_ENABLE_SHARED')!r}, LDLIBRARY = "
                    f"{sysconfig.get_config_var('LDLIBRARY')!r}): a C host cannot preload it")
    return library


def run_host(c_host, fmu, libpython, speed=SPEED_RPM, steps=STEPS, quick_exit=True, timeout=300):
    arguments = [str(c_host), str(fmu["dir"]), fmu["identifier"], fmu["guid"], str(fmu["vr"]["shaft_speed"]),
                 str(fmu["vr"]["shaft_torque_mean"]), str(fmu["vr"]["input_power"]), repr(speed), str(steps),
                 repr(STEP_SIZE)] + (["--quick-exit"] if quick_exit else [])
    return subprocess.run(arguments, capture_output=True, text=True, timeout=timeout,
                          env=host_environment(libpython), cwd=fmu["dir"].parent)


def parse_result(stdout: str) -> dict:
    match = re.search(r"^RESULT steps=(\d+) time=(\S+) shaft_torque_mean=(\S+) input_power=(\S+)$", stdout, re.M)
    assert match, f"no RESULT line in the host's output:\n{stdout[-2000:]}"
    worst = re.search(r"^WORST_STATUS (\d+)$", stdout, re.M)
    return {"steps": int(match[1]), "time": float(match[2]), "shaft_torque_mean": float(match[3]),
            "input_power": float(match[4]), "worst_status": int(worst[1]) if worst else None,
            "not_ok_calls": re.findall(r"^CALL .*$", stdout, re.M),
            "error_logs": re.findall(r"^LOG \[(?:DISCARD|ERROR|FATAL|PENDING|ILLEGAL)\].*$", stdout, re.M)}


def describe(process) -> str:
    code = process.returncode
    how = f"killed by {signal.Signals(-code).name}" if code < 0 else f"exit status {code}"
    return f"{how}\n--- stdout (end)\n{process.stdout[-1500:]}\n--- stderr (end)\n{process.stderr[-1500:]}"


@pytest.fixture(scope="session")
def fmpy_reference(c_host_fmu, tmp_path_factory):
    """The same run through fmpy, in a subprocess: 200 steps of 1 ms at 1500 rpm."""
    script = textwrap.dedent(f"""
        import json, sys
        from fmpy import simulate_fmu
        result = simulate_fmu({str(c_host_fmu['fmu'])!r}, stop_time={STEPS * STEP_SIZE!r},
                              output_interval={STEP_SIZE!r}, start_values={{"shaft_speed": {SPEED_RPM!r}}},
                              output=["shaft_torque_mean", "input_power"], debug_logging=True)
        print(json.dumps({{"time": float(result["time"][-1]), "input_power": float(result["input_power"][-1]),
                           "shaft_torque_mean": float(result["shaft_torque_mean"][-1])}}))
    """)
    process = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                             cwd=tmp_path_factory.mktemp("fmpy_reference"))
    assert process.returncode == 0, describe(process)
    return json.loads(process.stdout.strip().splitlines()[-1])


def test_c_host_runs_the_fmu_like_fmpy(c_host, c_host_fmu, libpython, fmpy_reference):
    """200 steps of 1 ms at 1500 rpm: every call fmi2OK, exit status 0, mean input power within 1 % of fmpy.

    The host ends with _exit() after fmi2FreeInstance and dlclose (see test_c_host_exits_normally)."""
    process = run_host(c_host, c_host_fmu, libpython)
    assert process.returncode == 0, describe(process)
    result = parse_result(process.stdout)
    assert result["worst_status"] == 0 and not result["not_ok_calls"], result["not_ok_calls"]
    assert not result["error_logs"], result["error_logs"]
    assert result["steps"] == STEPS and result["time"] == pytest.approx(STEPS * STEP_SIZE)
    assert fmpy_reference["time"] == pytest.approx(STEPS * STEP_SIZE), "the fmpy run stopped early"
    assert fmpy_reference["input_power"] > 0.0
    assert result["input_power"] == pytest.approx(fmpy_reference["input_power"], rel=0.01)


def test_c_host_prints_the_fmu_messages(c_host, c_host_fmu, libpython):
    """A negative speed as the start value: initialization is refused with fmi2Error (through the FMU's status
    shim, fmu_src/c/fmi2_status_shim.c), the next call is refused in the FMI error state, and the FMU's messages
    reach the C logger."""
    process = run_host(c_host, c_host_fmu, libpython, speed=-5.0, steps=3)
    assert process.returncode == 3, describe(process)
    result = parse_result(process.stdout)
    assert result["worst_status"] == 3 and result["steps"] == 0
    assert any("fmi2ExitInitializationMode -> ERROR" in line for line in result["not_ok_calls"]), \
        result["not_ok_calls"]
    assert any("fmi2SetReal(shaft_speed) -> ERROR" in line for line in result["not_ok_calls"]), \
        result["not_ok_calls"]
    assert any("'shaft_speed' = -5.0 rpm" in line for line in result["error_logs"]), process.stdout
    assert any("not allowed in the error state" in line and "'shaft_speed' = -5.0 rpm" in line
               for line in result["error_logs"]), process.stdout


def test_c_host_exits_normally(c_host, c_host_fmu, libpython):
    """The same run, the host returning from main: exit handlers and library destructors run, and the FMU's exit
    guard (fmu_src/exit_guard.py) keeps pythonfmu 0.7.0 from releasing its interpreter state twice there."""
    process = run_host(c_host, c_host_fmu, libpython, steps=20, quick_exit=False)
    result = parse_result(process.stdout)
    assert result["worst_status"] == 0, result["not_ok_calls"]
    assert process.returncode == 0, describe(process)
