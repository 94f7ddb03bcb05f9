"""Per-revolution and per-lobe means, efficiency, energy and torque balances, peak forces and modes (docs/model.md §4.6, §6.4).

All means are exact work differences: the work integrals are states, and the time loop lands on every valley
(every 2 pi / z of rotor angle), so revolution and lobe boundaries are recorded rows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .modes import MODE_COUNT, distinct_modes, mode_dwell, mode_dwell_array
from .layout import OUTPUT_INDEX
from .simulation import History

BOUNDARY_TOLERANCE = 1e-7       # rad: a recorded row this close to a multiple of the period is a boundary


@dataclass(frozen=True)
class WindowSummary:
    """Figures over one window [start_time, end_time] of whole lobes or revolutions."""
    start_time: float
    end_time: float
    input_power: float            # <P_in> [W]
    output_power: float           # <P_out> [W]
    friction_power: float         # <P_fric> [W]
    damping_power: float          # <P_damp> [W]
    mechanical_efficiency: float  # eta_m = <P_out>/<P_in>
    energy_residual: float        # (W_in - W_out - W_fric - W_damp - dKE - dPE - J2 int(omega theta_ddot)) / W_in
    driving_torque: float         # <T_d> = W_in / angle turned [N m]
    stator_torque: float          # <lambda3 + M_gas,stator>, trapezoidal mean [N m]
    gap_torque: float             # <M_gap>, pressure moment on the gaps no body carries [N m]
    max_normal_force: tuple       # max F_n per region c1..c6 [N]
    max_tilt: float               # max |phi3 - theta| [rad]
    mode_dwell: dict              # mode mask -> cumulative dwell [s]
    distinct_modes: tuple         # masks with dwell >= tau_min
    # chamber gas (Level 1; NaN for the pressure tables), docs/model.md §6.4, §7
    suction_mass_flow: float = math.nan     # net mass from the suction side / duration [kg/s]
    discharge_mass_flow: float = math.nan   # mass through the discharge valve / duration [kg/s]
    discharge_enthalpy: float = math.nan    # mass-weighted enthalpy of the discharged gas [J/kg]
    indicated_power: float = math.nan       # <-sum_chambers p dV/dt> [W]
    gas_mass_residual: float = math.nan     # (dm_chambers - m_suction + m_discharge) / m_discharge
    gas_energy_residual: float = math.nan   # (dU_chambers - E_suction + E_discharge - W_chambers) / W_chambers

    @property
    def torque_balance_error(self) -> float:
        """|<T_d> - <lambda3 + M_gas,stator>| / |<T_d>| (docs/model.md §11 T11)."""
        return abs(self.driving_torque - self.stator_torque) / abs(self.driving_torque)

    @property
    def torque_balance_error_with_gaps(self) -> float:
        """|<T_d> - <lambda3 + M_gas,stator + M_gap>| / |<T_d>|: the balance with every pressure boundary."""
        return abs(self.driving_torque - self.stator_torque - self.gap_torque) / abs(self.driving_torque)


def boundary_rows(history: History, period: float) -> np.ndarray:
    """Indices of the recorded rows at rotor angles that are whole multiples of `period` (one per multiple: the
    first row that reaches it, which is the valley event row; a slow start can leave many rows near theta = 0)."""
    angle = history["rotor_angle"]
    multiple = np.round(angle / period)
    near = np.abs(angle - multiple * period) < BOUNDARY_TOLERANCE
    candidates = np.flatnonzero(near)
    if candidates.size == 0:
        return candidates
    first_of_multiple = np.concatenate([[True], np.diff(multiple[candidates]) != 0])
    return candidates[first_of_multiple]


def summarise(history: History, first: int, last: int, rotor_inertia: float, min_dwell: float) -> WindowSummary:
    """WindowSummary between recorded rows `first` and `last` (inclusive)."""
    col = history.__getitem__
    window = slice(first, last + 1)
    time = col("time")[window]
    duration = time[-1] - time[0]
    work = {name: col(name)[last] - col(name)[first]
            for name in ("work_in", "work_out", "work_friction", "work_damping")}
    omega = col("rotor_speed")
    kinetic = col("kinetic_energy")[last] - col("kinetic_energy")[first]
    elastic = col("contact_energy")[last] - col("contact_energy")[first]
    rotor = 0.5 * rotor_inertia * (omega[last] ** 2 - omega[first] ** 2)
    residual = (work["work_in"] - work["work_out"] - work["work_friction"] - work["work_damping"] - kinetic
                - elastic - rotor)
    angle_turned = col("rotor_angle")[last] - col("rotor_angle")[first]
    stator = col("stator_contact_moment")[window] + col("stator_gas_moment")[window]
    stator_mean = float(np.trapezoid(stator, time) / duration)
    gap_mean = float(np.trapezoid(col("gap_moment")[window], time) / duration)
    forces = tuple(float(np.max(col(f"normal_force_{k}")[window])) for k in range(1, 7))
    dwell = mode_dwell(time, col("contact_mode")[window])
    gas = _gas_figures(history, first, last, duration)
    return WindowSummary(
        start_time=float(time[0]), end_time=float(time[-1]),
        input_power=work["work_in"] / duration, output_power=work["work_out"] / duration,
        friction_power=work["work_friction"] / duration, damping_power=work["work_damping"] / duration,
        mechanical_efficiency=work["work_out"] / work["work_in"],
        energy_residual=residual / work["work_in"],
        driving_torque=work["work_in"] / angle_turned, stator_torque=stator_mean, gap_torque=gap_mean,
        max_normal_force=forces, max_tilt=float(np.max(np.abs(col("vane_tilt")[window]))),
        mode_dwell=dwell, distinct_modes=tuple(distinct_modes(dwell, min_dwell)), **gas)


def _gas_figures(history: History, first: int, last: int, duration: float) -> dict:
    """Level 1 flow, enthalpy and work figures of a window, and its mass and energy balance residuals (docs/model.md §11
    T19): the chamber contents change by what crossed their boundary."""
    change = {name: history[name][last] - history[name][first]
              for name in ("chamber_mass", "chamber_internal_energy", "mass_suction", "mass_discharge",
                           "energy_suction", "energy_discharge", "work_chambers")}
    if not math.isfinite(change["mass_discharge"]):
        return {}
    delivered = change["mass_discharge"]
    return dict(
        suction_mass_flow=change["mass_suction"] / duration, discharge_mass_flow=delivered / duration,
        discharge_enthalpy=change["energy_discharge"] / delivered if delivered > 0.0 else math.nan,
        indicated_power=change["work_chambers"] / duration,
        gas_mass_residual=(change["chamber_mass"] - change["mass_suction"] + delivered) / delivered
        if delivered > 0.0 else math.nan,
        gas_energy_residual=(change["chamber_internal_energy"] - change["energy_suction"]
                             + change["energy_discharge"] - change["work_chambers"]) / change["work_chambers"])


def windows(history: History, period: float, rotor_inertia: float, min_dwell: float) -> list[WindowSummary]:
    """Summaries of every complete window of `period` rad of rotor angle in the history."""
    rows = boundary_rows(history, period)
    return [summarise(history, a, b, rotor_inertia, min_dwell) for a, b in zip(rows[:-1], rows[1:])]


def revolutions(simulation) -> list[WindowSummary]:
    """Per-revolution summaries of a simulation's recorded history (docs/model.md §6.4)."""
    p = simulation.params
    return windows(simulation.history, 2.0 * math.pi, p.rotor_inertia, p.mode_dwell_time)


def lobes(simulation) -> list[WindowSummary]:
    """Per-lobe summaries (2 pi / z of rotor angle each), for the z-fold periodicity check (docs/model.md §11 T13)."""
    p = simulation.params
    return windows(simulation.history, 2.0 * math.pi / p.lobes, p.rotor_inertia, p.mode_dwell_time)


class RevolutionMonitor:
    """Per-revolution figures while a run goes on, without keeping its history (what an FMU reports).

    Give it to a Simulation as an observer: it buffers the rows of the current revolution only, summarises each
    revolution as it completes (`last`), and keeps the dwell of every contact mode over the whole run.
    """

    def __init__(self, params):
        self.period = 2.0 * math.pi
        self.rotor_inertia = params.rotor_inertia
        self.min_dwell = params.mode_dwell_time
        self.pending: list[np.ndarray] = []       # rows since the last revolution boundary (boundary row first)
        self.last_boundary: int | None = None      # multiple of the period of that boundary
        self.last: WindowSummary | None = None     # the last completed revolution
        self.run_dwell = np.zeros(MODE_COUNT)      # dwell per mode mask over the whole run [s]
        self.previous_row: np.ndarray | None = None

    def __call__(self, rows: np.ndarray) -> None:
        rows = np.array(rows)                      # a copy: the simulation reuses its buffer
        time_and_mode = rows[:, [OUTPUT_INDEX["time"], OUTPUT_INDEX["contact_mode"]]]
        if self.previous_row is not None:
            time_and_mode = np.vstack([self.previous_row, time_and_mode])
        self.run_dwell += mode_dwell_array(time_and_mode[:, 0], time_and_mode[:, 1])
        self.previous_row = time_and_mode[-1]
        angle = rows[:, OUTPUT_INDEX["rotor_angle"]]
        reachable = math.floor(angle[-1] / self.period + BOUNDARY_TOLERANCE)
        start = 0
        if self.last_boundary is None or reachable > self.last_boundary:
            chunk = History(rows)
            for index in boundary_rows(chunk, self.period):
                multiple = round(angle[index] / self.period)
                if multiple == self.last_boundary:
                    continue
                if self.last_boundary is not None:
                    window = History(np.concatenate(self.pending + [rows[start:index + 1]]))
                    self.last = summarise(window, 0, len(window) - 1, self.rotor_inertia, self.min_dwell)
                self.pending = []
                self.last_boundary = multiple
                start = index
        if self.last_boundary is not None:
            self.pending.append(rows[start:])

    @property
    def distinct_modes(self) -> list[int]:
        """Modes whose dwell over the whole run reaches tau_min (docs/model.md §4.6)."""
        return [int(mask) for mask in np.flatnonzero(self.run_dwell >= self.min_dwell)]
