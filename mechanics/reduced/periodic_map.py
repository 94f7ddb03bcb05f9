"""Periodic-map tables of the detailed model: per rotor angle and speed, what one steady revolution looks like.

`build_map(params, speeds)` runs `Simulation` at constant speed to periodic steady state at each speed of a grid
(in parallel: on a dask cluster when a client is given, else in worker processes), samples every revolution on a
uniform grid of rotor angles, averages the revolutions and keeps their scatter, and returns a `MapTable` that
interpolates in (angle, speed). Tables are cached on disk (npz arrays + json metadata, never pickle) under a key
that hashes every parameter that affects them and the project's sources: a changed parameter or source file
gives a new table, never an old one.

Torque samples are cell means of the shaft work, T_k = (W(theta_{k+1}) - W(theta_k)) / dtheta, placed at the cell
mid-angles theta_k + dtheta/2; the periodic piecewise-linear interpolant through them has, over a whole revolution,
the integral dtheta sum_k T_k = W(2 pi) - W(0): the table's shaft work per revolution is the detailed model's
(docs/model.md §6.4). Every other channel is the value sampled at the node angle.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from contextlib import ExitStack
from pathlib import Path

import numpy as np

from ...kernels.compile_cache import cache_root, source_hash

from ..loop.outputs import REVOLUTION, STEP, fmu_outputs
from ..parameters import CompressorParameters
from ..performance import revolutions
from ..simulation import Simulation
from ..loop.speed import RPM, constant_speed

FORMAT_VERSION = 1
PROJECT_DIR = Path(__file__).resolve().parents[2]
TORQUE = "driving_torque"
# channels sampled per angle: the output columns behind the FMU's end-of-step outputs (mechanics.loop.outputs)
CHANNELS = tuple(output.source for output in fmu_outputs() if output.per == STEP)
# per-revolution figures: those behind the FMU's per-revolution outputs (real-gas ones are NaN under the tables)
FIGURES = tuple(output.source for output in fmu_outputs() if output.per == REVOLUTION)


@dataclasses.dataclass(frozen=True)
class MapSettings:
    """How a table is built; every field enters the cache key.

    samples: angle samples per revolution (>= 720); warmup_revolutions: revolutions run and discarded to reach
    periodic steady state; averaged_revolutions: revolutions sampled and averaged (their scatter is kept);
    table_speed_rpm: operating speed of the Level 0.5 pressure table (the operating speed of the grid).
    """
    table_speed_rpm: float
    samples: int = 720
    warmup_revolutions: int = 3
    averaged_revolutions: int = 4

    def __post_init__(self):
        checks = (("samples", self.samples, 720), ("warmup_revolutions", self.warmup_revolutions, 1),
                  ("averaged_revolutions", self.averaged_revolutions, 1))
        for name, value, low in checks:
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"'{name}' = {value!r} is invalid: allowed an integer >= {low}")
        if not (isinstance(self.table_speed_rpm, (int, float)) and math.isfinite(self.table_speed_rpm)
                and self.table_speed_rpm > 0.0):
            raise ValueError(f"'table_speed_rpm' = {self.table_speed_rpm!r} rpm is invalid: allowed a finite "
                             f"speed > 0 rpm")


# speed grid --------------------------------------------------------------------------------------------------
def initial_speed_grid(operating_rpm: float, count: int = 8) -> np.ndarray:
    """`count` uniform speeds from 10 % to 120 % of the operating speed [rpm]."""
    return np.linspace(0.1, 1.2, count) * operating_rpm


def chord_deviation(speeds: np.ndarray, values, scale) -> np.ndarray:
    """Per interior speed node i: the RMS over the angle (or the single figure) of v_i minus the chord of its
    neighbours, v_i - (w v_{i-1} + (1 - w) v_{i+1}), w = (s_{i+1} - s_i)/(s_{i+1} - s_{i-1}), divided by `scale`:
    what linear interpolation in speed would miss there."""
    values = np.asarray(values, dtype=float).reshape(len(speeds), -1)
    weight = ((speeds[2:] - speeds[1:-1]) / (speeds[2:] - speeds[:-2]))[:, None]
    chord = weight * values[:-2] + (1.0 - weight) * values[2:]
    return np.sqrt(np.mean((values[1:-1] - chord) ** 2, axis=1)) / scale


def curvature_refinement(speeds: np.ndarray, deviation: np.ndarray, room: int, tolerance: float) -> np.ndarray:
    """Midpoints to add where the values curve: the intervals on both sides of the interior nodes whose
    `chord_deviation` exceeds `tolerance`, worst first, at most `room` new speeds."""
    new: list[float] = []
    for node in np.argsort(deviation)[::-1] + 1:
        if deviation[node - 1] < tolerance:
            break
        for left in (node - 1, node):
            middle = 0.5 * (speeds[left] + speeds[left + 1])
            if len(new) < room and not any(math.isclose(middle, m) for m in new):
                new.append(middle)
    return np.array(sorted(new))


def refinement_speeds(table: "MapTable", room: int) -> np.ndarray:
    """Midpoints where the per-revolution input power or mass flow curves by more than 0.2 % of its largest value,
    or the torque waveform by more than 3 % of its ripple RMS (the accuracy the tables aim at)."""
    speeds = table.speeds
    torque = table.channels[TORQUE]
    deviations = [(chord_deviation(speeds, torque, np.std(torque[1:-1], axis=1)), 0.03)]
    for name in ("input_power", "discharge_mass_flow"):
        values = table.figures[name]
        if np.all(np.isfinite(values)):
            deviations.append((chord_deviation(speeds, values, np.max(np.abs(values))), 2e-3))
    deviation = np.max([d / tolerance for d, tolerance in deviations], axis=0)
    return curvature_refinement(speeds, deviation, room, 1.0)


# one speed point ---------------------------------------------------------------------------------------------
def run_speed_point(params: CompressorParameters, speed_rpm: float, settings: MapSettings,
                    boundary: dict | None = None, rates: dict | None = None) -> dict:
    """Run the detailed model at constant `speed_rpm` from theta = 0: warm-up revolutions, then sampled ones.

    boundary: the Simulation.set_boundary values to hold (default: the parameters' operating point). rates: more
    cell-mean channels, name -> ((history column, sign), ...), the per-angle rate of that signed sum of cumulative
    columns (the torque is the rate of work_in). Returns arrays per channel: mean over the sampled revolutions
    [samples] and the rev-to-rev RMS scatter sqrt(mean_r mean_k (x_rk - mean_k)^2) (a scalar), the per-revolution
    figures (mean and scatter), the run time.
    """
    started = time.perf_counter()
    simulation = Simulation(params, constant_speed(speed_rpm), initial_angle=0.0, keep_history=True,
                            table_speed_rpm=settings.table_speed_rpm)
    if boundary is not None:
        simulation.set_boundary(**boundary)
    period = 2.0 * math.pi / (speed_rpm * RPM)
    total = settings.warmup_revolutions + settings.averaged_revolutions
    simulation.advance(total * period * (1.0 + 1e-9))
    history = simulation.history
    angle = history["rotor_angle"]
    step = 2.0 * math.pi / settings.samples
    start = settings.warmup_revolutions * 2.0 * math.pi
    cumulative = {TORQUE: history["work_in"]}
    for name, terms in (rates or {}).items():
        cumulative[name] = sum(sign * history[column] for column, sign in terms)
    waveforms = {}
    for name in (*CHANNELS, *(rates or {})):
        per_revolution = []
        for r in range(settings.averaged_revolutions):
            base = start + r * 2.0 * math.pi
            if name in cumulative:              # cell means of a cumulative quantity
                edges = base + step * np.arange(settings.samples + 1)
                per_revolution.append(np.diff(np.interp(edges, angle, cumulative[name])) / step)
            else:
                per_revolution.append(np.interp(base + step * np.arange(settings.samples), angle, history[name]))
        waveforms[name] = np.array(per_revolution)
    summaries = revolutions(simulation)[-settings.averaged_revolutions:]     # the run starts on a boundary
    if len(summaries) != settings.averaged_revolutions:
        raise RuntimeError(f"{len(summaries)} complete revolutions recorded at {speed_rpm} rpm, expected "
                           f"{settings.averaged_revolutions}")
    figures = {name: [getattr(summary, name) for summary in summaries] for name in FIGURES}
    return dict(speed_rpm=float(speed_rpm), boundary=boundary,
                mean={n: w.mean(axis=0) for n, w in waveforms.items()},
                scatter={n: float(np.sqrt(np.mean((w - w.mean(axis=0)) ** 2))) for n, w in waveforms.items()},
                figures={n: float(np.mean(v)) for n, v in figures.items()},
                figure_scatter={n: float(np.std(v)) for n, v in figures.items()},
                seconds=time.perf_counter() - started)


def periodic_cumulative(rates: np.ndarray, step: float) -> np.ndarray:
    """Integrals from the first node of the periodic linear interpolant through `rates` (..., samples), at each node
    and one period on: shape (..., samples + 1)."""
    trapezoids = 0.5 * step * (rates + np.roll(rates, -1, axis=-1))
    return np.concatenate([np.zeros((*rates.shape[:-1], 1)), np.cumsum(trapezoids, axis=-1)], axis=-1)


def periodic_antiderivative(rates: np.ndarray, cumulative: np.ndarray, step: float, angle: float) -> float:
    """int_0^angle of the periodic linear interpolant through `rates` at the cell mid-angles (k + 1/2) step (exact,
    any real angle); `cumulative` = periodic_cumulative(rates, step)."""
    samples = rates.size
    shifted = angle - 0.5 * step
    turns = math.floor(shifted / (2.0 * math.pi))
    position = (shifted - turns * 2.0 * math.pi) / step
    k = min(int(position), samples - 1)
    f = position - k
    a, b = rates[k], rates[(k + 1) % samples]
    return turns * cumulative[-1] + cumulative[k] + step * (a * f + 0.5 * (b - a) * f * f)


# the table ---------------------------------------------------------------------------------------------------
class MapTable:
    """Channels on a (speed, angle) grid, periodic in angle, linear in speed.

    speeds [rpm], increasing; channels[name] has shape (speeds, samples), node angles theta_k = k dtheta for every
    channel except the torque, whose nodes are at (k + 1/2) dtheta (cell means of the work); figures[name] has
    shape (speeds,). Below the lowest speed the table holds the lowest speed's waveform (per angle) and figures;
    above the highest, the highest's: nothing is extrapolated.
    """

    def __init__(self, speeds, channels: dict, figures: dict, scatter: dict | None = None,
                 figure_scatter: dict | None = None, metadata: dict | None = None):
        self.speeds = np.asarray(speeds, dtype=float)
        if self.speeds.ndim != 1 or self.speeds.size < 1 or np.any(np.diff(self.speeds) <= 0.0):
            raise ValueError(f"'speeds' = {self.speeds!r} is invalid: allowed a strictly increasing list of speeds")
        self.channels = {n: np.asarray(v, dtype=float) for n, v in channels.items()}
        shapes = {v.shape for v in self.channels.values()}
        if len(shapes) != 1 or next(iter(shapes))[0] != self.speeds.size:
            raise ValueError(f"channel shapes {sorted(shapes)} do not match {self.speeds.size} speeds")
        self.samples = next(iter(shapes))[1]
        self.step = 2.0 * math.pi / self.samples
        self.figures = {n: np.asarray(v, dtype=float) for n, v in figures.items()}
        self.scatter = {n: np.asarray(v, dtype=float) for n, v in (scatter or {}).items()}
        self.figure_scatter = {n: np.asarray(v, dtype=float) for n, v in (figure_scatter or {}).items()}
        self.metadata = metadata or {}
        self._names = list(self.channels)
        self._stack = np.stack([self.channels[n] for n in self._names])            # (channel, speed, angle)
        self._offsets = np.array([self._offset(n) for n in self._names])
        self._figure_names = list(self.figures)
        self._figure_stack = np.stack([self.figures[n] for n in self._figure_names]) if self.figures else None
        torque = self.channels.get(TORQUE)
        if torque is not None:          # cumulative integral of the periodic linear interpolant at its nodes
            self._torque_cumulative = periodic_cumulative(torque, self.step)

    # interpolation weights -------------------------------------------------------------------------------
    def _speed_weights(self, speed_rpm: float):
        """(i, j, w): value = (1 - w) v_i + w v_j, clamped to the grid's ends."""
        speeds = self.speeds
        if speed_rpm <= speeds[0]:
            return 0, 0, 0.0
        if speed_rpm >= speeds[-1]:
            last = speeds.size - 1
            return last, last, 0.0
        j = int(np.searchsorted(speeds, speed_rpm, side="right"))
        return j - 1, j, (speed_rpm - speeds[j - 1]) / (speeds[j] - speeds[j - 1])

    def _offset(self, name: str) -> float:
        return 0.5 * self.step if name == TORQUE else 0.0

    def value(self, name: str, angle: float, speed_rpm: float) -> float:
        """The channel at rotor angle `angle` [rad] and speed [rpm]: periodic linear in angle, linear in speed."""
        i, j, w = self._speed_weights(speed_rpm)
        position = ((angle - self._offset(name)) / self.step) % self.samples
        k = int(position)
        f = position - k
        k1 = (k + 1) % self.samples
        data = self.channels[name]
        at_i = (1.0 - f) * data[i, k] + f * data[i, k1]
        at_j = (1.0 - f) * data[j, k] + f * data[j, k1]
        return float((1.0 - w) * at_i + w * at_j)

    def values(self, angle: float, speed_rpm: float) -> dict[str, float]:
        """Every channel at (angle, speed), as `value` gives each, in one vectorised evaluation."""
        i, j, w = self._speed_weights(speed_rpm)
        position = ((angle - self._offsets) / self.step) % self.samples
        k = position.astype(np.int64)
        f = position - k
        k1 = (k + 1) % self.samples
        rows = np.arange(len(self._names))
        stack = self._stack
        at_i = (1.0 - f) * stack[rows, i, k] + f * stack[rows, i, k1]
        at_j = (1.0 - f) * stack[rows, j, k] + f * stack[rows, j, k1]
        return dict(zip(self._names, ((1.0 - w) * at_i + w * at_j).tolist()))

    def figures_at(self, speed_rpm: float) -> dict[str, float]:
        """Every per-revolution figure at `speed_rpm`, linear in speed."""
        i, j, w = self._speed_weights(speed_rpm)
        stack = self._figure_stack
        return dict(zip(self._figure_names, ((1.0 - w) * stack[:, i] + w * stack[:, j]).tolist()))

    def figure(self, name: str, speed_rpm: float) -> float:
        """A per-revolution figure at `speed_rpm`, linear in speed."""
        i, j, w = self._speed_weights(speed_rpm)
        data = self.figures[name]
        return float((1.0 - w) * data[i] + w * data[j])

    def _torque_antiderivative(self, row: int, angle: float) -> float:
        """int_0^angle T_row(theta) dtheta of the periodic linear interpolant (exact, any real angle)."""
        return periodic_antiderivative(self.channels[TORQUE][row], self._torque_cumulative[row], self.step, angle)

    def torque_integral(self, angle_start: float, angle_end: float, speed_rpm: float) -> float:
        """int_{angle_start}^{angle_end} T(theta, speed) dtheta [J], exact for the interpolated torque."""
        i, j, w = self._speed_weights(speed_rpm)
        at_i = self._torque_antiderivative(i, angle_end) - self._torque_antiderivative(i, angle_start)
        if w == 0.0:
            return at_i
        at_j = self._torque_antiderivative(j, angle_end) - self._torque_antiderivative(j, angle_start)
        return (1.0 - w) * at_i + w * at_j

    # disk format -------------------------------------------------------------------------------------------
    def save(self, folder: Path, key: str) -> Path:
        """Write <key>.npz (arrays) and <key>.json (metadata); the npz is written last, atomically."""
        arrays = {"speeds": self.speeds}
        arrays.update({f"channel/{n}": v for n, v in self.channels.items()})
        arrays.update({f"figure/{n}": v for n, v in self.figures.items()})
        arrays.update({f"scatter/{n}": v for n, v in self.scatter.items()})
        arrays.update({f"figure_scatter/{n}": v for n, v in self.figure_scatter.items()})
        return write_table(folder, key, arrays, self.metadata)

    @classmethod
    def load(cls, path: Path) -> "MapTable":
        """Read a table written by `save` (no pickle)."""
        with np.load(path, allow_pickle=False) as data:
            groups = {"channel": {}, "figure": {}, "scatter": {}, "figure_scatter": {}}
            for name in data.files:
                if "/" in name:
                    group, field = name.split("/", 1)
                    groups[group][field] = data[name]
            speeds = data["speeds"]
        metadata = json.loads(Path(path).with_suffix(".json").read_text())
        return cls(speeds, groups["channel"], groups["figure"], groups["scatter"], groups["figure_scatter"],
                   metadata)


def write_table(folder: Path, key: str, arrays: dict, metadata: dict) -> Path:
    """Write <key>.json (metadata) and <key>.npz (arrays), the npz last and atomically: a table whose npz exists
    is complete."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{key}.json").write_text(json.dumps(dict(metadata, key=key), indent=1, sort_keys=True))
    temporary = folder / f"{key}.partial.npz"
    np.savez(temporary, **arrays)
    os.replace(temporary, folder / f"{key}.npz")
    return folder / f"{key}.npz"


# cache -------------------------------------------------------------------------------------------------------
def default_cache_dir() -> Path:
    """Beside the compiled kernels: <cache root>/../periodic_maps."""
    return cache_root().parent / "periodic_maps"


def cache_key(params: CompressorParameters, speeds, settings: MapSettings, project_dir: Path = PROJECT_DIR) -> str:
    """SHA-256 over every parameter, the speed grid request, the settings, the format and the sources."""
    description = dict(format=FORMAT_VERSION, parameters=dataclasses.asdict(params),
                       speeds=None if speeds is None else [float(s) for s in speeds],
                       settings=dataclasses.asdict(settings), sources=source_hash(project_dir))
    return hashlib.sha256(json.dumps(description, sort_keys=True).encode()).hexdigest()[:32]


def _progress(message: str) -> None:
    print(f"[periodic map] {message}", file=sys.stderr, flush=True)


def fan_out(function, arguments: tuple, client=None, workers: int = 1, done=None) -> list:
    """[function(*row) for each row of `arguments` (one list per parameter of `function`)], in order: on the dask
    `client`, in `workers` processes, or here (workers <= 1); done(result) as each result arrives."""
    with ExitStack() as stack:
        if client is not None:
            results = (future.result() for future in client.map(function, *arguments, pure=False))
        elif workers <= 1:
            results = map(function, *arguments)
        else:
            results = stack.enter_context(ProcessPoolExecutor(max_workers=workers)).map(function, *arguments)
        collected = []
        for result in results:
            collected.append(result)
            if done is not None:
                done(result)
        return collected


def _run_all(params, speeds, settings, client, workers) -> list[dict]:
    """run_speed_point over `speeds` (fan_out)."""
    speeds = [float(speed) for speed in speeds]
    count = len(speeds)
    return fan_out(run_speed_point, ([params] * count, speeds, [settings] * count), client, workers,
                   lambda result: _progress(f"{result['speed_rpm']:.0f} rpm done in {result['seconds']:.1f} s"))


def table_from_points(points: list[dict], metadata: dict) -> MapTable:
    """Assemble run_speed_point results (any order) into a MapTable."""
    points = sorted(points, key=lambda p: p["speed_rpm"])
    return MapTable([p["speed_rpm"] for p in points],
                    {n: np.array([p["mean"][n] for p in points]) for n in CHANNELS},
                    {n: np.array([p["figures"][n] for p in points]) for n in FIGURES},
                    {n: np.array([p["scatter"][n] for p in points]) for n in CHANNELS},
                    {n: np.array([p["figure_scatter"][n] for p in points]) for n in FIGURES},
                    dict(metadata, seconds_per_point=[p["seconds"] for p in points]))


def build_map(params: CompressorParameters, speeds=None, *, operating_rpm: float = 1500.0,
              settings: MapSettings | None = None, client=None, workers: int | None = None,
              cache_dir: Path | None = None, max_speeds: int = 12) -> MapTable:
    """The periodic-map table of `params`, from the disk cache or built.

    speeds: grid [rpm]; default 8 speeds from 10 % to 120 % of `operating_rpm`, refined (up to `max_speeds`) with
    midpoints where the input power, the discharge mass flow or the torque waveform curves
    (`refinement_speeds`). client: a dask.distributed Client to fan
    out on; else `workers` processes (default: the CPU count, 1 runs here).
    """
    settings = settings or MapSettings(table_speed_rpm=operating_rpm)
    if speeds is not None:
        speeds = np.asarray(speeds, dtype=float)
        if speeds.ndim != 1 or speeds.size < 1 or np.any(np.diff(speeds) <= 0.0) or speeds[0] <= 0.0:
            raise ValueError(f"'speeds' = {speeds.tolist()!r} rpm is invalid: allowed increasing speeds > 0 rpm")
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = cache_key(params, speeds, settings)
    path = folder / f"{key}.npz"
    if path.exists():
        _progress(f"loaded {path}")
        return MapTable.load(path)
    workers = workers if workers is not None else (os.cpu_count() or 1)
    grid = speeds if speeds is not None else initial_speed_grid(operating_rpm)
    _progress(f"building {grid.size} speed points ({settings.averaged_revolutions} averaged revolutions after "
              f"{settings.warmup_revolutions} warm-up each) into {path}")
    points = _run_all(params, grid, settings, client, workers)
    if speeds is None:
        added = refinement_speeds(table_from_points(points, {}), max_speeds - grid.size)
        if added.size:
            _progress(f"refining at {', '.join(f'{s:.0f}' for s in added)} rpm")
            points += _run_all(params, added, settings, client, workers)
    table = table_from_points(points, dict(parameters=dataclasses.asdict(params),
                                           settings=dataclasses.asdict(settings), format=FORMAT_VERSION))
    table.save(folder, key)
    _progress(f"saved {path}")
    return table
