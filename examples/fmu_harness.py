"""Shared plumbing of the fmpy harnesses (standalone.py, startup.py, motor_coupling.py).

The harnesses use the built `.fmu` files through fmpy exactly as a user would; this module holds what all three
need and nothing of the physics:

* `ensure_fmus`: build the FMUs with `python -m rotary_vane.fmu_src.build --out DIR` when they are missing or stale. Stale
  means built from other sources: every FMU carries the project's code under a private package name
  `rotary_vane_<version>_<source hash>_<model>` (fmu_src/build.py, `private_package_name`), read here from the names in
  the .fmu archive and compared with the name the current sources give.
* `FmuLog`: the fmpy logger callback (debug logging is always on); prints every message that is not OK as it
  arrives and keeps the messages for error reports.
* `simulate`: fmpy.simulate_fmu with the communication step passed as `output_interval`, start values checked
  against the modelDescription (name, type, min/max) before the run, and the result checked: a run that did not
  reach the stop time (fmpy stops quietly when a step is discarded) or an FMU that logged an error is a
  `HarnessError`, never a short result.
* `run_main`: runs a harness's main and turns a `HarnessError` or `InputError` into a message and exit status 1.
* small pieces every script needs: command-line number parsers with units, the output folder, a progress bar.
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
import zipfile
from pathlib import Path

PROJECT_DIR = Path(__file__).resolve().parent.parent
DEFAULT_FMU_DIR = PROJECT_DIR / "build" / "fmu"
DEFAULT_OUT_ROOT = PROJECT_DIR / "out"
COMPRESSOR = "RotaryVaneCompressor"
MOTOR = "DriveMotor"
LOOP = "RefrigerationLoop"
SYSTEM_FILES = ("OspSystemStructure.xml", "OspSystemStructure_ecco.xml", "SystemStructure.ssd",
                "OspSystemStructure_refrigeration.xml", "RefrigerationSystem.ssd")
RPM = 2.0 * math.pi / 60.0                      # rad/s per rpm
STATUS_NAMES = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")
ERROR = 3


class HarnessError(RuntimeError):
    """A run that cannot be trusted (stopped early, refused, an FMU error): the harness exits with status 1."""


class InputError(ValueError):
    """Bad input (an option or start value): names the variable, its value and the allowed range."""


# FMUs: build if missing or stale ------------------------------------------------------------------------------
def bundled_package(fmu: Path) -> str | None:
    """The private package name the FMU bundles (resources/rotary_vane_<version>_<hash>_<model>/), or None."""
    with zipfile.ZipFile(fmu) as archive:
        names = {name.split("/")[1] for name in archive.namelist()
                 if name.startswith("resources/rotary_vane_") and name.count("/") >= 2}
    return names.pop() if len(names) == 1 else None


def stale_reason(fmu_dir: Path) -> str | None:
    """Why the FMUs in `fmu_dir` must be (re)built, or None if they were built from the current sources."""
    from rotary_vane.fmu_src.build import private_package_name
    for name in (COMPRESSOR, MOTOR, LOOP):
        path = fmu_dir / f"{name}.fmu"
        current = private_package_name(name)
        if not path.is_file():
            return f"{path} is missing"
        try:
            bundled = bundled_package(path)
        except zipfile.BadZipFile:
            return f"{path} is not a valid FMU archive"
        if bundled != current:
            return f"{path} was built from other sources (it bundles {bundled}, the sources give {current})"
    missing = [name for name in SYSTEM_FILES if not (fmu_dir / name).is_file()]
    if missing:
        return f"system files {', '.join(missing)} are missing in {fmu_dir}"
    return None


def ensure_fmus(fmu_dir: Path) -> Path:
    """Build the FMUs into `fmu_dir` if they are missing or stale; return the folder."""
    fmu_dir = Path(fmu_dir).resolve()
    reason = stale_reason(fmu_dir)
    if reason is None:
        print(f"FMUs in {fmu_dir} are up to date with the sources")
        return fmu_dir
    print(f"building the FMUs ({reason}): python -m rotary_vane.fmu_src.build --out {fmu_dir}", flush=True)
    done = subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", str(fmu_dir)], cwd=PROJECT_DIR,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise HarnessError(f"the FMU build failed (exit status {done.returncode}):\n{done.stdout}{done.stderr}")
    reason = stale_reason(fmu_dir)
    if reason is not None:
        raise HarnessError(f"after the build: {reason}")
    return fmu_dir


# logging ----------------------------------------------------------------------------------------------------
class FmuLog:
    """fmpy logger callback: prints each message whose status is not OK (all of them with `verbose`) to stderr
    and keeps every message as (status, instance, category, text)."""

    def __init__(self, verbose: bool = False):
        self.verbose = verbose
        self.messages: list[tuple[int, str, str, str]] = []

    def __call__(self, environment, instance, status, category, message):
        entry = (int(status), (instance or b"").decode(errors="replace"),
                 (category or b"").decode(errors="replace"), (message or b"").decode(errors="replace"))
        self.messages.append(entry)
        if entry[0] != 0 or self.verbose:
            print(f"[FMU {entry[1]}] {self.status_name(entry[0])} {entry[2]}: {entry[3]}", file=sys.stderr,
                  flush=True)

    @staticmethod
    def status_name(status: int) -> str:
        return STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else f"status {status}"

    def mark(self) -> int:
        """Position in the message list (to look at the messages of one run only)."""
        return len(self.messages)

    def errors(self, since: int = 0) -> list[str]:
        return [f"{m[1]}: {m[3]}" for m in self.messages[since:] if m[0] >= ERROR]

    def last(self, count: int = 5, since: int = 0) -> str:
        """The last `count` messages that are not OK, one per line (or a note that there were none)."""
        lines = [f"  {self.status_name(m[0])} {m[1]}: {m[3]}" for m in self.messages[since:] if m[0] != 0]
        return "\n".join(lines[-count:]) if lines else "  (the FMU logged no warning or error)"


# start values -----------------------------------------------------------------------------------------------
def model_variables(model_description) -> dict:
    return {variable.name: variable for variable in model_description.modelVariables}


def has_variables(fmu: Path, *names: str) -> bool:
    """True if the FMU's modelDescription declares every one of `names`."""
    from fmpy import read_model_description
    variables = model_variables(read_model_description(str(fmu)))
    return all(name in variables for name in names)


def check_start_values(model_description, values: dict) -> None:
    """InputError naming the variable, its value and the allowed range, for a start value the FMU does not
    declare, cannot take, or declares out of [min, max]. The FMU checks more at initialization."""
    variables = model_variables(model_description)
    model = model_description.modelName
    for name, value in values.items():
        variable = variables.get(name)
        if variable is None:
            raise InputError(f"{model} has no variable '{name}' (given {value!r})")
        if variable.causality not in ("parameter", "input"):
            raise InputError(f"{model} variable '{name}' is an {variable.causality}, not a parameter or input")
        if variable.type in ("Real", "Integer"):
            unit = f" {variable.unit}" if variable.unit and variable.unit != "1" else ""
            low = float(variable.min) if variable.min is not None else -math.inf
            high = float(variable.max) if variable.max is not None else math.inf
            if not (isinstance(value, (int, float)) and math.isfinite(value) and low <= value <= high):
                raise InputError(f"{model} {variable.causality} '{name}' = {value!r}{unit} is out of range: "
                                 f"allowed [{low:g}, {high:g}]{unit}")
            if variable.type == "Integer" and value != int(value):
                raise InputError(f"{model} parameter '{name}' = {value!r} is invalid: allowed an integer")


# simulation -------------------------------------------------------------------------------------------------
def simulate(fmu: Path, *, stop_time: float, step: float, start_values: dict, log: FmuLog, input=None,
             progress=None):
    """fmpy.simulate_fmu from t = 0 with communication step `step` (output_interval) and debug logging on.

    Returns fmpy's structured result array. Raises HarnessError if the run did not reach `stop_time` or the
    FMU logged an error, with the FMU's messages."""
    from fmpy import read_model_description, simulate_fmu
    from fmpy.fmi1 import FMICallException
    model_description = read_model_description(str(fmu))
    check_start_values(model_description, start_values)
    since = log.mark()
    try:
        result = simulate_fmu(str(fmu), start_time=0.0, stop_time=stop_time, output_interval=step,
                              start_values=start_values, input=input, debug_logging=True, logger=log,
                              step_finished=progress, validate=True)
    except FMICallException as error:       # fmi2Error, e.g. parameters that conflict with each other
        raise HarnessError(f"{fmu.name}: {error}. The FMU said:\n{log.last(since=since)}") from None
    reached = float(result["time"][-1])
    if not math.isclose(reached, stop_time, rel_tol=1e-9, abs_tol=1e-6 * step):
        raise HarnessError(f"{fmu.name} stopped at t = {reached:g} s, before the stop time {stop_time:g} s "
                           f"(a refused step). The FMU said:\n{log.last(since=since)}")
    if log.errors(since):
        raise HarnessError(f"{fmu.name} reported errors although it reached the stop time:\n"
                           + "\n".join(log.errors(since)))
    return result


class ProgressBar:
    """fmpy `step_finished` callback drawing a text progress bar on stderr (redrawn in place on a terminal,
    a line every 10 % otherwise). tqdm is not a dependency of the project, so this is a few lines of our own."""

    WIDTH = 40

    def __init__(self, stop_time: float, label: str):
        self.stop_time, self.label = stop_time, label
        self.interactive = sys.stderr.isatty()
        self.shown = -1
        self.start = time.perf_counter()

    def __call__(self, simulation_time, recorder) -> bool:
        fraction = min(1.0, simulation_time / self.stop_time)
        percent = int(100 * fraction)
        if percent != self.shown and (self.interactive or percent % 10 == 0):
            self.shown = percent
            bar = "#" * int(self.WIDTH * fraction)
            text = (f"{self.label} [{bar:<{self.WIDTH}}] {percent:3d} %  t = {simulation_time:.3f} s  "
                    f"wall {time.perf_counter() - self.start:.1f} s")
            print("\r" + text if self.interactive else text, end="" if self.interactive else "\n",
                  file=sys.stderr, flush=True)
            if self.interactive and percent == 100:
                print(file=sys.stderr)
        return True                                      # go on


# command line -----------------------------------------------------------------------------------------------
class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """--help with each option's default, except where the default is None (the help text says what then)."""

    def _get_help_string(self, action):
        return action.help if action.default is None else super()._get_help_string(action)


def add_common_options(parser: argparse.ArgumentParser, script: str) -> None:
    """--fmu-dir, --out and --verbose, the same for every harness."""
    parser.add_argument("--fmu-dir", type=Path, default=DEFAULT_FMU_DIR,
                        help="folder of RotaryVaneCompressor.fmu, DriveMotor.fmu and RefrigerationLoop.fmu; they "
                             "are built there (python -m rotary_vane.fmu_src.build --out DIR) if missing or stale, "
                             "i.e. if the private package name rotary_vane_<version>_<source hash>_<model> bundled in "
                             "an FMU differs from the one of the current sources")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT_ROOT / script,
                        help="folder for the CSV, PNG and summary files")
    parser.add_argument("--verbose", action="store_true",
                        help="print every FMU log message (by default only warnings and errors)")


def output_folder(path: Path) -> Path:
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    return path


def run_main(main, argv=None) -> int:
    """Run a harness's main(argv); a HarnessError or InputError becomes 'error: ...' on stderr and status 1."""
    try:
        return main(argv)
    except (HarnessError, InputError) as error:
        print(f"error: {error}", file=sys.stderr, flush=True)
        return 1
