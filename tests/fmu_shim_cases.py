"""Runs of the FMU's shim (fmu_src/c/fmi2_status_shim.c), made once per test session and shared by
tests/fmu/test_fmu_c_host.py (which checks their details) and tests/fmu/test_fmu_contract.py (README rows C14, C16-C22).

* `python_host_cases`: a Python host (fmpy's FMU2Slave, its functions called directly) instantiates the built FMU
  with every resource-location form, with locations and GUIDs that must be refused, and walks the FMI states asking
  the status inquiries and calling the unsupported functions in each; debug logging is off throughout.
* `fatal_cases`: the same host with pythonfmu's library replaced by tests/c_host/pythonfmu_stub.c, which answers
  fmi2Fatal and aborts the process if the shim forwards any call after it.
* `c_host_run`: the C host (tests/c_host/fmu_host.c) in a clean environment: PATH=/usr/bin:/bin and HOME only (plus
  the kernel cache folder), no LD_PRELOAD, PYTHONHOME or PYTHONPATH.
"""
from __future__ import annotations

import functools
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import fmu_helpers as H

TESTS_DIR = Path(__file__).resolve().parent
HOST_SOURCE = TESTS_DIR / "c_host" / "fmu_host.c"
STUB_SOURCE = TESTS_DIR / "c_host" / "pythonfmu_stub.c"
CLEAN_PATH = "/usr/bin:/bin"
INSTANCE, NULL = "an instance", "NULL"          # what fmi2Instantiate returned, as the README's table writes it


def clean_environment(**changes: str) -> dict[str, str]:
    """PATH=/usr/bin:/bin and HOME, the kernel cache folder if the session sets one, and `changes`."""
    env = {"PATH": CLEAN_PATH, "HOME": os.environ.get("HOME", "/")}
    if os.environ.get(H.CACHE_ENVIRONMENT_VARIABLE):
        env[H.CACHE_ENVIRONMENT_VARIABLE] = os.environ[H.CACHE_ENVIRONMENT_VARIABLE]
    return {**env, **changes}


@functools.cache
def unpacked(fmu: Path, folder: Path) -> dict:
    """The FMU unzipped into folder/unpacked, and its modelDescription facts."""
    target = folder / "unpacked"
    if not target.is_dir():
        with zipfile.ZipFile(fmu) as archive:
            archive.extractall(target)
    root = ElementTree.parse(target / "modelDescription.xml").getroot()
    return {"fmu": fmu, "dir": target, "guid": root.get("guid"),
            "identifier": root.find("CoSimulation").get("modelIdentifier"),
            "vr": {v.get("name"): int(v.get("valueReference")) for v in root.iter("ScalarVariable")}}


def compile_c(source: Path, output: Path, *options: str) -> Path:
    gcc = shutil.which("gcc")
    if gcc is None:
        raise RuntimeError("gcc is not installed")
    done = subprocess.run([gcc, "-std=c99", "-O1", "-Wall", "-Wextra", *options, "-o", str(output), str(source),
                           "-ldl"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "warning" not in done.stderr, done.stderr
    return output


@functools.cache
def c_host(folder: Path) -> Path:
    return compile_c(HOST_SOURCE, folder / "fmu_host")


def c_host_run(host: Path, facts: dict, env: dict[str, str], *options: str, speed: float = 1500.0, steps: int = 200,
               step_size: float = 1e-3, directory: Path | None = None, timeout: float = 300):
    """The C host on the unpacked FMU (or the copy in `directory`), with `env` as its whole environment."""
    arguments = [str(host), str(directory or facts["dir"]), facts["identifier"], facts["guid"],
                 str(facts["vr"]["shaft_speed"]), str(facts["vr"]["shaft_torque_mean"]),
                 str(facts["vr"]["input_power"]), repr(speed), str(steps), repr(step_size), *options]
    return subprocess.run(arguments, capture_output=True, text=True, timeout=timeout, env=env,
                          cwd=(directory or facts["dir"]).parent)


def parse_c_host(stdout: str) -> dict:
    """The C host's RESULT, WORST_STATUS and FIRST_STEP_SECONDS lines, its not-OK calls and its log lines."""
    match = re.search(r"^RESULT steps=(\d+) time=(\S+) shaft_torque_mean=(\S+) input_power=(\S+)$", stdout, re.M)
    worst = re.search(r"^WORST_STATUS (\d+)$", stdout, re.M)
    first = re.search(r"^FIRST_STEP_SECONDS (\S+)$", stdout, re.M)
    return {"steps": int(match[1]) if match else None, "time": float(match[2]) if match else None,
            "shaft_torque_mean": float(match[3]) if match else None, "input_power": float(match[4]) if match else None,
            "worst_status": int(worst[1]) if worst else None, "first_step": float(first[1]) if first else None,
            "not_ok_calls": re.findall(r"^CALL .*$", stdout, re.M), "logs": re.findall(r"^LOG .*$", stdout, re.M),
            "error_logs": re.findall(r"^LOG \[(?:DISCARD|ERROR|FATAL|PENDING|ILLEGAL)\].*$", stdout, re.M)}


# a Python host that calls fmi2Instantiate itself (fmpy's FMU2Slave builds the resource location from its folder)
PRELUDE = """
import json, sys
from ctypes import byref, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p
from fmpy import read_model_description
from fmpy.fmi2 import (FMU2Slave, calloc, free, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
from fmpy.fmi1 import FMICallException
from fmpy.logging import addLoggerProxy

unzipdir = sys.argv[1]
description = read_model_description(unzipdir)
messages = []

def log(environment, instance, status, category, message):
    messages.append([int(status), (category or b"").decode(), (message or b"").decode(errors="replace")])

callbacks = fmi2CallbackFunctions()
callbacks.logger = fmi2CallbackLoggerTYPE(log)
callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
addLoggerProxy(byref(callbacks))
f = FMU2Slave(guid=description.guid, unzipDirectory=unzipdir, instanceName="shim",
              modelIdentifier=description.coSimulation.modelIdentifier)
out = {"messages": messages}

def record(key, label, value):
    out.setdefault(key, []).append([label, value])

def instantiate(location, guid=description.guid.encode()):
    del messages[:]
    f.component = f.fmi2Instantiate(b"shim", 1, guid, location, byref(callbacks), 0, 0)
    return f.component

def status(function, *args):
    try:
        result = getattr(f, function)(f.component, *args)
        return int(result) if isinstance(result, int) else 0
    except FMICallException as error:
        return int(error.status)

INQUIRIES = [("fmi2GetStatus", 0, c_int), ("fmi2GetRealStatus", 2, c_double), ("fmi2GetIntegerStatus", 0, c_int),
             ("fmi2GetBooleanStatus", 3, c_int), ("fmi2GetStringStatus", 1, c_char_p)]

def inquiries(key, where):
    for function, kind, kind_type in INQUIRIES:
        record(key, f"{function} {where}", status(function, kind, byref(kind_type())))
"""

PYTHON_HOST_CASES = PRELUDE + """
good = json.loads(sys.argv[2])                 # [label, location]: each must give an instance that steps
for label, location in good:
    if instantiate(location.encode()):
        steps = [status("fmi2SetupExperiment", 0, 0.0, 0.0, 0, 0.0), status("fmi2EnterInitializationMode"),
                 status("fmi2ExitInitializationMode"), status("fmi2DoStep", 0.0, 1e-3, 1)]
        record("C16", label, "an instance" if steps == [0, 0, 0, 0] else f"an instance whose calls gave {steps}")
        f.fmi2FreeInstance(f.component)
    else:
        record("C16", label, "NULL")
        record("messages of C16", label, list(messages))
for row, label, location, guid in json.loads(sys.argv[3]):      # each must give NULL with a message
    instance = instantiate(None if location is None else location.encode(),
                           None if guid is None else guid.encode() if guid else description.guid.encode())
    record(row, label, "an instance" if instance else "NULL")
    record(f"messages of {row}", label, list(messages))
    if instance:
        f.fmi2FreeInstance(instance)

# the FMI states: the status inquiries (C14, C20) and the unsupported functions (C21) in each
assert instantiate(f"file://{unzipdir}/resources".encode())
UNSUPPORTED = [("fmi2GetDirectionalDerivative", (None, 0, None, 0, None, None)),
               ("fmi2SetRealInputDerivatives", (None, 0, None, None)),
               ("fmi2GetRealOutputDerivatives", (None, 0, None, None)), ("fmi2CancelStep", ())]
def unsupported(where):
    for function, args in UNSUPPORTED:
        record("C21", f"{function} {where}", status(function, *args))
inquiries("C20", "in the instantiated state")
unsupported("in the instantiated state")
record("after C20/C21", "fmi2SetupExperiment", status("fmi2SetupExperiment", 0, 0.0, 0.0, 0, 0.0))
record("after C20/C21", "fmi2EnterInitializationMode", status("fmi2EnterInitializationMode"))
inquiries("C20", "in initialization mode")
record("after C20/C21", "fmi2ExitInitializationMode", status("fmi2ExitInitializationMode"))
unsupported("after initialization")
record("after C20/C21", "fmi2DoStep", status("fmi2DoStep", 0.0, 1e-3, 1))
time, terminated = c_double(), c_int(7)
record("allowed", "fmi2GetRealStatus(fmi2LastSuccessfulTime) after a step",
       status("fmi2GetRealStatus", 2, byref(time)))
record("allowed", "fmi2GetBooleanStatus(fmi2Terminated) after a step", status("fmi2GetBooleanStatus", 3,
                                                                              byref(terminated)))
out["last successful time"], out["terminated"] = time.value, terminated.value
record("C14", "fmi2GetStatus after a step", status("fmi2GetStatus", 0, byref(c_int())))
for function, kind, kind_type in INQUIRIES[2:3] + INQUIRIES[4:]:
    record("no such status", f"{function} after a step", status(function, kind, byref(kind_type())))
record("error state", "fmi2DoStep with step size -1", status("fmi2DoStep", 1e-3, -1.0, 1))
inquiries("C20", "in the error state")
record("after C20/C21", "fmi2Reset", status("fmi2Reset"))
for function, args in [("fmi2SetupExperiment", (0, 0.0, 0.0, 0, 0.0)), ("fmi2EnterInitializationMode", ()),
                       ("fmi2ExitInitializationMode", ()), ("fmi2Terminate", ())]:
    record("after C20/C21", function, status(function, *args))
record("allowed", "fmi2GetBooleanStatus(fmi2Terminated) after fmi2Terminate",
       status("fmi2GetBooleanStatus", 3, byref(c_int())))
out["state messages"] = list(messages)
f.fmi2FreeInstance(f.component)
print("@@RESULT@@ " + json.dumps(out), flush=True)
"""

FATAL_CASES = PRELUDE + """
assert instantiate(f"file://{unzipdir}/resources".encode())
record("before", "fmi2DoStep answered fmi2Discard by pythonfmu", status("fmi2DoStep", 0.0, 1e-3, 1))
record("before", "fmi2DoStep answered fmi2Fatal by pythonfmu", status("fmi2DoStep", 0.0, 1e-3, 1))
state = c_void_p()
for label, function, args in [
        ("fmi2GetReal", "fmi2GetReal", ((c_uint * 1)(0), 1, (c_double * 1)())),
        ("fmi2SetReal", "fmi2SetReal", ((c_uint * 1)(0), 1, (c_double * 1)(1.0))),
        ("fmi2GetFMUstate", "fmi2GetFMUstate", (byref(state),)),
        ("fmi2SetFMUstate", "fmi2SetFMUstate", (c_void_p(1),)),
        ("fmi2SerializedFMUstateSize", "fmi2SerializedFMUstateSize", (c_void_p(1), byref(c_size_t()))),
        ("fmi2DoStep", "fmi2DoStep", (0.0, 1e-3, 1)), ("fmi2Reset", "fmi2Reset", ()),
        ("fmi2Terminate", "fmi2Terminate", ()), ("fmi2SetDebugLogging", "fmi2SetDebugLogging", (1, 0, None)),
        ("fmi2GetBooleanStatus", "fmi2GetBooleanStatus", (3, byref(c_int()))),
        ("fmi2CancelStep", "fmi2CancelStep", ())]:
    record("C22", f"{label} after fmi2Fatal", status(function, *args))
f.fmi2FreeInstance(f.component)
out["freed"] = True
print("@@RESULT@@ " + json.dumps(out), flush=True)
"""


def run_script(script: str, *arguments: str, timeout: float = 300) -> dict:
    done = subprocess.run([sys.executable, "-c", script, *arguments], capture_output=True, text=True,
                          timeout=timeout, env=H.host_environment(), cwd=TESTS_DIR)
    lines = [line for line in done.stdout.splitlines() if line.startswith(H.RESULT_PREFIX)]
    assert done.returncode == 0 and lines, (f"exit status {done.returncode}\n--- stdout\n{done.stdout[-3000:]}"
                                            f"\n--- stderr\n{done.stderr[-3000:]}")
    return json.loads(lines[-1][len(H.RESULT_PREFIX):])


def copy_of(facts: dict, target: Path) -> Path:
    """A copy of the unpacked FMU at `target` (a new folder)."""
    if not target.is_dir():
        shutil.copytree(facts["dir"], target, symlinks=True)
    return target


@functools.cache
def python_host_cases(fmu: Path, folder: Path) -> dict:
    facts = unpacked(fmu, folder)
    resources = facts["dir"] / "resources"
    encoded = copy_of(facts, folder / "a folder with spaces" / "ünïcødé") / "resources"
    link = folder / "link to the unpacked FMU"
    if not link.exists():
        link.symlink_to(facts["dir"], target_is_directory=True)
    real = str(resources)
    good = [["file:///abs", f"file://{real}"], ["file:////abs (Ecos: file:/// + /abs)", f"file:///{real}"],
            ["file:/abs", f"file:{real}"], ["file://localhost/abs", f"file://localhost{real}"],
            ["FILE://LocalHost/abs", f"FILE://LocalHost{real}"],
            ["percent-encoded spaces and non-ASCII folder names", encoded.as_uri()],
            ["a path through a symbolic link and ..", f"file://{link}/binaries/../resources"]]
    bad = [["C17", "a folder that does not exist", "file:///nonexistent/resources", ""],
           ["C17", "an empty location", "", ""], ["C17", "a null location", None, ""],
           ["C17", "a plain path without a scheme", real, ""],
           ["C17", "an http: URI", "http://example.com/resources", ""],
           ["C17", "another host", f"file://otherhost{real}", ""],
           ["C17", "a relative path", "file:resources", ""],
           ["C17", "a malformed percent escape", f"file://{real}%zz", ""],
           ["C17", "a folder without the FMU's resources", f"file://{facts['dir']}", ""],
           ["C17", "a file instead of a folder", f"file://{resources}/slavemodule.txt", ""],
           ["C18", "a GUID of another FMU", f"file://{real}", "{00000000-0000-0000-0000-000000000000}"],
           ["C18", "a null GUID", f"file://{real}", None]]
    return run_script(PYTHON_HOST_CASES, str(facts["dir"]), json.dumps(good), json.dumps(bad))


@functools.cache
def fatal_cases(fmu: Path, folder: Path) -> dict:
    from rotary_vane.fmu_src.status_shim import fmi_headers
    facts = unpacked(fmu, folder)
    stubbed = copy_of(facts, folder / "with a pythonfmu stub")
    compile_c(STUB_SOURCE, stubbed / "binaries" / "linux64" / f"{facts['identifier']}_pythonfmu.so", "-fPIC",
              "-shared", "-Wno-unused-parameter", f"-I{fmi_headers()}")
    return run_script(FATAL_CASES, str(stubbed))


@functools.cache
def no_python_run(fmu: Path, folder: Path):
    """The C host with ROTARY_VANE_PYTHON naming an interpreter that does not exist."""
    facts = unpacked(fmu, folder)
    return c_host_run(c_host(folder), facts, clean_environment(ROTARY_VANE_PYTHON="/nonexistent/bin/python3"),
                      "--quick-exit", steps=2)


def cases_folder(tmp_path_factory) -> Path:
    """The session's one folder for these runs (the same path from every test module, so each run is made once)."""
    folder = tmp_path_factory.getbasetemp() / "fmu_shim_cases"
    folder.mkdir(exist_ok=True)
    return folder
