"""Parameter campaigns through the compressor FMU on dask: a grid or a list of parameter sets, one FMU run per point.

A campaign is a list of points; a point names FMU parameters (by their FMU variable names, SI units), inputs held
at a value over the run (`shaft_speed` [rpm], the suction and discharge conditions), and the run settings `stop_time` [s] and `communication_step` [s]; what a point leaves out
takes the FMU's start value (the run settings: the FMU's default experiment). Every name, type and declared range
is checked against the FMU's modelDescription before anything runs (an unknown name is refused with the closest
names). Checks that involve several parameters belong to the FMU: such a point runs, the FMU refuses it at
initialization, and it is recorded as failed with the FMU's message.

Each point runs at constant speed from t = 0 to `stop_time` in steps of `communication_step` in a dask worker
process (processes, not threads: every FMI call holds the GIL). A worker keeps one FMU instance and calls
fmi2Reset between points. The row of a point holds its parameter values, the status (done/failed), the FMU's
error and warning messages, and the summary figures read from the FMU outputs at the stop time:

* input_power, output_power, friction_power, damping_power, mechanical_efficiency, max_contact_force: the FMU's
  figures of the last completed revolution (left empty when the run completed none: the FMU reports 0 then);
* run_mean_shaft_torque = shaft_work / shaft_angle, the mean driving torque over the whole run (the average of
  the FMU's step-mean torque shaft_torque_mean weighted by the angle turned), and run_mean_input_power =
  shaft_work / end_time; shaft_work, shaft_angle, contact_mode_count and end_time (the time reached) at the end.

Results go to a CSV store, one line per point, appended (flushed and fsynced) as each point finishes. Columns:
point_id, status, the parameters the campaign sets (shaft_speed, stop_time, communication_step and every name
any point gives; full values, defaults filled in), the figures above, wall_time and cpu_time [s] (measured in the
worker around the point; cpu_time is the worker thread's CPU time: wall_time > cpu_time means it waited for a
CPU), worker (host:pid), fmu_guid, finished_at (UTC) and error. `point_id` is a hash of the point's full parameter
set (given values plus the FMU's start values of everything else), so a rerun of the same campaign skips the
points already in the store: killing a campaign loses only the points that were running. Failed points are
skipped too (the FMU refuses the same parameters again); `--retry-failed` runs them again and replaces their rows.
The store is locked while a campaign writes to it (`<store>.lock`). CSV rather than Parquet: a Parquet file cannot
be appended to row by row (each point would be a new file or a rewrite), CSV needs no pyarrow, any tool reads it.

Cluster: a LocalCluster of `--workers` processes by default, or an existing scheduler (`--scheduler
tcp://host:8786`). Workers read the FMU from its path: on a remote cluster the file must be at the same absolute
path on every worker host (a shared filesystem; a worker that lacks it, or has a different build, records the
point as failed). Each worker needs Python of the client's minor version with dask/distributed and cloudpickle
of the client's versions, fmpy, and the FMU's resources/requirements.txt (numpy, numba, pythonfmu; CoolProp for real gas); this project need
not be installed there: the FMU bundles its code and this module's functions are sent by value. The FMU ships its
numba kernels compiled; a host whose numba, Python or CPU they do not fit compiles them at its first point (about
30 s; cached in ROTARY_VANE_CACHE_DIR or ~/.cache).

Python API (run it under `if __name__ == "__main__":`: local workers are spawned processes that import the main
module):

    from rotary_vane.examples.campaign import grid, read_store, run_campaign
    points = grid({("slot_clearance", "stator_clearance"): [0.0, 5e-5], "shaft_speed": [1000, 1500]},
                  fixed={"stop_time": 0.5})
    report = run_campaign("build/fmu/RotaryVaneCompressor.fmu", points, "out/study.csv", workers=2)
    rows = read_store("out/study.csv")                        # dicts of strings, one per point

Usage (after `python -m rotary_vane.fmu_src.build`, which writes build/fmu/RotaryVaneCompressor.fmu):

    python examples/campaign.py --list-parameters
    python examples/campaign.py --store out/clearance.csv \\
        --grid slot_clearance+stator_clearance=0,2e-5,5e-5,1e-4,2e-4 --grid shaft_speed=1000,1500,2000 \\
        --set stop_time=0.5 --workers 2
    python examples/campaign.py --points points.json --store out/points.csv --scheduler tcp://10.0.0.5:8786

Names joined by '+' in one --grid move together (cR = cS above: 5 x 3 = 15 points). Exit status: 0 every point
done, 1 some point failed (all recorded), 2 bad arguments or parameters, 130 interrupted.
"""
from __future__ import annotations

import argparse
import csv
import difflib
import fcntl
import hashlib
import io
import itertools
import json
import math
import os
import shutil
import signal
import socket
import sys
import tempfile
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

PROJECT_DIR = Path(__file__).resolve().parents[1]
DEFAULT_FMU = PROJECT_DIR / "build" / "fmu" / "RotaryVaneCompressor.fmu"
SPEED_INPUT = "shaft_speed"
RUN_SETTINGS = ("stop_time", "communication_step")
PLUGIN_NAME = "rotary-vane-fmu-instances"
DONE, FAILED = "done", "failed"
# FMU outputs of the last completed revolution; the FMU reports 0 for them before the first one
REVOLUTION_OUTPUTS = ("input_power", "output_power", "friction_power", "damping_power", "mechanical_efficiency",
                      "max_contact_force")
RESULT_COLUMNS = (*REVOLUTION_OUTPUTS, "run_mean_shaft_torque", "run_mean_input_power", "shaft_work",
                  "shaft_angle", "contact_mode_count", "end_time")
RECORD_COLUMNS = ("wall_time", "cpu_time", "worker", "fmu_guid", "finished_at", "error")
MAX_ERROR_LENGTH = 2000                     # characters of FMU messages kept per point
STATUS_NAMES = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")


# the parameter space ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Setting:
    """One name a point may set: an FMU parameter, the speed input or a run setting."""
    name: str
    kind: str                                # Real, Integer, Boolean or String
    unit: str
    default: object
    minimum: float | None = None
    maximum: float | None = None
    positive: bool = False                   # run settings: > 0 (exclusive)
    description: str = ""

    def allowed_text(self) -> str:
        if self.positive:
            return f"a finite value > 0 {self.unit}".rstrip()
        if self.kind in ("Real", "Integer"):
            low = "-inf" if self.minimum is None else f"{self.minimum:g}"
            high = "inf" if self.maximum is None else f"{self.maximum:g}"
            return f"{'an integer in ' if self.kind == 'Integer' else ''}[{low}, {high}] {self.unit}".rstrip()
        return {"Boolean": "true or false", "String": "a string"}[self.kind]

    def convert(self, value, where: str):
        """The value in its canonical Python type (float, int, bool, str); ValueError naming the setting, the
        value and the allowed range otherwise. Strings (from the command line or a CSV) are parsed."""
        refused = ValueError(f"{where}parameter '{self.name}' = {value!r} is invalid: allowed {self.allowed_text()}")
        if self.kind == "String":
            if not isinstance(value, str):
                raise refused
            return value
        if self.kind == "Boolean":
            text = str(value).strip().lower()
            if isinstance(value, bool) or text in ("true", "false", "1", "0"):
                return value if isinstance(value, bool) else text in ("true", "1")
            raise refused
        if isinstance(value, bool):
            raise refused
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise refused from None
        if not math.isfinite(number):
            raise refused
        if self.kind == "Integer":
            if number != int(number):
                raise refused
            number = int(number)
        else:
            number += 0.0                    # -0.0 -> 0.0: one canonical zero for the point id
        if self.positive and number <= 0.0:
            raise refused
        if (self.minimum is not None and number < self.minimum) or (self.maximum is not None
                                                                     and number > self.maximum):
            raise refused
        return number


@dataclass(frozen=True)
class Point:
    """A resolved point: its id and its full parameter set (every setting, defaults included)."""
    point_id: str
    values: dict


def point_id(values: dict) -> str:
    """16 hex digits of SHA-256 over the canonical JSON of the full parameter set (sorted keys, repr floats)."""
    text = json.dumps(values, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class ParameterSpace:
    """What a point of a campaign on one FMU may set, read from the FMU's modelDescription."""

    def __init__(self, fmu: str | Path):
        from fmpy import read_model_description
        self.fmu = Path(fmu).resolve()
        if not self.fmu.is_file():
            raise ValueError(f"FMU file {str(self.fmu)!r} does not exist (build it with "
                             f"`python -m rotary_vane.fmu_src.build --out DIR`)")
        description = read_model_description(str(self.fmu))
        self.guid = description.guid
        self.settings: dict[str, Setting] = {}
        for variable in description.modelVariables:
            if variable.causality in ("parameter", "input"):       # inputs are held at the point's value
                self.settings[variable.name] = Setting(
                    variable.name, variable.type, variable.unit or "", self._start(variable),
                    _number_or_none(variable.min), _number_or_none(variable.max),
                    description=variable.description or "")
        if SPEED_INPUT not in self.settings:
            raise ValueError(f"FMU {self.fmu.name} has no input '{SPEED_INPUT}': not the compressor FMU")
        experiment = description.defaultExperiment
        defaults = {"stop_time": experiment.stopTime if experiment else None,
                    "communication_step": experiment.stepSize if experiment else None}
        for name in RUN_SETTINGS:
            self.settings[name] = Setting(name, "Real", "s", float(defaults[name]) if defaults[name] else None,
                                          positive=True, description="run setting of the campaign")
        self.outputs = {v.name: v.type for v in description.modelVariables if v.causality == "output"}
        missing = [name for name in (*REVOLUTION_OUTPUTS, "shaft_work", "shaft_angle", "contact_mode_count")
                   if name not in self.outputs]
        if missing:
            raise ValueError(f"FMU {self.fmu.name} lacks the outputs {missing}")

    @staticmethod
    def _start(variable):
        if variable.start is None:
            return None
        return {"Real": float, "Integer": int, "String": str,
                "Boolean": lambda s: str(s).lower() in ("true", "1")}[variable.type](variable.start)

    def setting(self, name: str, where: str = "") -> Setting:
        """The setting called `name`; ValueError listing the closest names if there is none."""
        if name in self.settings:
            return self.settings[name]
        close = difflib.get_close_matches(name, self.settings, n=5, cutoff=0.6)
        hint = (f"did you mean {', '.join(close)}?" if close else
                f"allowed: {', '.join(sorted(self.settings))}")
        raise ValueError(f"{where}unknown parameter {name!r} for {self.fmu.name}: {hint} "
                         f"(`--list-parameters` lists them with units and ranges)")

    def resolve(self, given: dict, where: str = "") -> Point:
        """Validate the given values and complete them with the defaults into a Point."""
        values = {name: setting.default for name, setting in self.settings.items()}
        for name, value in given.items():
            values[name] = self.setting(name, where).convert(value, where)
        for name in RUN_SETTINGS:
            if values[name] is None:
                raise ValueError(f"{where}'{name}' is not set and the FMU has no default experiment value for it")
        return Point(point_id(values), values)

    def resolve_all(self, points: list[dict]) -> list[Point]:
        """Every point resolved, in order; ValueError for any bad point or for two equal points."""
        if not points:
            raise ValueError("the campaign has no points")
        resolved, first_index = [], {}
        for index, given in enumerate(points):
            point = self.resolve(given, where=f"point {index}: ")
            if point.point_id in first_index:
                raise ValueError(f"points {first_index[point.point_id]} and {index} are the same parameter set "
                                 f"({given})")
            first_index[point.point_id] = index
            resolved.append(point)
        return resolved

    def listing(self) -> str:
        """The settings with kind, unit, default and allowed values (for --list-parameters)."""
        rows = [f"{'name':28s} {'type':8s} {'default':>14s}  allowed"]
        for name, s in self.settings.items():
            rows.append(f"{name:28s} {s.kind:8s} {str(s.default):>14s}  {s.allowed_text()}  {s.description}")
        return "\n".join(rows)


def _number_or_none(text):
    return None if text is None else float(text)


def grid(axes: dict, fixed: dict | None = None) -> list[dict]:
    """The cartesian product of the axes, first axis slowest, each point merged with `fixed`.

    An axis is `name: values`, or `(name, name, ...): values` for names that take the same value together
    (e.g. `("slot_clearance", "stator_clearance"): [0, 5e-5]`).
    """
    fixed = dict(fixed or {})
    names = [(key,) if isinstance(key, str) else tuple(key) for key in axes]
    every = [name for group in names for name in group]
    repeated = sorted({n for n in every if every.count(n) > 1} | (set(every) & set(fixed)))
    if repeated:
        raise ValueError(f"parameters {repeated} are set twice (in two axes, or in an axis and fixed)")
    for group, values in zip(names, axes.values()):
        if len(values) == 0:
            raise ValueError(f"axis {'+'.join(group)} has no values")
    return [{**fixed, **{name: value for group, value in zip(names, combination) for name in group}}
            for combination in itertools.product(*axes.values())]


# the worker side -------------------------------------------------------------------------------------------
class FmuRunner:
    """One FMU instance in a worker process, reused for point after point with fmi2Reset."""

    def __init__(self, fmu: str, guid: str, scratch: str | None = None):
        """Unpack the FMU into a new folder under `scratch` (default: the temporary folder)."""
        from fmpy import extract, read_model_description
        if not os.path.isfile(fmu):
            raise FileNotFoundError(f"FMU {fmu!r} is not on worker {worker_name()}: the workers need the FMU at "
                                    f"the same path (a shared filesystem)")
        self.folder = tempfile.mkdtemp(prefix="rvc_campaign_", dir=scratch)
        extract(fmu, self.folder)
        self.description = read_model_description(self.folder)
        if self.description.guid != guid:
            raise RuntimeError(f"FMU {fmu!r} on worker {worker_name()} has GUID {self.description.guid}, the "
                               f"campaign's has {guid}: the file differs between the client and this worker")
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.instance = None
        self.messages: list[tuple[int, str]] = []

    def _log(self, environment, instance, status, category, message):
        self.messages.append((int(status), (message or b"").decode(errors="replace")))

    def _fresh_instance(self):
        from fmpy.simulation import instantiate_fmu
        self.instance = instantiate_fmu(self.folder, self.description, "CoSimulation", debug_logging=True,
                                        logger=self._log)

    def run(self, values: dict) -> dict:
        """Simulate one point; a row of RESULT_COLUMNS and RECORD_COLUMNS plus the status. Never raises."""
        from fmpy.fmi1 import FMICallException
        start, cpu_start = time.perf_counter(), time.thread_time()
        self.messages.clear()
        outcome, end_time = {}, 0.0
        try:
            if self.instance is None:
                self._fresh_instance()
            else:
                self.instance.reset()
            fmu = self.instance
            stop, step = values["stop_time"], values["communication_step"]
            fmu.setupExperiment(startTime=0.0, stopTime=stop)
            for name, value in values.items():
                if name not in RUN_SETTINGS:
                    self._set(name, value)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            steps = max(1, math.ceil(stop / step * (1.0 - 1e-12)))
            failure = None
            for k in range(steps):
                time_now = k * step
                size = (stop if k == steps - 1 else (k + 1) * step) - time_now
                try:
                    status = fmu.fmi2DoStep(fmu.component, time_now, size, 1)
                except FMICallException as error:
                    status = error.status
                if status not in (0, 1):
                    failure = f"fmi2DoStep at t = {time_now:g} s returned {STATUS_NAMES[status]}"
                    break
                end_time = time_now + size
            if failure is None:             # a failed point keeps only the time it reached
                outcome = self._summary(end_time)
        except Exception as error:          # noqa: BLE001 - a point's failure must not stop the campaign
            failure = f"{type(error).__name__}: {error}"
            self.close_instance()           # the instance may be dead (fmi2Fatal): the next point makes a new one
        notes = []                          # warnings and errors; a message repeating an earlier one is left out
        for text in [text for status, text in self.messages if status >= 1] + ([failure] if failure else []):
            if not any(earlier in text for earlier in notes):
                notes.append(text)
        return dict(outcome, status=FAILED if failure else DONE, end_time=end_time,
                    error=" | ".join(notes)[:MAX_ERROR_LENGTH],
                    wall_time=time.perf_counter() - start, cpu_time=time.thread_time() - cpu_start,
                    worker=worker_name(), fmu_guid=self.description.guid,
                    finished_at=datetime.now(timezone.utc).isoformat(timespec="seconds"))

    def _set(self, name: str, value) -> None:
        variable = self.variables[name]
        reference = [variable.valueReference]
        setter = {"Real": self.instance.setReal, "Integer": self.instance.setInteger,
                  "Boolean": self.instance.setBoolean, "String": self.instance.setString}[variable.type]
        setter(reference, [value])

    def _summary(self, end_time: float) -> dict:
        names = [*REVOLUTION_OUTPUTS, "shaft_work", "shaft_angle"]
        reals = self.instance.getReal([self.variables[n].valueReference for n in names])
        out = dict(zip(names, (float(v) for v in reals)))
        out["contact_mode_count"] = int(self.instance.getInteger(
            [self.variables["contact_mode_count"].valueReference])[0])
        if out["input_power"] == 0.0:       # no completed revolution: the FMU reports 0, not a figure
            out.update(dict.fromkeys(REVOLUTION_OUTPUTS))
        out["run_mean_shaft_torque"] = out["shaft_work"] / out["shaft_angle"] if out["shaft_angle"] > 0 else None
        out["run_mean_input_power"] = out["shaft_work"] / end_time if end_time > 0 else None
        return out

    def close_instance(self) -> None:
        if self.instance is not None:
            try:
                self.instance.terminate()
                self.instance.freeInstance()
            except Exception:               # noqa: BLE001 - a dead instance cannot be freed cleanly
                pass
            self.instance = None

    def close(self) -> None:
        self.close_instance()
        shutil.rmtree(self.folder, ignore_errors=True)


def worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _worker_plugin_class():
    """The dask WorkerPlugin that owns each worker's FmuRunners (made on demand: dask is imported lazily)."""
    from distributed import WorkerPlugin

    class FmuInstances(WorkerPlugin):
        """One FmuRunner per (FMU path, GUID) in each worker; freed when the worker or the plugin goes."""
        name = PLUGIN_NAME

        def setup(self, worker):
            self.runners = {}
            self.scratch = worker.local_directory    # dask purges it when a killed worker left it behind

        def runner(self, fmu: str, guid: str) -> FmuRunner:
            if (fmu, guid) not in self.runners:
                self.runners[(fmu, guid)] = FmuRunner(fmu, guid, self.scratch)
            return self.runners[(fmu, guid)]

        def teardown(self, worker):
            for runner in self.runners.values():
                runner.close()
            self.runners.clear()

    return FmuInstances


def run_point(fmu: str, guid: str, values: dict) -> dict:
    """The dask task: simulate one point with this worker's FmuRunner for the FMU."""
    from distributed import get_worker
    try:
        runner = get_worker().plugins[PLUGIN_NAME].runner(fmu, guid)
    except Exception as error:              # noqa: BLE001 - e.g. the FMU is not on this worker's filesystem
        return dict(status=FAILED, error=f"{type(error).__name__}: {error}", worker=worker_name(), fmu_guid=guid,
                    finished_at=datetime.now(timezone.utc).isoformat(timespec="seconds"))
    return runner.run(values)


# the store -------------------------------------------------------------------------------------------------
def store_columns(parameter_names: list[str]) -> list[str]:
    return ["point_id", "status", *parameter_names, *RESULT_COLUMNS, *RECORD_COLUMNS]


def parameter_columns(columns: list[str]) -> list[str]:
    """The parameter names of a store's header (between status and the results)."""
    return [name for name in columns if name not in ("point_id", "status", *RESULT_COLUMNS, *RECORD_COLUMNS)]


def cell(value) -> str:
    """CSV text of a value: repr for floats (exact round trip), empty for None, line breaks as ' | ' (one line
    per row: a kill during a write leaves at most a partial last line)."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value).replace("\r\n", "\n").replace("\r", "\n").replace("\n", " | ")


def read_store(path: str | Path) -> list[dict]:
    """The rows of a store as dicts of strings (empty cells are ''), in file order; [] if there is none."""
    path = Path(path)
    if not path.is_file() or path.stat().st_size == 0:
        return []
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


class ResultStore:
    """The CSV store of a campaign: one line per point, appended and fsynced as each point finishes.

    Open it with a context manager: it takes an exclusive lock (`<store>.lock`), drops a partial last line that
    a kill during a write may have left, and writes the header if the file is new (or checks it otherwise).
    """

    def __init__(self, path: str | Path, columns: list[str]):
        self.path = Path(path)
        self.columns = columns
        self.handle = None
        self.lock = None

    def __enter__(self) -> "ResultStore":
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.lock = open(f"{self.path}.lock", "w")
        try:
            fcntl.flock(self.lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self.lock.close()
            raise RuntimeError(f"store {str(self.path)!r} is in use by another campaign") from None
        self._drop_partial_line()
        existing = read_store(self.path)
        if self.path.is_file() and self.path.stat().st_size > 0:
            with self.path.open(newline="", encoding="utf-8") as handle:
                header = next(csv.reader(handle))
            if header != self.columns:
                self.lock.close()
                raise ValueError(f"store {str(self.path)!r} holds a campaign over the parameters "
                                 f"{parameter_columns(header)}, this one is over {parameter_columns(self.columns)}: "
                                 f"use another store")
        self.rows = existing
        self.handle = self.path.open("a", newline="", encoding="utf-8")
        if not existing and self.path.stat().st_size == 0:
            self._write(self.columns)
            _fsync_folder(self.path.parent)
        return self

    def __exit__(self, *exc) -> None:
        self.handle.close()
        self.lock.close()

    def _drop_partial_line(self) -> None:
        if not self.path.is_file():
            return
        data = self.path.read_bytes()
        if data and not data.endswith(b"\n"):
            with self.path.open("r+b") as handle:
                handle.truncate(data.rfind(b"\n") + 1)

    def _write(self, cells: list[str]) -> None:
        line = io.StringIO()
        csv.writer(line, lineterminator="\n").writerow(cells)
        self.handle.write(line.getvalue())
        self.handle.flush()
        os.fsync(self.handle.fileno())

    def append(self, row: dict) -> None:
        self._write([cell(row.get(name)) for name in self.columns])
        self.rows.append({name: cell(row.get(name)) for name in self.columns})

    def drop(self, point_ids: set[str]) -> None:
        """Rewrite the store without the rows of `point_ids` (a temporary file, then an atomic replace)."""
        keep = [row for row in self.rows if row["point_id"] not in point_ids]
        if len(keep) == len(self.rows):
            return
        temporary = self.path.with_name(self.path.name + ".tmp")
        with temporary.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(self.columns)
            writer.writerows([row[name] for name in self.columns] for row in keep)
            handle.flush()
            os.fsync(handle.fileno())
        self.handle.close()
        os.replace(temporary, self.path)
        _fsync_folder(self.path.parent)
        self.handle = self.path.open("a", newline="", encoding="utf-8")
        self.rows = keep


def _fsync_folder(folder: Path) -> None:
    descriptor = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


# the campaign ----------------------------------------------------------------------------------------------
@dataclass
class CampaignReport:
    """What a call of run_campaign did."""
    store: Path
    total: int                 # points in the campaign
    skipped: int               # already in the store
    done: int                  # run now and done
    failed: int                # run now and failed
    stored_failed: int         # points of the campaign stored as failed at the end (now or before)
    wall_time: float           # s, from opening the store to the cluster's shutdown
    failures: list             # (point_id, error) of the points that failed now


class Progress:
    """A counter on stderr: tqdm if installed, else a line per point (or one rewritten line on a terminal)."""

    def __init__(self, total: int, enabled: bool = True):
        self.total, self.count, self.failed, self.enabled = total, 0, 0, enabled
        self.start = time.perf_counter()
        self.bar = None
        if enabled:
            try:
                from tqdm import tqdm
                self.bar = tqdm(total=total, unit="point", file=sys.stderr)
            except ImportError:
                pass

    def update(self, row: dict) -> None:
        self.count += 1
        self.failed += row["status"] == FAILED
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix(failed=self.failed)
            return
        elapsed = time.perf_counter() - self.start
        text = (f"[{self.count}/{self.total}] {row['point_id']} {row['status']} "
                f"({row.get('wall_time') or 0.0:.2f} s)  failed {self.failed}  elapsed {elapsed:.0f} s")
        if sys.stderr.isatty():
            print("\r" + text, end="\n" if self.count == self.total else "", file=sys.stderr, flush=True)
        else:
            print(text, file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_campaign(fmu: str | Path, points: list[dict], store: str | Path, *, workers: int | None = None,
                 scheduler: str | None = None, retry_failed: bool = False, progress: bool = True) -> CampaignReport:
    """Run every point of `points` not yet in `store` through the FMU on dask; return what was done.

    `points`: dicts of setting name -> value (see `grid`); `workers`: processes of the local cluster (default:
    the CPU count, at most the number of points to run); `scheduler`: the address of an existing dask scheduler
    instead. Every point is validated before the cluster starts (ValueError).
    """
    space = ParameterSpace(fmu)
    resolved = space.resolve_all(points)
    given_names = sorted({name for point in points for name in point} - {SPEED_INPUT, *RUN_SETTINGS})
    columns = store_columns([SPEED_INPUT, *RUN_SETTINGS, *given_names])
    if workers is not None and workers < 1:
        raise ValueError(f"workers = {workers} is invalid: allowed an integer >= 1")
    start = time.perf_counter()
    with ResultStore(store, columns) as results:
        stored = {row["point_id"]: row for row in results.rows}
        ours = {point.point_id for point in resolved}
        if retry_failed:
            results.drop({pid for pid, row in stored.items() if pid in ours and row["status"] == FAILED})
            stored = {row["point_id"]: row for row in results.rows}
        other_builds = {row["fmu_guid"] for pid, row in stored.items() if pid in ours} - {space.guid}
        pending = [point for point in resolved if point.point_id not in stored]
        print(f"{len(resolved)} points: {len(resolved) - len(pending)} already in {results.path}, "
              f"{len(pending)} to run", file=sys.stderr, flush=True)
        if other_builds:
            print(f"note: stored points of this campaign came from other builds of the FMU (GUID "
                  f"{', '.join(sorted(other_builds))}); they are kept; use a new store to recompute them",
                  file=sys.stderr)
        report = CampaignReport(results.path, len(resolved), len(resolved) - len(pending), 0, 0, 0, 0.0, [])
        if pending:
            _run_pending(space, pending, results, report, workers, scheduler, progress)
        report.stored_failed = sum(row["status"] == FAILED for row in results.rows if row["point_id"] in ours)
    report.wall_time = time.perf_counter() - start
    return report


def _run_pending(space, pending, results, report, workers, scheduler, progress) -> None:
    import cloudpickle
    from distributed import Client, LocalCluster, as_completed
    # The scheduler and the workers need not have this module: the task is a local function, which dask can only
    # send with cloudpickle, and cloudpickle sends this module's functions and classes by value once registered.
    if __name__ != "__main__":
        cloudpickle.register_pickle_by_value(sys.modules[__name__])
    fmu_path, guid = str(space.fmu), space.guid

    def simulate(values: dict) -> dict:
        return run_point(fmu_path, guid, values)

    if scheduler:
        cluster = None
        client = Client(scheduler)
    else:
        count = min(workers or os.cpu_count() or 1, len(pending))
        cluster = LocalCluster(n_workers=count, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    counter = Progress(len(pending), progress)
    futures = []
    try:
        client.register_plugin(_worker_plugin_class()(), name=PLUGIN_NAME)
        by_key = {}
        for point in pending:
            future = client.submit(simulate, point.values, key=f"rvc-point-{point.point_id}", pure=False)
            by_key[future.key] = point
            futures.append(future)
        for future in as_completed(futures):
            point = by_key[future.key]
            try:
                row = future.result()
            except Exception as error:      # noqa: BLE001 - e.g. the worker process died (KilledWorker)
                row = dict(status=FAILED, error=f"{type(error).__name__}: {error}", fmu_guid=space.guid)
            row.update(point.values, point_id=point.point_id)
            results.append(row)
            counter.update(row)
            if row["status"] == DONE:
                report.done += 1
            else:
                report.failed += 1
                report.failures.append((point.point_id, row.get("error", "")))
        if scheduler:
            client.unregister_worker_plugin(PLUGIN_NAME)     # frees the FMU instances on the shared workers
    finally:
        counter.close()
        for future in futures:
            future.cancel()
        client.close()
        if cluster is not None:
            cluster.close()


# command line ----------------------------------------------------------------------------------------------
def assignment(text: str) -> tuple[list[str], str]:
    """'a+b=1,2' -> (['a', 'b'], '1,2')."""
    names, separator, values = text.partition("=")
    if not separator or not names.strip() or not values.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=VALUE (or NAME[+NAME...]=V1,V2,... for --grid)")
    return [name.strip() for name in names.split("+")], values.strip()


def read_points(path: Path) -> list[dict]:
    """Points from a JSON file (a list of objects) or a CSV file (a header of names, a row per point)."""
    if path.suffix.lower() == ".json":
        points = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(points, list) or not all(isinstance(p, dict) for p in points):
            raise ValueError(f"{path}: expected a JSON list of objects (one per point)")
        return points
    if path.suffix.lower() == ".csv":
        with path.open(newline="", encoding="utf-8") as handle:
            return [{k: v for k, v in row.items() if v != ""} for row in csv.DictReader(handle)]
    raise ValueError(f"{path}: give a .json or a .csv file of points")


def campaign_points(grid_axes: list, fixed: list, points_file: Path | None) -> list[dict]:
    """The points of the command line: --points rows or the --grid product, each with the --set values."""
    settings = {}
    for names, value in fixed:
        for name in names:
            if name in settings:
                raise ValueError(f"--set {name} is given twice")
            settings[name] = value
    if points_file is not None:
        if grid_axes:
            raise ValueError("give either --grid or --points, not both")
        points = read_points(points_file)
        clashes = sorted({name for point in points for name in point} & set(settings))
        if clashes:
            raise ValueError(f"{clashes} are set both by --set and in {points_file}")
        return [{**settings, **point} for point in points]
    axes = {tuple(names): values.split(",") for names, values in grid_axes}
    return grid(axes, settings) if axes else [settings]


def parse_arguments(argv=None):
    parser = argparse.ArgumentParser(
        description="Run a parameter campaign (a grid or a list of points) through the compressor FMU on dask, "
                    "appending one CSV row per point as it finishes; a rerun skips the points already stored.",
    )
    parser.add_argument("--fmu", type=Path, default=DEFAULT_FMU,
                        help=f"the RotaryVaneCompressor.fmu to run (default: {DEFAULT_FMU})")
    parser.add_argument("--store", type=Path, help="CSV store of the results (created, or resumed)")
    parser.add_argument("--grid", type=assignment, action="append", default=[], metavar="NAME[+NAME]=V1,V2,...",
                        help="an axis of the grid (repeatable; names joined by + take the same values together); "
                             "FMU units: SI, shaft_speed in rpm")
    parser.add_argument("--points", type=Path, help="a .json list of objects or a .csv with a header of names: "
                                                    "one point each (instead of --grid)")
    parser.add_argument("--set", dest="fixed", type=assignment, action="append", default=[], metavar="NAME=VALUE",
                        help="a value for every point (repeatable), e.g. stop_time=0.5, communication_step=1e-3, "
                             "lobes=5 (defaults: the FMU's start values and default experiment)")
    parser.add_argument("--workers", type=int, help="worker processes of the local cluster (default: CPU count)")
    parser.add_argument("--scheduler", help="address of an existing dask scheduler, e.g. tcp://10.0.0.5:8786, "
                                            "instead of a local cluster")
    parser.add_argument("--retry-failed", action="store_true",
                        help="run the points stored as failed again (their rows are replaced)")
    parser.add_argument("--no-progress", action="store_true", help="no progress output")
    parser.add_argument("--list-parameters", action="store_true",
                        help="list what a point may set (from the FMU's modelDescription) and exit")
    return parser, parser.parse_args(argv)


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv=None) -> int:
    parser, args = parse_arguments(argv)
    try:
        if args.list_parameters:
            print(ParameterSpace(args.fmu).listing())
            return 0
        if args.store is None:
            parser.error("--store is required")
        points = campaign_points(args.grid, args.fixed, args.points)
        signal.signal(signal.SIGTERM, _raise_interrupt)      # a kill closes the cluster like Ctrl-C does
        report = run_campaign(args.fmu, points, args.store, workers=args.workers, scheduler=args.scheduler,
                              retry_failed=args.retry_failed, progress=not args.no_progress)
    except (ValueError, RuntimeError) as error:
        parser.error(str(error))
    except KeyboardInterrupt:
        print(f"\ninterrupted: the points finished so far are in {args.store}; run the same command again to go "
              f"on", file=sys.stderr)
        return 130
    print(f"{report.total} points: {report.skipped} were stored already, {report.done} done and {report.failed} "
          f"failed now, {report.wall_time:.1f} s; store: {report.store}")
    for point, error in report.failures[:10]:
        print(f"  failed {point}: {error}")
    if report.stored_failed:
        print(f"points of this campaign stored as failed: {report.stored_failed} (--retry-failed runs them again)")
    return 1 if report.stored_failed else 0


if __name__ == "__main__":
    sys.exit(main())
