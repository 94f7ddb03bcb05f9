"""`Simulation`: owns all state of one compressor run and advances it in time (docs/model.md §8.1, ARCHITECTURE "State").

Build it from validated parameters and a speed law, call `advance(t)` as often as needed (optionally with a new
speed for the advance, as an FMU does once per communication step), and read `outputs`, `history` and the
per-revolution summaries. All arrays the compiled loop needs live here, so saving and restoring a run is a copy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rotary_vane.thermo.property_table import describe_status, table_status

from .displacement import displacement
from .errors import IntegrationError
from .geometry import law_arguments
from .dynamics import evaluate
from .integrators import (ABM_HISTORY, CONTROL_HISTORY, CONTROL_SIZE, CONTROL_STEP, COUNTER_SIZE, advance_abm4,
                          advance_dopri5)
from .layout import (MEM_LOBE_COUNT, GAS_STATE_INVALID, LEADING_DENSITY, LEADING_TEMPERATURE, REAL_GAS_STATE_SIZE, TRAILING_DENSITY,
                     TRAILING_TEMPERATURE, ANGLE, ANGULAR_VELOCITY, MEM_LOBE_START, MEMORY_SIZE,
                     OUTPUT_INDEX, OUTPUT_NAMES, OUTPUT_SIZE, REACHED_END, RECORD_FULL, STATE_SIZE, STATUS_TEXT, VX,
                     VY, WORK_IN, X, Y)
from .gas_source import gas_source
from .machine import machine_from_parameters
from .parameters import CompressorParameters
from .speed import SpeedLaw, check_speed, constant_speed, rotor_motion

RECORD_CHUNK = 4096


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
    """A full copy of everything the run depends on (for save/restore)."""
    time: float
    state: np.ndarray
    memory: np.ndarray
    control: np.ndarray
    abm_history: np.ndarray
    speed_law: np.ndarray
    last_output: np.ndarray
    counters: np.ndarray


class Simulation:
    """One compressor run under a speed input.

    params: validated `CompressorParameters` (defaults of docs/model.md §9 if omitted).
    speed: a `SpeedLaw` from t = 0 (default constant 1500 rpm).
    initial_angle: rotor angle theta0 at t = 0 [rad]; docs/model.md §3.3 uses 0.02 for constant speed, 0 for start-up.
    keep_history: record every accepted step (needed for plots and revolution summaries).
    table_speed_rpm: operating speed of the Level 0.5 pressure table (default: the speed law's target).
    observers: callables given the output row of the initial state (t = 0, not part of the history), then each
        chunk of accepted output rows as it is produced (they copy what they keep); a per-revolution monitor thus
        sees the start as a boundary when the run starts on one.
    """

    def __init__(self, params: CompressorParameters | None = None, speed: SpeedLaw | None = None,
                 initial_angle: float = 0.02, keep_history: bool = True, table_speed_rpm: float | None = None,
                 observers=()):
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
        self.gas, suction_gas, self.gas_reference = gas_source(self.params, operating_speed)
        self.machine = machine_from_parameters(self.params, suction_gas)
        self.keep_history = keep_history
        self.observers = list(observers)
        self.time = 0.0
        self.speed_law = speed.segment(0.0, float(initial_angle))
        self.state = self._nominal_state(float(initial_angle), rotor_motion(0.0, self.speed_law)[1])
        self.memory = np.zeros(MEMORY_SIZE)
        lobe = 2.0 * math.pi / self.params.lobes
        self.memory[MEM_LOBE_START] = math.floor(initial_angle / lobe) * lobe
        self.control = np.zeros(CONTROL_SIZE)
        self.control[CONTROL_STEP] = self.params.initial_step
        self.abm_history = np.zeros((ABM_HISTORY, self.state.size))
        self.counters = np.zeros(COUNTER_SIZE, dtype=np.int64)
        self._chunks: list[np.ndarray] = []
        self._record = np.empty((RECORD_CHUNK, OUTPUT_SIZE))
        self.last_output = np.full(OUTPUT_SIZE, np.nan)
        if self.observers:
            initial = np.empty((1, OUTPUT_SIZE))
            evaluate(self.time, self.state, self.machine, self.speed_law, self.gas, self.memory.copy(),
                     np.empty(self.state.size), initial[0])
            for observer in self.observers:
                observer(initial)

    def _nominal_state(self, angle: float, omega: float) -> np.ndarray:
        """Nominal pose and velocity (docs/model.md §3.3): untilted, centred, tip centre at R0 + s + c_S."""
        p = self.params
        s, ds, _, _ = displacement(angle, *law_arguments(p)[:5])
        radius = p.base_radius + s + p.stator_clearance
        tip_centre = self.machine.tip_centre
        e_r = np.array([math.cos(angle), math.sin(angle)])
        e_t = np.array([-e_r[1], e_r[0]])
        centre = (radius - tip_centre) * e_r
        velocity = ds * omega * e_r + (radius - tip_centre) * omega * e_t
        real_gas = p.pressure_model == "real_gas"
        y = np.zeros(REAL_GAS_STATE_SIZE if real_gas else STATE_SIZE)
        y[X], y[Y], y[ANGLE] = centre[0], centre[1], angle
        y[VX], y[VY], y[ANGULAR_VELOCITY] = velocity[0], velocity[1], omega
        if real_gas:                                # both chambers start at the suction state (docs/model.md §7.2)
            y[LEADING_TEMPERATURE] = y[TRAILING_TEMPERATURE] = p.suction_temperature
            y[LEADING_DENSITY] = y[TRAILING_DENSITY] = self.machine.suction_density
        return y

    # speed input ----------------------------------------------------------------------------------------
    def set_speed(self, speed: SpeedLaw) -> None:
        """Follow `speed` from the current time and angle on (a ramp starts from its own start_rpm)."""
        theta = rotor_motion(self.time, self.speed_law)[0]
        self.speed_law = speed.segment(self.time, theta)
        self.control[CONTROL_HISTORY] = 0          # a new law is a non-smooth point: restart ABM4

    def _speed_for_advance(self, end_time: float, speed_rpm: float, interpolate: bool) -> None:
        omega_target = check_speed("speed_rpm", speed_rpm)
        theta, omega, _ = rotor_motion(self.time, self.speed_law)
        if interpolate and end_time > self.time:
            law = np.array([1.0, self.time, theta, omega, omega_target, end_time - self.time])
        else:
            law = np.array([0.0, self.time, theta, omega_target, omega_target, 0.0])
            # a held speed jumps: the motor delivers the rotor's kinetic energy 1/2 J2 (w2^2 - w1^2) at once
            self.state[WORK_IN] += 0.5 * self.params.rotor_inertia * (omega_target ** 2 - omega ** 2)
        if not np.array_equal(law[[0, 3, 4]], self.speed_law[[0, 3, 4]]) or interpolate:
            self.speed_law = law
            self.control[CONTROL_HISTORY] = 0

    # time loop ----------------------------------------------------------------------------------------
    def advance(self, end_time: float, speed_rpm: float | None = None, interpolate: bool = False) -> None:
        """Integrate to `end_time` [s]. With `speed_rpm`, the speed over this advance is that value held
        (interpolate=False) or moved linearly from the current speed to it (interpolate=True)."""
        if not (isinstance(end_time, (int, float, np.floating)) and math.isfinite(end_time)) \
                or end_time < self.time:
            raise ValueError(f"'end_time' = {end_time!r} s is invalid: allowed a finite time >= the current time "
                             f"{self.time!r} s")
        if speed_rpm is not None:
            self._speed_for_advance(float(end_time), speed_rpm, interpolate)
        if end_time == self.time:
            return
        method_abm4 = self.params.integrator == "abm4"
        while True:
            if method_abm4:
                status, t, rows = advance_abm4(self.time, self.state, float(end_time), self.machine,
                                               self.speed_law, self.gas, self.memory, self.control,
                                               self.abm_history, self._record, self.counters)
            else:
                status, t, rows = advance_dopri5(self.time, self.state, float(end_time), self.machine,
                                                 self.speed_law, self.gas, self.memory, self.control,
                                                 self._record, self.counters)
            self.time = t
            if rows:
                self.last_output = self._record[rows - 1].copy()
                if self.keep_history:
                    self._chunks.append(self._record[:rows].copy())
                for observer in self.observers:
                    observer(self._record[:rows])
            if status == REACHED_END:
                return
            if status != RECORD_FULL:
                raise IntegrationError(self._failure_text(status), t, self.state)

    def _failure_text(self, status: int) -> str:
        """Why the loop stopped; for a chamber state the table refused, which chamber, its state and why."""
        text = STATUS_TEXT[status]
        if status == GAS_STATE_INVALID:
            for name, temperature, density in (("leading", LEADING_TEMPERATURE, LEADING_DENSITY),
                                               ("trailing", TRAILING_TEMPERATURE, TRAILING_DENSITY)):
                code = table_status(self.state[temperature], self.state[density], self.gas.properties)
                if code != 0:
                    text += "; " + describe_status(code, self.state[temperature], self.state[density],
                                                   self.gas.properties, fluid=self.gas_reference.fluid,
                                                   state=f"{name} chamber (lobe {int(self.memory[MEM_LOBE_COUNT])})")
        return text

    # results ------------------------------------------------------------------------------------------
    @property
    def outputs(self) -> dict[str, float]:
        """The output row of the last accepted step (NaN before the first step)."""
        return dict(zip(OUTPUT_NAMES, self.last_output.tolist()))

    @property
    def history(self) -> History:
        """All recorded accepted steps so far."""
        if len(self._chunks) > 1:
            self._chunks = [np.concatenate(self._chunks)]
        return History(self._chunks[0] if self._chunks else np.empty((0, OUTPUT_SIZE)))

    def clear_history(self) -> None:
        """Forget recorded steps (the state and the last output are kept)."""
        self._chunks = []

    @property
    def rotor_angle(self) -> float:
        return rotor_motion(self.time, self.speed_law)[0]

    @property
    def rotor_speed(self) -> float:
        return rotor_motion(self.time, self.speed_law)[1]

    # save / restore ---------------------------------------------------------------------------------------
    def get_state(self) -> SimulationState:
        """A deep copy of everything the continuation depends on."""
        return SimulationState(self.time, self.state.copy(), self.memory.copy(), self.control.copy(),
                               self.abm_history.copy(), self.speed_law.copy(), self.last_output.copy(),
                               self.counters.copy())

    def set_state(self, saved: SimulationState) -> None:
        """Continue from a state returned by `get_state` (the history is not rewound)."""
        self.time = saved.time
        for name in ("state", "memory", "control", "abm_history", "speed_law", "last_output", "counters"):
            getattr(self, name)[...] = getattr(saved, name)

