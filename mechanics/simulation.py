"""`Simulation`: owns all state of one compressor run and advances it in time (docs/model.md §8.1).

Build it from validated parameters and a speed law, call `advance(t)` as often as needed (optionally with a new
speed for the advance, as an FMU does once per communication step), and read `outputs`, `history`, the lobe
records and the per-revolution summaries (mechanics.performance). All arrays the compiled loop needs live here, so
saving and restoring a run is a copy, and an advance is one call of the compiled loop.
"""
from __future__ import annotations

import hashlib
import logging
import math
import warnings
from dataclasses import dataclass, fields

import numpy as np

from ..thermo.chamber_model import (LEADING_MASS, LEADING_TEMPERATURE, TRAILING_MASS, TRAILING_TEMPERATURE,
                                   boundary_nodes)
from ..thermo.flow_paths import FlowNode
from ..thermo.fluid import Fluid
from ..thermo.property_table import table_from_arrays
from ..thermo.real_gas_nozzle import nozzle_table_from_arrays

from .geometry.chamber_geometry import sector_table
from .geometry.displacement import displacement
from .gas.boundary import (Boundary, boundary_of, hold_boundary, moved_reference, ramp_boundary, ramp_duration,
                           solve_boundary)
from .contact.self_locking import check_vane_not_self_locking
from .errors import ContactLawWarning, IntegrationError
from .gas.gas_coupling import gas_coupling
from .gas.refused_state import refused_state_text
from .geometry.stator import law_arguments
from .loop.integrators import (ABM_HISTORY, ACCEPTED, CONTROL_HISTORY, CONTROL_SIZE, CONTROL_STEP, COUNTER_SIZE,
                               EVENT_RETRIES, GRID_COLUMNS, GRID_COUNTS_SIZE, GRID_FELL_BACK, GRID_FOLLOW, GRID_RECORDED, REJECTED, WORKSPACE_ROWS, evaluate_state, initial_chamber_inputs, run)
from .loop.layout import (ANGLE, ANGULAR_VELOCITY, GAS_BLOCK, GAS_STATE_INVALID, MEM_LOBE_COUNT, MEM_LOBE_START,
                          MEMORY_SIZE, REACHED_END, REAL_GAS_STATE_SIZE, RECORD_FULL, STATUS_TEXT, VANE_STATE_SIZE, VX,
                          VY, WORK_IN, WORK_LIMIT, X, Y)
from .loop.machine import machine_array, record_of
from .loop.outputs import OUTPUT_INDEX, OUTPUT_NAMES, OUTPUT_SIZE
from .parameters import CompressorParameters
from .performance import WindowSummary, revolution_groups, summarise_records
from .loop.run_cost import slow_run_notice
from .loop.speed import CONSTANT, LINEAR, SpeedLaw, check_speed, constant_speed, rotor_motion
from .loop.windows import (ACC_LAW_EXCESS, MODE_KEYS, RECORD_ACCUMULATORS, RECORD_SIZE, WINDOW_ACCUMULATORS,
                           new_window)

GRID_CAPACITY = 8192            # steps one advance records for replay (longer advances are not replayed)
KEPT_GRIDS = 4                  # the latest recorded grids kept for replay
GRID_METHODS = ("dopri5", "ark548")   # the methods whose step may follow a given grid (ABM4's history is at one spacing)
HISTORY_CHUNK = 4096            # output rows per call of the loop when the history is kept
RECORD_CHUNK = 64               # lobe records per call of the loop
LOG = logging.getLogger(__name__)

# The work bound of one advance: at most WORK_FLOOR + `work_per_ms` step attempts (accepted or rejected) per ms of
# the interval. Valid runs need (benchmarks/bench_work_bound.py) 70-220 per ms at 1500 rpm, about 520 at 30000 rpm
# or at the tightest tolerances, and 100 000 with max_step at its minimum of 1e-8 s; the default, WORK_PER_MS, is
# ten times that: a state that cannot advance (a step size of 0 or 5e-324, a time that does not move) stops at it
# instead of spinning.
WORK_FLOOR = 1000
WORK_PER_MS = 1_000_000


def work_bound(interval: float, work_per_ms: float = WORK_PER_MS) -> int:
    """The most step attempts an advance over `interval` seconds may make."""
    return WORK_FLOOR + math.ceil(work_per_ms * min(interval, 1e6) * 1e3)


class History:
    """Accepted-step output rows (docs/model.md §8.1b); `history["vane_displacement"]` is one column."""

    def __init__(self, rows: np.ndarray):
        self.rows = rows

    def __getitem__(self, name: str) -> np.ndarray:
        return self.rows[:, OUTPUT_INDEX[name]]

    def __len__(self) -> int:
        return self.rows.shape[0]

    names = OUTPUT_NAMES


@dataclass
class SimulationState:
    """A full copy of everything the continuation depends on (for save/restore, FMU rollback)."""
    time: float
    state: np.ndarray
    memory: np.ndarray
    control: np.ndarray
    abm_history: np.ndarray
    window: np.ndarray
    run_dwell: np.ndarray
    speed_law: np.ndarray
    last_output: np.ndarray
    counters: np.ndarray
    recent_records: np.ndarray
    boundary_nodes: np.ndarray        # the suction and back FlowNodes held (mechanics.gas.boundary), 8 values


ARRAY_FIELDS = tuple(f.name for f in fields(SimulationState) if f.name != "time")


class Simulation:
    """One compressor run under a speed input.

    params: validated `CompressorParameters` (defaults of docs/model.md §9 if omitted).
    speed: a `SpeedLaw` from t = 0 (default constant 1500 rpm).
    initial_angle: rotor angle theta0 at t = 0 [rad]; docs/model.md §3.3 uses 0.02 for constant speed, 0 for start-up.
    keep_history: record every accepted step and every lobe record (for plots and studies); without it only the
        last output row and the lobe records of the last revolution are kept (what an FMU needs).
    table_speed_rpm: operating speed of the Level 0.5 pressure table (default: the speed law's target).

    `contact_law_excess` is the largest penetration beyond a force law's validity limit so far [m]; the first time it
    becomes positive a ContactLawWarning is issued (once per run; an FMU sets `warn_contact_law = False` and logs
    it itself).
    """
    warn_contact_law = True
    work_per_ms = WORK_PER_MS            # the work bound (work_bound) of each advance

    def __init__(self, params: CompressorParameters | None = None, speed: SpeedLaw | None = None,
                 initial_angle: float = 0.02, keep_history: bool = True, table_speed_rpm: float | None = None):
        self.params = params if params is not None else CompressorParameters()
        speed = speed if speed is not None else constant_speed(1500.0)
        if not isinstance(speed, SpeedLaw):
            raise ValueError(f"'speed' = {speed!r} is invalid: allowed a SpeedLaw (constant_speed, cycloidal_ramp, "
                             f"linear_ramp)")
        if not (isinstance(initial_angle, (int, float)) and math.isfinite(initial_angle)):
            raise ValueError(f"'initial_angle' = {initial_angle!r} is invalid: allowed a finite angle in rad")
        table_rpm = speed.target_rpm if table_speed_rpm is None else table_speed_rpm
        operating_speed = check_speed("table_speed_rpm", table_rpm)
        if self.params.pressure_model == "ideal_gas_table" and operating_speed <= 0.0:
            raise ValueError(f"'table_speed_rpm' = {table_rpm!r} rpm (the speed law's target unless given) is "
                             f"invalid for pressure_model 'ideal_gas_table': allowed an operating speed > 0 rpm "
                             f"(the table depends on it)")
        p = self.params
        check_vane_not_self_locking(p)             # a vane that jams in its slot cannot run (docs/model.md §5.5)
        notice = slow_run_notice(p, speed.target_rpm)
        if notice:                                 # said up front (docs/model.md §8.3)
            LOG.warning(notice)
        self.gas = gas_coupling(p, operating_speed)
        self.gas_reference = self.gas.reference
        self._initial_boundary = self.boundary
        machine = machine_array(p)
        self.machine = record_of(machine)          # the constants by name (mechanics.loop.machine)
        sectors = sector_table(self.machine)
        self._context = (machine, None, self.gas.pressure_table, self.gas.chambers, self.gas.flow_work,
                         *self.gas.properties, *self.gas.nozzles, sectors.segments, sectors.nodes)
        self.keep_history = keep_history
        self.time = 0.0
        self.speed_law = speed.segment(0.0, float(initial_angle))
        if p.pressure_model == "real_gas":
            self._check_valley_volumes()
        self.state = self._nominal_state(float(initial_angle), rotor_motion(0.0, self.speed_law)[1])
        self.memory = np.zeros(MEMORY_SIZE)
        lobe = 2.0 * math.pi / p.lobes
        self.memory[MEM_LOBE_START] = math.floor(initial_angle / lobe) * lobe
        self.control = np.zeros(CONTROL_SIZE)
        self.control[CONTROL_STEP] = p.initial_step
        self.abm_history = np.zeros((ABM_HISTORY, self.state.size))
        self.counters = np.zeros(COUNTER_SIZE, dtype=np.int64)
        self.run_dwell = np.zeros(MODE_KEYS)
        self._work = np.zeros((WORKSPACE_ROWS, self.state.size))
        self._outs = np.zeros((2, OUTPUT_SIZE))
        self._rows = np.empty((HISTORY_CHUNK if keep_history else 1, OUTPUT_SIZE))
        self._record_buffer = np.empty((RECORD_CHUNK, RECORD_SIZE))
        self._grid = np.empty((GRID_CAPACITY, GRID_COLUMNS))      # the steps to follow (replay)
        self._recorded_grid = np.empty((GRID_CAPACITY, GRID_COLUMNS))     # those this advance chose
        self._grid_counts = np.zeros(GRID_COUNTS_SIZE, dtype=np.int64)
        self._grids: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}     # start key -> (steps, control)
        self.replay_fallbacks = 0            # replays whose error exceeded the limit (docs/model.md §8.2)
        self._chunks: list[np.ndarray] = []
        self._records: list[np.ndarray] = []
        self.recent_records = np.empty((0, RECORD_SIZE))
        self.last_revolution: WindowSummary | None = None
        self._at_valley = abs(initial_angle - self.memory[MEM_LOBE_START]) <= 1e-12 * max(1.0, abs(initial_angle))
        self._start_outputs()
        self.contact_law_excess = 0.0

    def _start_outputs(self) -> None:
        """The initial output row and the first window, from the state at the start."""
        self.initial_output = np.empty(OUTPUT_SIZE)
        status = evaluate_state(self.time, self.state, self.memory, self.initial_output, np.empty(self.state.size),
                                *self._kernel_context())
        self.last_output = self.initial_output.copy()
        if status != 0:
            raise IntegrationError(self._failure_text(status), self.time, self.state)
        self.window = new_window(self.initial_output, self._at_valley)

    def _nominal_state(self, angle: float, omega: float) -> np.ndarray:
        """Nominal pose and velocity (docs/model.md §3.3): untilted, centred, tip centre at R0 + s + c_S; under real
        gas both chambers hold suction gas (docs/model.md §7.2)."""
        p = self.params
        s, ds, _, _ = displacement(angle, *law_arguments(p)[:5])
        radius = p.base_radius + s + p.stator_clearance
        tip_centre = self.machine.tip_centre
        e_r = np.array([math.cos(angle), math.sin(angle)])
        e_t = np.array([-e_r[1], e_r[0]])
        centre = (radius - tip_centre) * e_r
        velocity = ds * omega * e_r + (radius - tip_centre) * omega * e_t
        real_gas = p.pressure_model == "real_gas"
        y = np.zeros(REAL_GAS_STATE_SIZE if real_gas else VANE_STATE_SIZE)
        y[X], y[Y], y[ANGLE] = centre[0], centre[1], angle
        y[VX], y[VY], y[ANGULAR_VELOCITY] = velocity[0], velocity[1], omega
        if real_gas:
            suction_temperature = self.gas.chambers["suction_temperature"][0]
            y[GAS_BLOCK + LEADING_TEMPERATURE] = y[GAS_BLOCK + TRAILING_TEMPERATURE] = suction_temperature
            y[GAS_BLOCK + LEADING_MASS] = y[GAS_BLOCK + TRAILING_MASS] = math.nan     # set from the volumes below
            self._fill_chambers_with_suction_gas(y)
        return y

    def _check_valley_volumes(self) -> None:
        """Refuse, before any work, a real-gas machine whose chambers cannot hold gas at the valleys: with a wide
        valley gap the vane straddling the valley line leaves the chamber beside it a negative geometric volume (the
        tip's cap above the rotor circle counts against the chamber on its side of the line, docs/model.md §7.2). For the untilted vane at
        the start and the end of a lobe, on its nominal radius or lifted by c_S, centred or against either slot wall,
        at least a quarter of the dead volume must remain (a margin for tilt, measured in tests/mechanics/test_real_gas.py)."""
        p = self.params
        lobe = 2.0 * math.pi / p.lobes
        memory = np.zeros(MEMORY_SIZE)
        machine, _, *rest = self._kernel_context()
        smallest = math.inf
        for angle, chamber in ((0.0, 1), (lobe * (1.0 - 1e-9), 0)):          # new trailing, old leading
            law = constant_speed(0.0).segment(0.0, angle)                     # the rotor at `angle`
            s, _, _, _ = displacement(angle, *law_arguments(p)[:5])
            e_r = np.array([math.cos(angle), math.sin(angle)])
            e_t = np.array([-e_r[1], e_r[0]])
            for lift in (0.0, -p.stator_clearance):
                for side in (-0.5, 0.0, 0.5):
                    centre = ((p.base_radius + s + p.stator_clearance + lift - self.machine.tip_centre) * e_r
                              + side * p.slot_clearance * e_t)
                    y = np.zeros(REAL_GAS_STATE_SIZE)
                    y[X], y[Y], y[ANGLE] = centre[0], centre[1], angle
                    smallest = min(smallest, initial_chamber_inputs(0.0, y, memory, machine, law, *rest)[chamber])
        if smallest + p.dead_volume < 0.25 * p.dead_volume:
            raise ValueError(
                f"parameter 'stator_clearance' = {p.stator_clearance:g} m is out of range for pressure_model "
                f"'real_gas' with dead_volume = {p.dead_volume:g} m3: at the valley the chamber beside the vane can "
                f"have a geometric volume of {smallest:.3g} m3 (the wide valley gap), leaving less than a quarter of "
                f"the dead volume; allowed: a smaller stator_clearance, or dead_volume >= {-4.0 * smallest / 3.0:.3g} "
                f"m3")

    def _fill_chambers_with_suction_gas(self, y: np.ndarray) -> None:
        """Chamber masses rho_s V of the nominal pose's volumes (with the dead volume)."""
        memory = np.zeros(MEMORY_SIZE)
        lobe = 2.0 * math.pi / self.params.lobes
        memory[MEM_LOBE_START] = math.floor(y[ANGLE] / lobe) * lobe
        volumes = initial_chamber_inputs(0.0, y, memory, *self._kernel_context())
        dead = self.params.dead_volume
        suction_density = self.gas.chambers["suction_density"][0]
        y[GAS_BLOCK + LEADING_MASS] = suction_density * (volumes[0] + dead)
        y[GAS_BLOCK + TRAILING_MASS] = suction_density * (volumes[1] + dead)

    def _kernel_context(self) -> tuple:
        machine, _, *rest = self._context
        return (machine, self.speed_law, *rest)

    # speed input ----------------------------------------------------------------------------------------
    def set_speed(self, speed: SpeedLaw) -> None:
        """Follow `speed` from the current time and angle on (a ramp starts from its own start_rpm)."""
        theta = rotor_motion(self.time, self.speed_law)[0]
        self.speed_law = speed.segment(self.time, theta)
        self.control[CONTROL_HISTORY] = 0          # a new law is a non-smooth point: restart ABM4

    def _speed_for_advance(self, end_time: float, speed_rpm: float, interpolate: bool) -> None:
        omega_target = check_speed("speed_rpm", speed_rpm)
        law = self.speed_law
        theta, omega, _ = rotor_motion(self.time, law)
        if interpolate and end_time > self.time and omega_target != omega:
            segment = (LINEAR, self.time, theta, omega, omega_target, end_time - self.time)
        else:
            segment = (CONSTANT, self.time, theta, omega_target, omega_target, 0.0)
            # a held speed jumps: the motor delivers the rotor's kinetic energy 1/2 J2 (w2^2 - w1^2) at once
            self.state[WORK_IN] += 0.5 * self.params.rotor_inertia * (omega_target ** 2 - omega ** 2)
        # a new segment is a non-smooth point (restart ABM4); an unchanged speed keeps the law and the history
        if segment[0] == LINEAR or (segment[0], segment[3], segment[4]) != (law[0], law[3], law[4]):
            law[:] = segment                       # in place: the kernel's argument stays the same array
            self.control[CONTROL_HISTORY] = 0

    # boundary input -------------------------------------------------------------------------------------
    @property
    def boundary(self) -> Boundary:
        """The boundary conditions the run holds now (suction node, back node: thermo.flow_paths.FlowNode)."""
        return boundary_of(self.gas.chambers)

    def set_boundary(self, suction_pressure: float, discharge_pressure: float, suction_temperature=None,
                     suction_enthalpy=None) -> None:
        """Hold the suction state (p_s [Pa] with T_s [K] or h_s [J/kg]) and the discharge pressure p_d [Pa] from
        the current time on (mechanics.gas.boundary: the boundary nodes solved on the property table, no CoolProp). At
        the start time, before any advance, the chambers are filled again with the new suction gas. A value the
        run cannot take raises ValueError naming it, before anything changes (mechanics.gas.boundary.solve_boundary).
        `advance(boundary=...)` takes the same values, held or interpolated over the advance."""
        nodes = solve_boundary(self.params, self.gas, self.boundary, suction_pressure, discharge_pressure,
                               suction_temperature, suction_enthalpy)
        self._hold_nodes(nodes)

    def _hold_nodes(self, nodes: Boundary | None) -> None:
        """Hold solved nodes from the current time on (None: unchanged; a ramp that ended stays at its end)."""
        if nodes is None:
            return
        self._hold(nodes)
        self.control[CONTROL_HISTORY] = 0                 # a jump of the right-hand side: restart ABM4
        if self.time == 0.0 and self.counters[ACCEPTED] + self.counters[REJECTED] == 0:
            self.state[:] = self._nominal_state(self.state[ANGLE], self.state[ANGULAR_VELOCITY])
            self._start_outputs()

    def _hold(self, nodes: Boundary) -> None:
        """Hold `nodes` and refer the per-revolution figures to them (unless they are the ones held)."""
        if nodes == self.boundary and ramp_duration(self.gas.chambers) == 0.0:
            return
        hold_boundary(self.gas, nodes)
        self._refer_figures(nodes)

    def _refer_figures(self, nodes: Boundary) -> None:
        """Refer the per-revolution figures to the boundary `nodes` (held, or reached at the end of a ramp)."""
        if self.gas.reference is not None:
            self.gas_reference = (self.gas.reference if nodes == self._initial_boundary else
                                  moved_reference(self.gas.reference, self.gas, nodes))

    def _boundary_for_advance(self, end_time: float, nodes: Boundary | None, interpolate: bool) -> None:
        """The boundary over an advance to end_time: the new nodes held from now on, or (interpolate) every node
        field moved linearly from its value now to the new one at end_time, as the speed (docs/model.md §7.3.3)."""
        if not (interpolate and end_time > self.time and nodes is not None):
            self._hold_nodes(nodes)
            return
        now = Boundary(*boundary_nodes(self.gas.chambers[0], self.time))      # the boundary of the moment
        ramp_boundary(self.gas, now, nodes, self.time, end_time - self.time)
        self.control[CONTROL_HISTORY] = 0                 # a kink of the right-hand side: restart ABM4
        self._refer_figures(nodes)

    # time loop ----------------------------------------------------------------------------------------
    def advance(self, end_time: float, speed_rpm: float | None = None, interpolate: bool = False,
                boundary: dict | None = None) -> None:
        """Integrate to `end_time` [s]. With `speed_rpm`, the speed over this advance is that value held
        (interpolate=False) or moved linearly from the current speed to it (interpolate=True); with `boundary`
        (set_boundary's keywords), the boundary likewise. A boundary the run cannot take raises ValueError naming
        the input before anything changes."""
        if not (isinstance(end_time, (int, float, np.floating)) and math.isfinite(end_time)) \
                or end_time < self.time:
            raise ValueError(f"'end_time' = {end_time!r} s is invalid: allowed a finite time >= the current time "
                             f"{self.time!r} s")
        nodes = None if boundary is None else solve_boundary(self.params, self.gas, self.boundary, **boundary)
        key = self._grid_key(float(end_time))          # of the state before the input acts on it
        if speed_rpm is not None:
            self._speed_for_advance(float(end_time), speed_rpm, interpolate)
        if boundary is not None:
            self._boundary_for_advance(float(end_time), nodes, interpolate)
        if end_time == self.time:
            return
        replayed = self._start_grid(key)
        start, budget = self.time, work_bound(end_time - self.time, self.work_per_ms)
        attempts = self._attempts()
        while True:
            if self.gas_reference is not None:
                self.gas.flow_work["refused_time"] = math.nan      # no refused evaluation in this call yet
            status, t, rows, records = run(
                self.time, float(end_time), self.state, self.memory, self.control, self.abm_history, self.window,
                self.run_dwell, self._work, self._outs, self._rows, self.keep_history, self._record_buffer,
                self.counters, budget - (self._attempts() - attempts), self._grid, self._recorded_grid,
                self._grid_counts, *self._kernel_context())
            self.time = t
            if rows:
                last = self._rows[rows - 1] if self.keep_history else self._rows[0]
                self.last_output[:] = last
                if self.keep_history:
                    self._chunks.append(self._rows[:rows].copy())
            if records:
                self._take_records(self._record_buffer[:records])
            self._note_law_excess(records)
            if status == REACHED_END:
                self._finish_grid(key, replayed)
                return
            if status == WORK_LIMIT:
                raise IntegrationError(f"{self._failure_text(status)}: {budget} attempts for the "
                                       f"{end_time - start:.6g} s from t = {start!r} s to {end_time!r} s reached "
                                       f"only t = {t!r} s, with the step size {self.control[CONTROL_STEP]!r} s",
                                       t, self.state)
            if status != RECORD_FULL:
                raise IntegrationError(self._failure_text(status), t, self.state)

    # step-grid replay (docs/model.md §8.2) ------------------------------------------------------------------
    def _grid_key(self, end_time: float) -> bytes | None:
        """The replay key of an advance to `end_time` from the current state: a hash of the time, the state, the
        memory and the step control (not the speed law: the input may differ between replays), or None if this
        method does not follow grids."""
        if self.params.integrator not in GRID_METHODS:
            return None
        digest = hashlib.blake2b(np.array([self.time, end_time]).tobytes(), digest_size=16)
        for values in (self.state, self.memory, self.control):
            digest.update(values.tobytes())
        return digest.digest()

    def _start_grid(self, key: bytes | None) -> bool:
        """Load the grid recorded from this start, if any (then the advance replays it); returns whether it did."""
        counts = self._grid_counts
        counts[:] = 0
        grid = self._grids.get(key) if key is not None else None
        if grid is not None:
            self._grid[:len(grid[0])] = grid[0]
            counts[GRID_FOLLOW] = len(grid[0])
        return grid is not None

    def _finish_grid(self, key: bytes | None, replayed: bool) -> None:
        """Keep the grid of an adaptive advance (the latest KEPT_GRIDS); after a replay that held, end with the step
        control the recorded advance ended with, so the state after the step does not depend on the replay."""
        counts = self._grid_counts
        if key is None:
            return
        if replayed:
            if counts[GRID_FELL_BACK]:
                self.replay_fallbacks += 1
            else:
                self.control[:] = self._grids[key][1]
            return
        if counts[GRID_RECORDED] <= GRID_CAPACITY:
            self._grids[key] = (self._recorded_grid[:counts[GRID_RECORDED]].copy(), self.control.copy())
            while len(self._grids) > KEPT_GRIDS:
                del self._grids[next(iter(self._grids))]

    def _attempts(self) -> int:
        """Step attempts so far: accepted, rejected and redone to land on a contact event."""
        return int(self.counters[ACCEPTED] + self.counters[REJECTED] + self.counters[EVENT_RETRIES])

    def _take_records(self, records: np.ndarray) -> None:
        """Keep the new lobe records (all of them with the history; in any case the last 2z - 1, which hold the
        last completed revolution) and summarise the revolution they complete, if any."""
        lobes = self.params.lobes
        if self.keep_history:
            self._records.append(records.copy())
        candidates = np.concatenate([self.recent_records, records])
        self.recent_records = candidates[-(2 * lobes - 1):]        # always holds the last complete revolution
        groups = revolution_groups(candidates, lobes)
        if groups and (self.last_revolution is None or groups[-1][-1, 0] != self._last_revolution_lobe):
            self._last_revolution_lobe = groups[-1][-1, 0]
            self.last_revolution = summarise_records(groups[-1], self.params.rotor_inertia,
                                                     self.params.mode_dwell_time, self.gas_reference)

    _last_revolution_lobe = -1.0

    def _note_law_excess(self, records: int) -> None:
        """Update contact_law_excess from the new lobe records and the open window; warn the first time."""
        excess = self.window[WINDOW_ACCUMULATORS + ACC_LAW_EXCESS]
        if records:
            excess = max(excess, self._record_buffer[:records, RECORD_ACCUMULATORS + ACC_LAW_EXCESS].max())
        if excess > self.contact_law_excess:
            if self.contact_law_excess == 0.0 and self.warn_contact_law:
                warnings.warn(self.law_excess_text(excess), ContactLawWarning, stacklevel=3)
            self.contact_law_excess = float(excess)

    def law_excess_text(self, excess: float) -> str:
        return (f"a contact penetrated {excess:.3g} m beyond the validity limit of the '{self.params.stiffness_model}' "
                f"force law by t = {self.time:.6g} s; the force continues along the law's tangent (docs/model.md "
                f"§5.2). Contact forces beyond the limit are an extrapolation")

    def _failure_text(self, status: int) -> str:
        """Why the loop stopped; for a chamber state the tables refused, first what the chamber pressures say of the
        ports (the remedy, which a host that shortens long messages keeps), then which chamber, its state and why:
        the failed step attempt's (mechanics.gas.refused_state), else (a stop at the valley switch) the last
        accepted."""
        text = STATUS_TEXT[status]
        if status == GAS_STATE_INVALID and self.gas_reference is not None:
            text += self._port_hint()
            chambers = (("leading", LEADING_TEMPERATURE, LEADING_MASS), ("trailing", TRAILING_TEMPERATURE, TRAILING_MASS))
            accepted = [(name, self.state[GAS_BLOCK + temperature],
                         self.state[GAS_BLOCK + mass] / self.last_output[OUTPUT_INDEX[f"{name}_volume"]])
                        for name, temperature, mass in chambers]
            text += refused_state_text(self.gas.flow_work[0], accepted, table_from_arrays(*self.gas.properties),
                                       nozzle_table_from_arrays(*self.gas.nozzles),
                                       Fluid(self.gas_reference.point.coolprop_name), int(self.memory[MEM_LOBE_COUNT]),
                                       self.boundary.suction.pressure, self.boundary.back.pressure)
        return text

    def _port_hint(self) -> str:
        """What the chamber pressures of the last accepted step say about a state that left the table: a leading
        chamber far above discharge pressure behind a port that cannot pass the displaced gas at this speed, or a
        trailing chamber starved by the suction port."""
        p = self.params
        leading = self.last_output[OUTPUT_INDEX["leading_pressure"]]
        trailing = self.last_output[OUTPUT_INDEX["trailing_pressure"]]
        suction_pressure, discharge_pressure = self.boundary.suction.pressure, self.boundary.back.pressure
        rpm = self.rotor_speed * 30.0 / math.pi
        text = (f"; at the last accepted step (t = {self.time:.6g} s, {rpm:.6g} rpm) p_L = {leading:.4g} Pa "
                f"({leading / discharge_pressure:.3g} x discharge_pressure) and p_T = {trailing:.4g} Pa "
                f"({trailing / suction_pressure:.3g} x suction_pressure)")
        if leading > 1.5 * discharge_pressure:
            text += (f": the discharge port (discharge_port_area = {p.discharge_port_area:g} m2, "
                     f"discharge_port_coefficient = {p.discharge_port_coefficient:g}) cannot pass the displaced gas "
                     f"at this speed; lower the speed or enlarge the port (docs/model.md §7.4)")
        elif trailing < 0.5 * suction_pressure:
            text += (f": the suction port (suction_port_area = {p.suction_port_area:g} m2) starves the chamber at "
                     f"this speed; lower the speed or enlarge the port (docs/model.md §7.4)")
        return text

    def evaluate(self, t: float, state: np.ndarray, memory: np.ndarray | None = None):
        """The right-hand side at (t, state) with this run's constants and speed law: (kernel status, dy/dt, output
        row as a dict). `memory` defaults to the run's current memory (docs/model.md §8.1)."""
        state = np.asarray(state, dtype=np.float64)
        if state.shape != self.state.shape:
            raise ValueError(f"'state' has shape {state.shape}: allowed {self.state.shape} (mechanics.loop.layout)")
        rates = np.zeros(state.size)
        out = np.full(OUTPUT_SIZE, np.nan)
        status = evaluate_state(float(t), state.copy(), (self.memory if memory is None else memory).copy(), out,
                                rates, *self._kernel_context())
        return status, rates, dict(zip(OUTPUT_NAMES, out.tolist()))

    # results ------------------------------------------------------------------------------------------
    @property
    def outputs(self) -> dict[str, float]:
        """The output row of the last accepted step (the initial state's before the first step)."""
        return dict(zip(OUTPUT_NAMES, self.last_output.tolist()))

    @property
    def history(self) -> History:
        """All recorded accepted steps so far."""
        if len(self._chunks) > 1:
            self._chunks = [np.concatenate(self._chunks)]
        return History(self._chunks[0] if self._chunks else np.empty((0, OUTPUT_SIZE)))

    @property
    def lobe_records(self) -> np.ndarray:
        """Every lobe record so far (mechanics.loop.windows layout), or the last 2z - 1 without the history."""
        if not self.keep_history:
            return self.recent_records
        if len(self._records) > 1:
            self._records = [np.concatenate(self._records)]
        return self._records[0] if self._records else np.empty((0, RECORD_SIZE))

    def clear_history(self) -> None:
        """Forget recorded steps and lobe records (the state, the last output and the last revolution are kept)."""
        self._chunks = []
        self._records = []

    @property
    def rotor_angle(self) -> float:
        return rotor_motion(self.time, self.speed_law)[0]

    @property
    def rotor_speed(self) -> float:
        return rotor_motion(self.time, self.speed_law)[1]

    # save / restore ---------------------------------------------------------------------------------------
    def get_state(self) -> SimulationState:
        """A copy of everything the continuation depends on (the recent lobe records are shared: that array is
        replaced when records arrive, never changed in place)."""
        return SimulationState(self.time, *(self.recent_records if name == "recent_records" else
                                            np.array(getattr(self, name), copy=True) for name in ARRAY_FIELDS))

    @property
    def boundary_nodes(self) -> np.ndarray:
        """The boundary nodes held, as one array (suction node, then back node: FlowNode fields); an advance ends
        every ramp it starts, so between advances this is the whole boundary."""
        return np.array([*self.boundary.suction, *self.boundary.back])

    def set_state(self, saved: SimulationState) -> None:
        """Continue from a state returned by `get_state` (the history is not rewound)."""
        self.time = saved.time
        for name in ARRAY_FIELDS:
            if name == "recent_records":
                self.recent_records = np.asarray(saved.recent_records, dtype=np.float64)
            elif name == "boundary_nodes":
                self._hold(Boundary(FlowNode(*saved.boundary_nodes[:4].tolist()),
                                    FlowNode(*saved.boundary_nodes[4:].tolist())))
            else:
                getattr(self, name)[...] = getattr(saved, name)
        groups = revolution_groups(self.recent_records, self.params.lobes)
        self.last_revolution = (summarise_records(groups[-1], self.params.rotor_inertia, self.params.mode_dwell_time,
                                                  self.gas_reference) if groups else None)
        self._last_revolution_lobe = groups[-1][-1, 0] if groups else -1.0
