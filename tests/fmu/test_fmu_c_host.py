"""The compressor FMU in hosts that are not Python programs, and what its shim (fmu_src/c/fmi2_status_shim.c)
answers for itself.

A small C host (tests/c_host/fmu_host.c, compiled here with gcc) dlopens the FMU binary and runs it through the plain
FMI 2 C API, as Ecos, OMSimulator, Simulink or Dymola do, from a clean environment: PATH=/usr/bin:/bin and HOME only,
no LD_PRELOAD, PYTHONHOME or PYTHONPATH. The FMU's shim loads the libpython of the interpreter that built it
(fmu_src/c/host_python.c). The result is compared with the same run through fmpy, in a subprocess too. The runs
themselves are in tests/fmu_shim_cases.py (shared with the README's contract rows in tests/fmu/test_fmu_contract.py).
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import fmu_shim_cases as S
from fmu_shim_cases import INSTANCE, NULL

MODEL = "RotaryVaneCompressor"
SPEED_RPM = 1500.0
STEPS, STEP_SIZE = 200, 1e-3
DECLARED_CATEGORIES = {"logAll", "logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal"}


@pytest.fixture(scope="session")
def folder(tmp_path_factory) -> Path:
    return S.cases_folder(tmp_path_factory)


@pytest.fixture(scope="session")
def c_host_fmu(built_fmus, folder):
    return S.unpacked(built_fmus / f"{MODEL}.fmu", folder)


@pytest.fixture(scope="session")
def c_host(folder):
    try:
        return S.c_host(folder)
    except RuntimeError as error:
        pytest.skip(str(error))


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


def test_c_host_runs_the_fmu_like_fmpy_from_a_clean_environment(c_host, c_host_fmu, fmpy_reference):
    """200 steps of 1 ms at 1500 rpm with no LD_PRELOAD, PYTHONHOME or PYTHONPATH: every call fmi2OK, exit status 0,
    input power within 1e-7 of fmpy's (the same interpreter runs the same code). The host ends with _exit() after fmi2FreeInstance and dlclose (see
    test_c_host_exits_normally)."""
    env = S.clean_environment()
    assert not any(key.startswith(("PYTHON", "LD_")) for key in env), env
    process = S.c_host_run(c_host, c_host_fmu, env, "--quick-exit")
    assert process.returncode == 0, describe(process)
    result = S.parse_c_host(process.stdout)
    assert result["worst_status"] == 0 and not result["not_ok_calls"], result["not_ok_calls"]
    assert not result["error_logs"], result["error_logs"]
    assert result["steps"] == STEPS and result["time"] == pytest.approx(STEPS * STEP_SIZE)
    assert fmpy_reference["time"] == pytest.approx(STEPS * STEP_SIZE), "the fmpy run stopped early"
    assert fmpy_reference["input_power"] > 0.0
    assert result["input_power"] == pytest.approx(fmpy_reference["input_power"], rel=1e-7)


def test_c_host_prints_the_fmu_messages(c_host, c_host_fmu):
    """A negative speed as the start value: initialization is refused with fmi2Error, the next call is refused in
    the FMI error state, and the FMU's messages reach the C logger with a declared category."""
    process = S.c_host_run(c_host, c_host_fmu, S.clean_environment(), "--quick-exit", speed=-5.0, steps=3)
    assert process.returncode == 3, describe(process)
    result = S.parse_c_host(process.stdout)
    assert result["worst_status"] == 3 and result["steps"] == 0
    assert any("fmi2ExitInitializationMode -> ERROR" in line for line in result["not_ok_calls"]), \
        result["not_ok_calls"]
    assert any("fmi2SetReal(shaft_speed) -> ERROR" in line for line in result["not_ok_calls"]), \
        result["not_ok_calls"]
    assert any("'shaft_speed' = -5.0 rpm" in line for line in result["error_logs"]), process.stdout
    assert any("not allowed in the error state" in line and "'shaft_speed' = -5.0 rpm" in line
               for line in result["error_logs"]), process.stdout
    assert all(line.split()[3].rstrip(":") in DECLARED_CATEGORIES for line in result["logs"]), result["logs"]


def test_c_host_exits_normally(c_host, c_host_fmu):
    """The same run, the host returning from main: exit handlers and library destructors run, and the FMU's exit
    guard (fmu_src/exit_guard.py) keeps pythonfmu 0.7.0 from releasing its interpreter state twice there."""
    process = S.c_host_run(c_host, c_host_fmu, S.clean_environment(), steps=20)
    result = S.parse_c_host(process.stdout)
    assert result["worst_status"] == 0, result["not_ok_calls"]
    assert process.returncode == 0, describe(process)


def test_c_host_reads_a_percent_encoded_non_ascii_folder(c_host, c_host_fmu, folder):
    """The FMU unpacked into a folder with a space and non-ASCII letters, its binary loaded from there and the
    resource location percent-encoded: in the C locale of a clean environment too (the shim starts Python in UTF-8
    mode there, as the python program does)."""
    copy = S.copy_of(c_host_fmu, folder / "c host in a folder with spaces" / "ünïcødé")
    process = S.c_host_run(c_host, c_host_fmu, S.clean_environment(), "--quick-exit",
                           f"--resources={(copy / 'resources').as_uri()}", directory=copy, steps=2)
    assert process.returncode == 0, describe(process)
    assert "%20" in (copy / "resources").as_uri() and "%C3%BC" in (copy / "resources").as_uri()


def test_without_a_python_instantiate_returns_null_and_says_what_to_set(c_host, c_host_fmu, folder):
    """ROTARY_VANE_PYTHON naming an interpreter that does not exist (python3 is on PATH, the build's interpreter
    exists: the variable is the user's choice and is not replaced by another): NULL, and the message, through the
    host's logger with a declared category, names the variable, its value and what it must name."""
    process = S.no_python_run(c_host_fmu["fmu"], folder)
    assert process.returncode == 3, describe(process)
    result = S.parse_c_host(process.stdout)
    assert result["not_ok_calls"] == ["CALL fmi2Instantiate -> NULL"] and result["steps"] is None
    [message] = result["error_logs"]
    assert message.startswith("LOG [ERROR] c_host logStatusError: fmi2Instantiate: "), message
    assert "ROTARY_VANE_PYTHON=/nonexistent/bin/python3" in message and "requirements.txt" in message, message


def shim_with_recorded_interpreter(c_host_fmu, target: Path, interpreter: dict) -> Path:
    """A copy of the unpacked FMU whose shim records `interpreter` as the one that built it."""
    from rotary_vane.fmu_src.status_shim import compile_shim
    copy = S.copy_of(c_host_fmu, target)
    [private] = [p.name for p in (copy / "resources").iterdir() if p.is_dir() and p.name.startswith("rotary_vane_")]
    tag = f"{MODEL}/{private}"                        # as fmu_src/build.py gives it
    reason = compile_shim(copy / "binaries" / "linux64" / f"{MODEL}.so", tag, c_host_fmu["guid"], interpreter)
    assert reason is None, reason
    return copy


def test_the_python_on_path_serves_when_the_recorded_one_is_gone(c_host, c_host_fmu, folder):
    """The interpreter recorded at build time no longer exists: the first python3 on PATH is asked for its
    libpython and serves (here a python3 on PATH that runs this test's interpreter); with no python3 on PATH
    either, NULL and a message that names both places looked at."""
    gone = {"version": f"{sys.version_info.major}.{sys.version_info.minor}", "executable": "/gone/bin/python",
            "library": "/gone/lib/libpython.so"}
    copy = shim_with_recorded_interpreter(c_host_fmu, folder / "recorded interpreter gone", gone)
    bin_folder = folder / "bin with python3"
    bin_folder.mkdir(exist_ok=True)
    python3 = bin_folder / "python3"
    python3.write_text(f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
    python3.chmod(0o755)
    found = S.c_host_run(c_host, c_host_fmu, S.clean_environment(PATH=f"{bin_folder}:{S.CLEAN_PATH}"),
                         "--quick-exit", directory=copy, steps=2)
    assert found.returncode == 0, describe(found)
    none = S.c_host_run(c_host, c_host_fmu, S.clean_environment(PATH=str(folder / "empty")), "--quick-exit",
                        directory=copy, steps=2)
    assert none.returncode == 3, describe(none)
    [message] = S.parse_c_host(none.stdout)["error_logs"]
    assert "/gone/bin/python" in message and "no python3 on PATH" in message and "ROTARY_VANE_PYTHON" in message


@pytest.fixture(scope="session")
def python_host(c_host_fmu, folder):
    return S.python_host_cases(c_host_fmu["fmu"], folder)


def test_every_resource_location_form_gives_an_instance_that_steps(python_host):
    assert python_host["C16"] and all(value == INSTANCE for _, value in python_host["C16"]), python_host


@pytest.mark.parametrize("row", ["C17", "C18"])
def test_a_bad_resource_location_or_guid_gives_null_and_a_message(python_host, row):
    """NULL, and one message through the logger, with the category of fmi2Error, that quotes what was given."""
    assert python_host[row] and all(value == NULL for _, value in python_host[row]), python_host[row]
    for label, messages in python_host[f"messages of {row}"]:
        assert [(status, category) for status, category, _ in messages] == [(3, "logStatusError")], (label, messages)
        assert messages[0][2].startswith("fmi2Instantiate: "), (label, messages)


def test_status_inquiries_follow_the_state_table(python_host):
    """fmi2Error before initialization and in the error state (C20); after a step the inquiries pythonfmu can answer
    are fmi2OK (the last successful time is the end of the step, the slave does not want to terminate) and the
    others fmi2Discard (C14 and 'no such status'); after fmi2Terminate they are allowed too."""
    assert len(python_host["C20"]) == 15 and all(status == 3 for _, status in python_host["C20"]), python_host["C20"]
    assert all(status == 0 for _, status in python_host["allowed"]), python_host["allowed"]
    assert python_host["last successful time"] == pytest.approx(1e-3) and python_host["terminated"] == 0
    assert all(status == 2 for _, status in python_host["C14"] + python_host["no such status"])


def test_refused_inquiries_and_unsupported_calls_leave_the_state_alone(python_host):
    """After the refused status inquiries and the unsupported functions (C21: fmi2Error each) the instance is not in
    the error state: initialization, a step, fmi2Reset and a second run through fmi2Terminate all give fmi2OK."""
    assert len(python_host["C21"]) == 8 and all(status == 3 for _, status in python_host["C21"]), python_host["C21"]
    assert python_host["error state"] == [["fmi2DoStep with step size -1", 3]]
    assert all(status == 0 for _, status in python_host["after C20/C21"]), python_host["after C20/C21"]
    messages = python_host["state messages"]
    assert all(category in DECLARED_CATEGORIES for _, category, _ in messages), messages
    assert any("fmi2CancelStep is not supported" in text for _, _, text in messages), messages
    assert any("fmi2GetRealStatus is not allowed in the instantiated state" in text for _, _, text in messages)


@pytest.fixture(scope="session")
def fatal(c_host_fmu, folder):
    return S.fatal_cases(c_host_fmu["fmu"], folder)


def test_after_fatal_nothing_reaches_pythonfmu(fatal):
    """pythonfmu's library (a stub that aborts the process if called after its fmi2Fatal) answers a step with
    fmi2Fatal: every later call is fmi2Fatal from the shim, and fmi2FreeInstance does not reach the stub either."""
    assert fatal["before"] == [["fmi2DoStep answered fmi2Discard by pythonfmu", 2],
                               ["fmi2DoStep answered fmi2Fatal by pythonfmu", 4]]
    assert len(fatal["C22"]) == 11 and all(status == 4 for _, status in fatal["C22"]), fatal["C22"]
    assert fatal["freed"] is True


def test_pythonfmu_messages_get_declared_categories_and_a_discard_reaches_the_logger(fatal):
    """With debug logging off: the stub's discard (category "cppfmu") and fatal (no category) reach the logger with
    logStatusDiscard and logStatusFatal; each later call says the instance was lost and why."""
    messages = fatal["messages"]
    assert [m[:2] for m in messages[:2]] == [[2, "logStatusDiscard"], [4, "logStatusFatal"]], messages
    assert messages[0][2] == "stub: a discarded step" and messages[1][2] == "stub: a Python exception"
    later = messages[2:]
    assert len(later) == 11 and all(status == 4 and category == "logStatusFatal" and "the instance was lost" in text
                                    and "fmi2DoStep returned fmi2Fatal: stub: a Python exception" in text
                                    for status, category, text in later), later


@pytest.mark.slow
def test_first_step_latency_without_and_with_ld_preload(c_host, c_host_fmu):
    """The time from the C host's start to the end of its first fmi2DoStep, median of 3, from a clean environment
    and with the former recipe (LD_PRELOAD of libpython, PYTHONHOME, PYTHONPATH): the shim's own work (choosing and
    loading libpython) costs less than 0.2 s."""
    import site
    import statistics
    from rotary_vane.fmu_src.status_shim import shared_libpython
    preload = S.clean_environment(LD_PRELOAD=shared_libpython(), PYTHONHOME=sys.base_prefix,
                                  PYTHONPATH=os.pathsep.join(site.getsitepackages()))
    times = {}
    for label, env in (("clean", S.clean_environment()), ("LD_PRELOAD", preload)):
        runs = [S.parse_c_host(S.c_host_run(c_host, c_host_fmu, env, "--quick-exit", steps=1).stdout)["first_step"]
                for _ in range(3)]
        times[label] = statistics.median(runs)
    print(f"first-step latency: {times}")
    assert times["clean"] < times["LD_PRELOAD"] + 0.2, times
