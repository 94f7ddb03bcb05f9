"""The compressor FMU's model state as plain data: the `Simulation` state and the per-revolution monitor.

`snapshot` is taken before every communication step (to restore it if the step fails) and by fmi2GetFMUstate, so it
is cheap: the simulation's arrays are copied (a few kB), the monitor's buffered rows of the current revolution
are shared, not copied (the monitor appends new arrays and never changes a buffered one). `serializable` makes the
bytes of fmi2SerializeFMUstate small: of the buffered rows only the columns the revolution summary reads over the
whole window are kept (docs/model.md §6.4: time, stator and gap moments, normal forces, contact mode, vane tilt),
and the first row in full (the summary's differences start there); the other columns of the other rows are never
read and come back as NaN.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from rotary_vane.mechanics.layout import OUTPUT_INDEX, OUTPUT_SIZE
from rotary_vane.mechanics.performance import RevolutionMonitor, WindowSummary
from rotary_vane.mechanics.simulation import SimulationState

SIMULATION_ARRAYS = [f.name for f in dataclasses.fields(SimulationState) if f.name != "time"]
WINDOW_COLUMNS = ("time", "stator_contact_moment", "stator_gas_moment", "gap_moment",
                  *(f"normal_force_{k}" for k in range(1, 7)), "contact_mode", "vane_tilt")


def simulation_state(simulation) -> dict:
    saved = simulation.get_state()
    return {name: getattr(saved, name) for name in ("time", *SIMULATION_ARRAYS)}


def restore_simulation(simulation, state: dict) -> None:
    """Set a saved state into `simulation`, which must have been built with the same parameters (ValueError if an
    array does not match the simulation's shape and type)."""
    arrays = {}
    for name in SIMULATION_ARRAYS:
        current, saved = getattr(simulation, name), np.asarray(state[name])
        if saved.shape != current.shape or saved.dtype != current.dtype:
            raise ValueError(f"saved array '{name}' has shape {saved.shape} {saved.dtype}, the model needs "
                             f"{current.shape} {current.dtype}")
        arrays[name] = saved
    simulation.set_state(SimulationState(time=float(state["time"]), **arrays))


def monitor_state(monitor: RevolutionMonitor) -> dict:
    """The monitor's state; its last summary is shared too (the monitor replaces it, never changes it), `compact`
    makes it plain data."""
    return dict(pending=list(monitor.pending), last_boundary=monitor.last_boundary, last=monitor.last,
                run_dwell=monitor.run_dwell.copy(),
                previous_row=None if monitor.previous_row is None else monitor.previous_row.copy())


def restore_monitor(params, state: dict) -> RevolutionMonitor:
    monitor = RevolutionMonitor(params)
    run_dwell = np.array(state["run_dwell"], dtype=float)
    if run_dwell.shape != monitor.run_dwell.shape:
        raise ValueError(f"saved run_dwell has shape {run_dwell.shape}, the monitor needs {monitor.run_dwell.shape}")
    monitor.pending = _expand_pending(state["pending"])
    monitor.last_boundary = None if state["last_boundary"] is None else int(state["last_boundary"])
    last = state["last"]
    monitor.last = last if last is None or isinstance(last, WindowSummary) else _summary_from_state(last)
    monitor.run_dwell = run_dwell
    monitor.previous_row = None if state["previous_row"] is None else np.array(state["previous_row"], dtype=float)
    return monitor


def compact(state: dict) -> dict:
    """`monitor_state` as plain data, its buffered rows reduced to what the revolution summary reads."""
    state = {**state, "last": None if state["last"] is None else _summary_state(state["last"])}
    pending = state["pending"]
    if not isinstance(pending, list) or not pending:
        return state
    rows = np.concatenate(pending)
    columns = [OUTPUT_INDEX[name] for name in WINDOW_COLUMNS]
    return {**state, "pending": dict(first=rows[0].copy(), columns=list(WINDOW_COLUMNS),
                                     rows=np.ascontiguousarray(rows[1:, columns]))}


def _expand_pending(pending) -> list[np.ndarray]:
    if isinstance(pending, list):
        arrays = [np.array(rows, dtype=float) for rows in pending]
        if any(rows.ndim != 2 or rows.shape[1] != OUTPUT_SIZE for rows in arrays):
            raise ValueError(f"saved revolution rows are not of width {OUTPUT_SIZE}")
        return arrays
    first, names, kept = (np.array(pending["first"], dtype=float), list(pending["columns"]),
                          np.array(pending["rows"], dtype=float))
    if first.shape != (OUTPUT_SIZE,) or kept.ndim != 2 or kept.shape[1] != len(names) \
            or not set(names) <= set(OUTPUT_INDEX):
        raise ValueError("saved revolution rows do not match the model's output layout")
    rows = np.full((kept.shape[0] + 1, OUTPUT_SIZE), np.nan)
    rows[0] = first
    rows[1:, [OUTPUT_INDEX[name] for name in names]] = kept
    return [rows]


def _summary_state(summary: WindowSummary) -> dict:
    fields = {f.name: getattr(summary, f.name) for f in dataclasses.fields(summary)}
    fields["mode_dwell"] = {str(int(mask)): float(dwell) for mask, dwell in summary.mode_dwell.items()}
    fields["distinct_modes"] = [int(mask) for mask in summary.distinct_modes]
    fields["max_normal_force"] = [float(force) for force in summary.max_normal_force]
    return fields


def _summary_from_state(fields: dict) -> WindowSummary:
    names = {f.name for f in dataclasses.fields(WindowSummary)}
    if set(fields) != names:
        raise ValueError(f"saved revolution summary has fields {sorted(fields)[:5]}..., expected {sorted(names)[:5]}...")
    values = {name: float(value) if isinstance(value, (int, float)) else value for name, value in fields.items()}
    values["mode_dwell"] = {int(mask): float(dwell) for mask, dwell in fields["mode_dwell"].items()}
    values["distinct_modes"] = tuple(int(mask) for mask in fields["distinct_modes"])
    values["max_normal_force"] = tuple(float(force) for force in fields["max_normal_force"])
    return WindowSummary(**values)
