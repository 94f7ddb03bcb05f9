"""Helpers for the FMU product tests (tests/fmu/test_fmu_compressor.py): build the FMU, drive it from host processes.

Every FMU run happens in a separate Python process (a "host"): a crash inside the FMU (a numba kernel, the
pythonfmu C++ layer, interpreter exit) then shows as a non-zero exit status instead of killing pytest. Two halves:

* test side (`build_fmu`, `run_host`, `run_hosts`): build the FMU with `python -m rotary_vane.fmu_src.build`, run a host script
  with a timeout and return its exit status, stderr and the JSON it emitted.
* host side (`Host`, `simulate`, `speed_signal`, `emit`): imported by the host scripts (this file only imports the
  standard library at module level, so a host can import foreign `mechanics`/`thermo` packages first). `Host`
  drives one instance through fmpy's low-level `FMU2Slave` API and records the FMI call trace (fmpy's
  `fmi_call_logger`) and the FMU's log messages (fmpy's `logger`, after fmpy's printf-style formatting proxy).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

PROJECT_DIR = Path(__file__).resolve().parents[1]
TESTS_DIR = Path(__file__).resolve().parent
MODEL = "RotaryVaneCompressor"
RESULT_PREFIX = "@@RESULT@@ "
DEFAULT_TIMEOUT = 240.0               # s per host process (a cold numba compile takes about 30 s)
STATUS_NAMES = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")
OK, WARNING, DISCARD, ERROR, FATAL = range(5)
CACHE_ENVIRONMENT_VARIABLE = "ROTARY_VANE_CACHE_DIR"

# the operating point of the issue: 1500 rpm, c = 0.05 mm (slot and stator clearance)
# the operating point of the FMU tests whose subject is not the chamber gas: the Level 0.5 pressure table (the FMU's
# default is the real gas; the tests that concern it set nothing or pressure_model = "real_gas")
OPERATING_POINT = {"shaft_speed": 1500.0, "slot_clearance": 5e-5, "stator_clearance": 5e-5,
                   "pressure_model": "ideal_gas_table"}


# test side ----------------------------------------------------------------------------------------------------
def build_fmu(out_dir: Path, project_dir: Path = PROJECT_DIR, timeout: float = 900.0, options=()) -> Path:
    """Build the FMU of the sources in `project_dir` into `out_dir` (a subprocess, with the build's `options`);
    return the .fmu path."""
    out_dir = Path(out_dir)
    done = subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", str(out_dir), *options],
                          cwd=project_dir, env=host_environment(), capture_output=True, text=True, timeout=timeout)
    if done.returncode != 0:
        raise RuntimeError(f"FMU build in {project_dir} failed with exit status {done.returncode}:\n"
                           f"{done.stdout}\n{done.stderr}")
    path = out_dir / f"{MODEL}.fmu"
    if not path.is_file():
        raise RuntimeError(f"FMU build did not write {path}:\n{done.stdout}\n{done.stderr}")
    return path


def host_environment(**changes: str) -> dict[str, str]:
    """The environment of a host process: this one without PYTHONPATH, plus `changes`."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env.update(changes)
    return env


@dataclass
class HostRun:
    """What one host process did."""
    returncode: int
    stdout: str
    stderr: str
    wall: float
    results: list = field(default_factory=list)       # every emitted JSON object, in order

    @property
    def result(self):
        """The last emitted JSON object."""
        if not self.results:
            raise AssertionError(f"the host emitted no result (exit status {self.returncode}).\n"
                                 f"stdout:\n{self.stdout[-3000:]}\nstderr:\n{self.stderr[-3000:]}")
        return self.results[-1]

    def check(self) -> "HostRun":
        """Assert a clean exit (status 0: no crash, also not at interpreter exit); return self."""
        assert self.returncode == 0, (
            f"host process exited with status {self.returncode}"
            f"{' (signal ' + str(-self.returncode) + ')' if self.returncode < 0 else ''}\n"
            f"stdout:\n{self.stdout[-3000:]}\nstderr:\n{self.stderr[-5000:]}")
        return self


def run_host(script: str, *, env: dict[str, str] | None = None, timeout: float = DEFAULT_TIMEOUT,
             cwd: Path | None = None) -> HostRun:
    """Run `script` (Python source; dedented) in a fresh interpreter with a timeout.

    The script runs from a temporary folder (nothing of the project on sys.path except through the installed
    package); `import fmu_helpers as H` works in it (the tests folder is appended to sys.path). Unless `env` names
    one, its TMPDIR is a folder inside that one, removed with it: fmpy unpacks every FMU a host loads into a new
    40 MB temporary folder, and hundreds of host processes must not fill the disk.
    """
    source = (f"import sys\nsys.path.append({str(TESTS_DIR)!r})\n" + textwrap.dedent(script))
    with tempfile.TemporaryDirectory(prefix="rvc_host_") as folder:
        path = Path(folder) / "host.py"
        path.write_text(source)
        start = time.perf_counter()
        try:
            done = subprocess.run([sys.executable, str(path)], cwd=cwd or folder,
                                  env=private_temporary_folder(env if env is not None else host_environment(),
                                                               Path(folder)),
                                  capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired as expired:
            raise AssertionError(f"host process did not finish within {timeout} s\nstdout:\n"
                                 f"{(expired.stdout or b'')[-3000:]!r}\nstderr:\n{(expired.stderr or b'')[-3000:]!r}")
        wall = time.perf_counter() - start
    results = [json.loads(line[len(RESULT_PREFIX):]) for line in done.stdout.splitlines()
               if line.startswith(RESULT_PREFIX)]
    return HostRun(done.returncode, done.stdout, done.stderr, wall, results)


def private_temporary_folder(env: dict[str, str], folder: Path) -> dict[str, str]:
    """`env` with TMPDIR set to a new folder `folder`/tmp, unless `env` sets a TMPDIR of its own (one that is not
    this process's: the test session sets TMPDIR for itself, tests/conftest.py, and every host environment copies
    it)."""
    if env.get("TMPDIR") not in (None, os.environ.get("TMPDIR")):
        return env
    (folder / "tmp").mkdir()
    return dict(env, TMPDIR=str(folder / "tmp"))


def run_hosts(scripts: list[str], *, env: dict[str, str] | None = None, timeout: float = DEFAULT_TIMEOUT,
              jobs: int = 2) -> list[HostRun]:
    """Run several host scripts, `jobs` at a time; results in the order of `scripts`."""
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(lambda s: run_host(s, env=env, timeout=timeout), scripts))


def cache_listing(folder: Path) -> dict[str, tuple[int, int]]:
    """relative path -> (size, mtime in ns) of every file under `folder`."""
    folder = Path(folder)
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file()}


def periodic_map_messages(stderr: str) -> list[str]:
    """The lines a host wrote about its periodic-map tables ('[periodic map] loaded ...', '... building ...')."""
    return [line for line in stderr.splitlines() if line.startswith("[periodic map]")]


def relative_difference(value: float, reference: float) -> float:
    return abs(value - reference) / abs(reference)


# host side ----------------------------------------------------------------------------------------------------
def emit(obj) -> None:
    """Send a JSON-serialisable result to the test (floats round-trip exactly through repr)."""
    print(RESULT_PREFIX + json.dumps(obj), flush=True)


def speed_signal(rows):
    """fmpy input: a structured array with columns time and shaft_speed; a repeated time is a step change."""
    import numpy as np
    return np.array([tuple(map(float, row)) for row in rows], dtype=[("time", np.float64),
                                                                     ("shaft_speed", np.float64)])


def status_of(call: str) -> str:
    """'OK', 'DISCARD', ... from one line of fmpy's fmi_call_logger ('' for calls without a status)."""
    return call.rsplit("-> ", 1)[1].strip() if "-> " in call and call.rsplit("-> ", 1)[1].strip() in STATUS_NAMES \
        else ""


class Host:
    """One FMU instance driven through fmpy's documented low-level API (fmpy.fmi2.FMU2Slave).

    `events` interleaves the FMI calls (("call", text, status)) with the FMU's log messages
    (("log", status, category, message)); a message belongs to the next call in the list (the FMU logs while the
    call runs, fmpy's call logger reports the call when it returns).
    """

    def __init__(self, fmu: str | Path, unzipdir: str | Path | None = None):
        from fmpy import extract, read_model_description
        from fmpy.simulation import instantiate_fmu
        self.unzipdir = str(unzipdir if unzipdir is not None else extract(str(fmu)))
        self.model_description = read_model_description(self.unzipdir)
        self.variables = {v.name: v for v in self.model_description.modelVariables}
        self.real_outputs = [v.name for v in self.model_description.modelVariables
                             if v.causality == "output" and v.type == "Real"]
        self.integer_outputs = [v.name for v in self.model_description.modelVariables
                                if v.causality == "output" and v.type == "Integer"]
        self.events: list[tuple] = []
        self.fmu = instantiate_fmu(self.unzipdir, self.model_description, "CoSimulation", debug_logging=True,
                                   logger=self._log, fmi_call_logger=self._call)

    def _log(self, environment, instance, status, category, message):
        self.events.append(("log", int(status), (category or b"").decode(errors="replace"),
                            (message or b"").decode(errors="replace")))

    def _call(self, text):
        self.events.append(("call", text, status_of(text)))

    # values --------------------------------------------------------------------------------------------
    def set(self, **values) -> None:
        for name, value in values.items():
            variable = self.variables[name]
            reference = [variable.valueReference]
            if variable.type == "Real":
                self.fmu.setReal(reference, [float(value)])
            elif variable.type == "Integer":
                self.fmu.setInteger(reference, [int(value)])
            elif variable.type == "Boolean":
                self.fmu.setBoolean(reference, [bool(value)])
            else:
                self.fmu.setString(reference, [str(value)])

    def outputs(self) -> dict:
        """Every output (Real and Integer)."""
        reals = self.fmu.getReal([self.variables[n].valueReference for n in self.real_outputs])
        integers = self.fmu.getInteger([self.variables[n].valueReference for n in self.integer_outputs])
        return {**dict(zip(self.real_outputs, reals)), **dict(zip(self.integer_outputs, integers))}

    # FMI sequence ----------------------------------------------------------------------------------------
    def initialize(self, start_time: float = 0.0, **parameters) -> int:
        """setupExperiment, parameters (and start inputs), enter and exit initialization mode; exit's status."""
        from fmpy.fmi1 import FMICallException
        self.fmu.setupExperiment(startTime=start_time)
        self.set(**parameters)
        self.fmu.enterInitializationMode()
        try:
            return self.fmu.exitInitializationMode()
        except FMICallException as error:
            return error.status

    def step(self, current_time: float, step_size: float) -> int:
        """fmi2DoStep; its status (0 OK, 2 discard, ...), never an exception."""
        from fmpy.fmi1 import FMICallException
        try:        # fmpy's wrapper of the C function returns the status (FMU2Slave.doStep returns None)
            return self.fmu.fmi2DoStep(self.fmu.component, current_time, step_size, 1)
        except FMICallException as error:
            return error.status

    def run(self, start: float, step_size: float, steps: int, speed=None) -> list[dict]:
        """`steps` communication steps from `start`; speed(t) (rpm) is set before each step if given; returns
        the outputs after each step. Fails (AssertionError) on any status other than OK."""
        rows = []
        for k in range(steps):
            t = start + k * step_size
            if speed is not None:
                self.set(shaft_speed=speed(t))
            status = self.step(t, step_size)
            assert status == OK, f"doStep({t}, {step_size}) returned {STATUS_NAMES[status]}: {self.messages()[-3:]}"
            rows.append(self.outputs())
        return rows

    def close(self) -> None:
        """fmi2Terminate (refused with fmi2Error in the error state, where only fmi2FreeInstance is left) and
        fmi2FreeInstance. The unpacked folder stays until run_host removes the host's temporary folder: the FMU's
        Python code, imported from the first instance's folder, stays imported for the process, and a later instance
        reads its compiled kernels from there."""
        from fmpy.fmi1 import FMICallException
        try:
            self.fmu.terminate()
        except FMICallException:
            pass
        self.fmu.freeInstance()

    # trace -----------------------------------------------------------------------------------------------
    def calls(self) -> list[str]:
        return [e[1] for e in self.events if e[0] == "call"]

    def messages(self) -> list[tuple[int, str, str]]:
        return [e[1:] for e in self.events if e[0] == "log"]

    def trace(self) -> list[dict]:
        """Each call with its status and the messages logged during it."""
        out, pending = [], []
        for event in self.events:
            if event[0] == "log":
                pending.append({"status": event[1], "category": event[2], "message": event[3]})
            else:
                name = event[1].split("(", 1)[0]
                out.append({"function": name, "status": event[2], "messages": pending})
                pending = []
        return out


def simulate(fmu: str | Path, **kwargs) -> dict:
    """fmpy.simulate_fmu with debug logging, a message logger and the call trace; returns a JSON-able dict with
    the result columns, the call statuses and the messages."""
    from fmpy import simulate_fmu
    messages, calls = [], []

    def logger(environment, instance, status, category, message):
        messages.append((int(status), (category or b"").decode(errors="replace"),
                         (message or b"").decode(errors="replace")))

    result = simulate_fmu(str(fmu), debug_logging=True, logger=logger, fmi_call_logger=calls.append, **kwargs)
    return {"columns": {name: [float(v) for v in result[name]] for name in result.dtype.names},
            "statuses": sorted({status_of(c) for c in calls} - {""}), "messages": messages,
            "resource_location": next((c.split('resourceLocation="', 1)[1].split('"', 1)[0]
                                       for c in calls if c.startswith("fmi2Instantiate")), None)}


def finite(values) -> bool:
    return all(math.isfinite(v) for v in values)


# What a script for run_json_script starts with: its spec from argv[1], and `load(path, name)`, which instantiates
# an FMU with fmpy's FMU2Slave and leaves it in initialization mode (returns the slave and its value references).
JSON_SCRIPT_PREAMBLE = r'''import json, sys
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave
spec = json.loads(sys.argv[1])

def load(path, name):
    md = read_model_description(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName=name)
    fmu.instantiate(loggingOn=True)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    return fmu, {v.name: v.valueReference for v in md.modelVariables}
'''


def run_json_script(script: str, spec: dict, cwd, timeout: float = 300.0):
    """Run `script` in a fresh interpreter in `cwd` with the JSON `spec` as argv[1]; it prints one line
    'RESULT <json>'. Return (that result, the completed process); fail if the script did not finish."""
    with tempfile.TemporaryDirectory(prefix="rvc_script_") as folder:
        process = subprocess.run([sys.executable, "-c", script, json.dumps(spec)], cwd=cwd, capture_output=True,
                                 text=True, timeout=timeout,
                                 env=private_temporary_folder(dict(os.environ), Path(folder)))
    assert process.returncode == 0, \
        f"subprocess failed:\n{process.stdout[-3000:]}\n{process.stderr[-3000:]}"
    lines = [line for line in process.stdout.splitlines() if line.startswith("RESULT ")]
    assert lines, f"no result:\n{process.stdout[-3000:]}\n{process.stderr[-3000:]}"
    return json.loads(lines[-1][len("RESULT "):]), process
