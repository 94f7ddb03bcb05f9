"""Periodic map over the fluid inputs: the detailed model's periodic steady state per rotor angle on a grid of
speed x suction pressure x discharge pressure, at a fixed suction superheat (docs/model.md §12.4).

`build_fluid_map(params, settings)` runs `run_speed_point` (mechanics.reduced.periodic_map) at every grid point
with the boundary held there (suction temperature T_dew(p_s) + superheat), on a dask client or in worker processes,
and returns a `FluidMapTable`, cached on disk as npz + json (never pickle) under a key hashing the parameters, the
settings, the format and the sources, like the speed-only tables.

Conservative channels (RATES): shaft work, drawn mass and enthalpy, delivered mass and enthalpy are tabulated as
cell means of the detailed model's cumulative quantities per angle cell (as the torque is in the speed-only map);
their integral over any angle span is exact for the interpolant, so over a revolution it is the detailed model's
total, and a host summing the step increments gets the cumulative value exactly. Every other channel is sampled at
the node angles. Interpolation: multilinear in (speed, p_s, p_d); speeds outside the grid hold the end speed's
waveform (as the speed-only map), pressures outside the grid's box are refused (ValueError naming the input).

Suction state (docs/model.md §12.4): the table is at the fixed superheat; another suction enthalpy h_s at p_s scales
the mass rates by rho(p_s, h_s) / rho_tab(p_s) and the enthalpy rates to ratio (E_tab + (h_s - h_tab) M_tab): the
same volume drawn at the actual density, the same enthalpy rise per kg. rho(p_s, h) is tabulated at build time
(CoolProp) over ENTHALPY_OFFSETS around h_tab(p_s), linear in both; an enthalpy outside that range is refused.
"""
from __future__ import annotations

import bisect
import dataclasses
import hashlib
import json
import math
import os
from pathlib import Path

import numpy as np

from ...kernels.compile_cache import source_hash
from ...thermo.fluid import coolprop
from ..parameters import CompressorParameters
from .periodic_map import (CHANNELS, FIGURES, FORMAT_VERSION, PROJECT_DIR, TORQUE, MapSettings, _progress,
                           default_cache_dir, fan_out, periodic_cumulative, run_speed_point, write_table)

# conservative channels: name -> signed cumulative history columns (mechanics.loop.outputs; the FMU's flow outputs)
RATES = {
    "shaft_work": (("work_in", 1.0),),
    "drawn_mass": (("mass_suction", 1.0),),
    "drawn_enthalpy": (("energy_suction", 1.0),),
    "delivered_mass": (("mass_discharge", 1.0), ("mass_back_chamber", -1.0)),
    "delivered_enthalpy": (("energy_discharge", 1.0), ("energy_back_chamber", -1.0)),
}
MASS_RATES = {"drawn_mass": "drawn_enthalpy", "delivered_mass": "delivered_enthalpy"}   # mass -> its enthalpy
ENTHALPY_OFFSETS = np.linspace(-40e3, 40e3, 33)       # J/kg around h_tab(p_s): the suction states taken


@dataclasses.dataclass(frozen=True)
class FluidMapSettings:
    """The grid and how each point is run; every field enters the cache key.

    speeds [rpm], suction_pressures [Pa], discharge_pressures [Pa]: increasing grids; suction_superheat [K]: the
    suction state of every point, T_s = T_dew(p_s) + superheat; table_speed_rpm, samples, warmup_revolutions,
    averaged_revolutions: as periodic_map.MapSettings.
    """
    speeds: tuple
    suction_pressures: tuple
    discharge_pressures: tuple
    suction_superheat: float
    table_speed_rpm: float = 1500.0
    samples: int = 720
    warmup_revolutions: int = 3
    averaged_revolutions: int = 4

    def __post_init__(self):
        for name in ("speeds", "suction_pressures", "discharge_pressures"):
            values = np.asarray(getattr(self, name), dtype=float)
            if values.ndim != 1 or values.size < 2 or np.any(np.diff(values) <= 0.0) or values[0] <= 0.0 \
                    or not np.all(np.isfinite(values)):
                raise ValueError(f"'{name}' = {list(getattr(self, name))!r} is invalid: allowed at least 2 "
                                 f"increasing finite values > 0")
            object.__setattr__(self, name, tuple(float(v) for v in values))
        if not (math.isfinite(self.suction_superheat) and self.suction_superheat >= 1.0):
            raise ValueError(f"'suction_superheat' = {self.suction_superheat!r} K is invalid: allowed >= 1 K (the "
                             f"property table's margin from the dew line)")
        for name, low in (("samples", 720), ("warmup_revolutions", 1), ("averaged_revolutions", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"'{name}' = {value!r} is invalid: allowed an integer >= {low}")

    def point_settings(self) -> MapSettings:
        """The settings of one grid point's run."""
        return MapSettings(table_speed_rpm=self.table_speed_rpm, samples=self.samples,
                           warmup_revolutions=self.warmup_revolutions,
                           averaged_revolutions=self.averaged_revolutions)


def system_grid(params: CompressorParameters, operating_rpm: float = 1500.0) -> FluidMapSettings:
    """The default grid (docs/model.md §12.4): 1/3 to 16/15 of `operating_rpm` (4 speeds: 500, 1000, 1400, 1600 rpm at
    1500; below, the lowest speed's waveform holds), p_s 200-500 kPa (6), p_d 450 kPa-1.40 MPa (8): the
    refrigeration system's start-up from 488 kPa on both sides to its steady 272 kPa / 1.16 MPa, with margin; the
    suction superheat is that of the parameters' suction state."""
    dew = coolprop().PropsSI("T", "P", params.suction_pressure, "Q", 1.0, params.fluid)
    return FluidMapSettings(speeds=tuple(np.array([1.0 / 3.0, 2.0 / 3.0, 14.0 / 15.0, 16.0 / 15.0]) * operating_rpm),
                            suction_pressures=tuple(np.linspace(200e3, 500e3, 6)),
                            discharge_pressures=tuple(np.linspace(450e3, 1.4e6, 8)),
                            suction_superheat=float(params.suction_temperature - dew), table_speed_rpm=operating_rpm)


def suction_states(fluid: str, settings: FluidMapSettings) -> dict:
    """Per suction-pressure node: T_tab, h_tab, rho_tab at the superheat, and rho over h_tab + ENTHALPY_OFFSETS."""
    props = coolprop().PropsSI
    pressures = np.array(settings.suction_pressures)
    temperatures = np.array([props("T", "P", p, "Q", 1.0, fluid) for p in pressures]) + settings.suction_superheat
    enthalpies = np.array([props("H", "P", p, "T", t, fluid) for p, t in zip(pressures, temperatures)])
    densities = np.array([props("D", "P", p, "T", t, fluid) for p, t in zip(pressures, temperatures)])
    grid = np.array([[props("D", "P", p, "H", h + offset, fluid) for offset in ENTHALPY_OFFSETS]
                     for p, h in zip(pressures, enthalpies)])
    return dict(temperature=temperatures, enthalpy=enthalpies, density=densities, density_grid=grid)


class FluidMapTable:
    """Channels on a (speed, p_s, p_d, angle) grid (module docstring). channels[name], rates[name]: shape
    (speeds, suction pressures, discharge pressures, samples), node angles k dtheta for channels, (k + 1/2) dtheta
    for rates and the torque; figures[name]: (speeds, p_s, p_d); suction[name]: per p_s node (suction_states)."""

    AXES = (("shaft_speed", "rpm"), ("suction_pressure", "Pa"), ("discharge_pressure", "Pa"))

    def __init__(self, grid: tuple, channels: dict, rates: dict, figures: dict, suction: dict,
                 metadata: dict | None = None):
        self.grid = tuple(np.asarray(axis, dtype=float) for axis in grid)
        self._grid_lists = tuple(axis.tolist() for axis in self.grid)             # bisect on floats: fast
        self.channels = {n: np.asarray(v, dtype=float) for n, v in channels.items()}
        self.rates = {n: np.asarray(v, dtype=float) for n, v in rates.items()}
        self.figures = {n: np.asarray(v, dtype=float) for n, v in figures.items()}
        self.suction = {n: np.asarray(v, dtype=float) for n, v in suction.items()}
        self.metadata = metadata or {}
        shape = tuple(axis.size for axis in self.grid)
        for group in (self.channels, self.rates):
            for name, values in group.items():
                if values.shape[:3] != shape:
                    raise ValueError(f"channel '{name}' has shape {values.shape}, the grid {shape}")
        self.samples = next(iter(self.rates.values())).shape[3]
        self.step = 2.0 * math.pi / self.samples
        self._names = list(self.channels)
        self._stack = np.stack([self.channels[n] for n in self._names])       # (channel, s, p, d, angle)
        self._offsets = np.array([0.5 * self.step if n == TORQUE else 0.0 for n in self._names])
        self._rate_names = list(self.rates)
        self._rates = np.stack([self.rates[n] for n in self._rate_names])           # (rate, s, p, d, angle)
        self._cumulative = periodic_cumulative(self._rates, self.step)             # (rate, s, p, d, angle + 1)
        self._figure_names = list(self.figures)
        self._figures = np.stack([self.figures[n] for n in self._figure_names])    # (figure, s, p, d)

    # the box and the weights -------------------------------------------------------------------------------
    def box_error(self, suction_pressure: float, discharge_pressure: float) -> str | None:
        """None inside the table's pressure box, else the refusal naming the input, its value and the box."""
        for (name, unit), axis, value in zip(self.AXES[1:], self.grid[1:], (suction_pressure, discharge_pressure)):
            if not (math.isfinite(value) and axis[0] <= value <= axis[-1]):
                return (f"input '{name}' = {value!r} {unit} is outside the periodic map's box: allowed "
                        f"[{axis[0]:g}, {axis[-1]:g}] {unit} (p_s in [{self.grid[1][0]:g}, {self.grid[1][-1]:g}] "
                        f"Pa, p_d in [{self.grid[2][0]:g}, {self.grid[2][-1]:g}] Pa)")
        return None

    @staticmethod
    def _axis_weights(axis: list, value: float):
        """((i, 1 - w), (j, w)) of linear interpolation on the increasing list `axis`, the ends held."""
        if value <= axis[0]:
            return ((0, 1.0),)
        if value >= axis[-1]:
            return ((len(axis) - 1, 1.0),)
        j = bisect.bisect_right(axis, value)
        w = (value - axis[j - 1]) / (axis[j] - axis[j - 1])
        return ((j - 1, 1.0 - w), (j, w))

    def corners(self, speed_rpm: float, suction_pressure: float, discharge_pressure: float):
        """(i, j, l, weights): index arrays of the multilinear interpolation's corners and their weights;
        ValueError outside the pressure box."""
        error = self.box_error(suction_pressure, discharge_pressure)
        if error is not None:
            raise ValueError(error)
        speeds, suctions, discharges = (self._axis_weights(axis, value) for axis, value in
                                        zip(self._grid_lists, (speed_rpm, suction_pressure, discharge_pressure)))
        corners = [(i, j, l, wi * wj * wl) for i, wi in speeds for j, wj in suctions for l, wl in discharges]
        i, j, l, w = (np.array(column) for column in zip(*corners))
        return i, j, l, w

    # suction state ------------------------------------------------------------------------------------------
    def suction_correction(self, suction_pressure: float, suction_enthalpy: float) -> tuple[float, float]:
        """(density ratio rho(p_s, h_s) / rho_tab(p_s), h_s - h_tab(p_s)) (module docstring); ValueError if h_s is
        outside the tabulated range."""
        weights = self._axis_weights(self._grid_lists[1], suction_pressure)
        h_tab = sum(w * self.suction["enthalpy"][j] for j, w in weights)
        rho_tab = sum(w * self.suction["density"][j] for j, w in weights)
        offset = suction_enthalpy - h_tab
        if not (ENTHALPY_OFFSETS[0] <= offset <= ENTHALPY_OFFSETS[-1]):
            raise ValueError(f"input 'suction_enthalpy' = {suction_enthalpy!r} J/kg is outside the periodic map's "
                             f"suction states at p_s = {suction_pressure:g} Pa: allowed "
                             f"[{h_tab + ENTHALPY_OFFSETS[0]:g}, {h_tab + ENTHALPY_OFFSETS[-1]:g}] J/kg")
        rho = sum(w * np.interp(offset, ENTHALPY_OFFSETS, self.suction["density_grid"][j]) for j, w in weights)
        return float(rho / rho_tab), float(offset)

    def suction_enthalpy_at(self, suction_pressure: float, suction_temperature: float) -> float:
        """h(p_s, T_s) of a superheated suction gas: h_tab + c_p,tab (T_s - T_tab), with the c_p of the tabulated
        state (a suction temperature input; the gas side only)."""
        weights = self._axis_weights(self._grid_lists[1], suction_pressure)
        t_tab = sum(w * self.suction["temperature"][j] for j, w in weights)
        h_tab = sum(w * self.suction["enthalpy"][j] for j, w in weights)
        cp = sum(w * self.suction["gas_heat_capacity"][j] for j, w in weights)
        return float(h_tab + cp * (suction_temperature - t_tab))

    # evaluation ---------------------------------------------------------------------------------------------
    def values(self, angle: float, speed_rpm: float, suction_pressure: float, discharge_pressure: float) -> dict:
        """Every node-sampled channel at the point: periodic linear in angle, multilinear in the rest."""
        i, j, l, w = self.corners(speed_rpm, suction_pressure, discharge_pressure)
        position = ((angle - self._offsets) / self.step) % self.samples
        k = position.astype(np.int64)[:, None]
        f = (position[:, None] - k)
        rows = np.arange(len(self._names))[:, None]
        at = (1.0 - f) * self._stack[rows, i, j, l, k] + f * self._stack[rows, i, j, l, (k + 1) % self.samples]
        return dict(zip(self._names, (at @ w).tolist()))

    def figures_at(self, speed_rpm: float, suction_pressure: float, discharge_pressure: float) -> dict:
        """Every per-revolution figure at the point, multilinear."""
        i, j, l, w = self.corners(speed_rpm, suction_pressure, discharge_pressure)
        return dict(zip(self._figure_names, (self._figures[:, i, j, l] @ w).tolist()))

    def _antiderivatives(self, i, j, l, angle: float) -> np.ndarray:
        """(rate, corner): int_0^angle of each rate's periodic linear interpolant through its cell means
        (periodic_map.periodic_antiderivative, vectorised over the rates and corners)."""
        shifted = angle - 0.5 * self.step
        turns = math.floor(shifted / (2.0 * math.pi))
        position = (shifted - turns * 2.0 * math.pi) / self.step
        k = min(int(position), self.samples - 1)
        f = position - k
        a, b = self._rates[:, i, j, l, k], self._rates[:, i, j, l, (k + 1) % self.samples]
        cumulative = self._cumulative[:, i, j, l]
        return turns * cumulative[..., -1] + cumulative[..., k] + self.step * (a * f + 0.5 * (b - a) * f * f)

    def rate_integrals(self, angle_start: float, angle_end: float, speed_rpm: float, suction_pressure: float,
                       discharge_pressure: float, suction_enthalpy: float | None = None) -> dict:
        """int of every conservative rate over [angle_start, angle_end] at the point, exact for the interpolant;
        with `suction_enthalpy`, the suction-state correction of the module docstring."""
        i, j, l, w = self.corners(speed_rpm, suction_pressure, discharge_pressure)
        span = (self._antiderivatives(i, j, l, angle_end) - self._antiderivatives(i, j, l, angle_start)) @ w
        result = dict(zip(self._rate_names, span.tolist()))
        if suction_enthalpy is not None:
            ratio, offset = self.suction_correction(suction_pressure, suction_enthalpy)
            for mass, enthalpy in MASS_RATES.items():
                result[enthalpy] = ratio * (result[enthalpy] + offset * result[mass])
                result[mass] = ratio * result[mass]
        return result

    # disk format --------------------------------------------------------------------------------------------
    def save(self, folder: Path, key: str) -> Path:
        """Write <key>.npz (arrays) and <key>.json (metadata), as the speed-only tables."""
        arrays = {f"grid/{k}": axis for k, axis in enumerate(self.grid)}
        for group, values in (("channel", self.channels), ("rate", self.rates), ("figure", self.figures),
                              ("suction", self.suction)):
            arrays.update({f"{group}/{n}": v for n, v in values.items()})
        return write_table(folder, key, arrays, self.metadata)

    @classmethod
    def load(cls, path: Path) -> "FluidMapTable":
        """Read a table written by `save` (no pickle)."""
        groups = {"grid": {}, "channel": {}, "rate": {}, "figure": {}, "suction": {}}
        with np.load(path, allow_pickle=False) as data:
            for name in data.files:
                group, field = name.split("/", 1)
                groups[group][field] = data[name]
        grid = tuple(groups["grid"][str(k)] for k in range(3))
        metadata = json.loads(Path(path).with_suffix(".json").read_text())
        return cls(grid, groups["channel"], groups["rate"], groups["figure"], groups["suction"], metadata)


# building -----------------------------------------------------------------------------------------------------
def fluid_cache_key(params: CompressorParameters, settings: FluidMapSettings, project_dir: Path = PROJECT_DIR) -> str:
    """SHA-256 over every parameter, the settings, the format and the sources."""
    description = dict(kind="fluid", format=FORMAT_VERSION, parameters=dataclasses.asdict(params),
                       settings=dataclasses.asdict(settings), offsets=ENTHALPY_OFFSETS.tolist(),
                       sources=source_hash(project_dir))
    return hashlib.sha256(json.dumps(description, sort_keys=True).encode()).hexdigest()[:32]


def _points(settings: FluidMapSettings, states: dict) -> list[tuple]:
    return [(speed, dict(suction_pressure=p_s, discharge_pressure=p_d, suction_temperature=float(t_s)))
            for speed in settings.speeds
            for p_s, t_s in zip(settings.suction_pressures, states["temperature"])
            for p_d in settings.discharge_pressures]


def _run_point(params, speed, boundary, settings):
    return run_speed_point(params, speed, settings.point_settings(), boundary=boundary, rates=RATES)


def _run_all(params, points, settings, client, workers) -> list[dict]:
    """_run_point over `points` (periodic_map.fan_out)."""
    count = len(points)
    arguments = ([params] * count, [p[0] for p in points], [p[1] for p in points], [settings] * count)
    results = fan_out(_run_point, arguments, client, workers)
    _progress(f"{count} points in {sum(r['seconds'] for r in results):.0f} s of run time")
    return results


def table_from_points(settings: FluidMapSettings, states: dict, results: list[dict], metadata: dict) -> FluidMapTable:
    shape = (len(settings.speeds), len(settings.suction_pressures), len(settings.discharge_pressures))

    def gather(group, names):
        return {n: np.array([r[group][n] for r in results]).reshape(*shape, -1).squeeze(-1)
                if group == "figures" else np.array([r[group][n] for r in results]).reshape(*shape, -1)
                for n in names}

    suction = dict(states)
    suction["gas_heat_capacity"] = np.array([coolprop().PropsSI("C", "P", p, "T", t, metadata["fluid"])
                                             for p, t in zip(settings.suction_pressures, states["temperature"])])
    return FluidMapTable((settings.speeds, settings.suction_pressures, settings.discharge_pressures),
                         gather("mean", CHANNELS), gather("mean", RATES), gather("figures", FIGURES), suction,
                         dict(metadata, seconds_per_point=[r["seconds"] for r in results]))


def build_fluid_map(params: CompressorParameters, settings: FluidMapSettings, *, client=None,
                    workers: int | None = None, cache_dir: Path | None = None) -> FluidMapTable:
    """The fluid periodic map of `params` on `settings`' grid, from the disk cache or built (module docstring).
    client: a dask.distributed Client to fan out on; else `workers` processes (default: the CPU count)."""
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = fluid_cache_key(params, settings)
    path = folder / f"{key}.npz"
    if path.exists():
        _progress(f"loaded {path}")
        return FluidMapTable.load(path)
    states = suction_states(params.fluid, settings)
    points = _points(settings, states)
    _progress(f"building {len(points)} points (speed x p_s x p_d) into {path}")
    results = _run_all(params, points, settings, client, workers if workers is not None else (os.cpu_count() or 1))
    table = table_from_points(settings, states, results,
                              dict(parameters=dataclasses.asdict(params), settings=dataclasses.asdict(settings),
                                   format=FORMAT_VERSION, fluid=params.fluid))
    table.save(folder, key)
    _progress(f"saved {path}")
    return table
