"""The compressor FMU's model state as plain data: the arrays of `mechanics.Simulation`.

`snapshot` is taken before every communication step (to restore it if the step fails) and by fmi2GetFMUstate, so
it is cheap: the simulation's arrays are copied (a few tens of kB), the lobe records of the last revolution are
shared (the simulation replaces that array, it never changes it in place). Everything the FMU reports per
revolution is computed again from those records on restore, so the state holds no derived figures.
"""
from __future__ import annotations

import math

import numpy as np

from ..mechanics.loop.integrators import (ABM_HISTORY, CONTROL_HISTORY, CONTROL_PREVIOUS_ERROR, CONTROL_SIZE,
                                          CONTROL_SMALL_ERRORS, CONTROL_STEP, COUNTER_SIZE, smallest_step)
from ..mechanics.loop.layout import MEMORY_SIZE, REAL_GAS_STATE_SIZE, VANE_STATE_SIZE
from ..mechanics.loop.outputs import OUTPUT_INDEX, OUTPUT_SIZE, STEP_OUTPUTS
from ..mechanics.simulation import ARRAY_FIELDS, SimulationState
from ..mechanics.loop.speed import SHAPES
from ..mechanics.loop.windows import MODE_KEYS, RECORD_SIZE, WINDOW_ACCUMULATORS, WINDOW_SIZE, WINDOW_START

from . import state_schema as schema

SPEED_LAW_SIZE = 6     # mechanics.loop.speed.SpeedLaw.segment: shape, start time, angle, speed, target, duration


def simulation_state(simulation) -> dict:
    saved = simulation.get_state()
    return {name: getattr(saved, name) for name in ("time", *ARRAY_FIELDS)}


def restore_simulation(simulation, state: dict) -> None:
    """Set a saved state into `simulation`, which must have been built with the same parameters (ValueError if an
    array does not match the simulation's shape and type)."""
    arrays = {}
    for name in ARRAY_FIELDS:
        current, saved = getattr(simulation, name), np.asarray(state[name])
        if name == "recent_records":
            valid = saved.ndim == 2 and saved.shape[1] == current.shape[1] and saved.dtype == current.dtype
        else:
            valid = saved.shape == current.shape and saved.dtype == current.dtype
        if not valid:
            raise ValueError(f"saved array '{name}' has shape {saved.shape} {saved.dtype}, the model needs "
                             f"{current.shape} {current.dtype}")
        arrays[name] = saved
    simulation.set_state(SimulationState(time=float(state["time"]), **arrays))


# the schema of the compressor's model state (fmu_src.state_schema), checked before a state read from bytes is used
def _lobes(tree) -> int:
    return tree["model"]["parameters"]["lobes"]


def _state_size(tree) -> int:
    return REAL_GAS_STATE_SIZE if tree["model"]["parameters"]["pressure_model"] == "real_gas" else VANE_STATE_SIZE


def _float_array(*shape, low=-math.inf, high=math.inf):
    return schema.Array("<f8", lambda tree: tuple(size(tree) if callable(size) else size for size in shape), low, high)


SIMULATION = schema.Record({
    "time": schema.Real(0.0, math.inf),
    "state": _float_array(_state_size),
    "memory": _float_array(MEMORY_SIZE),
    "control": _float_array(CONTROL_SIZE, low=0.0),
    "abm_history": _float_array(ABM_HISTORY, _state_size),
    # output rows have undefined (NaN) columns, and a window its whole start row until the first valley when the run
    # started between two (windows.new_window): check_rows checks them
    "window": schema.Array("<f8", lambda tree: (WINDOW_SIZE,), finite=False),
    "run_dwell": _float_array(MODE_KEYS, low=0.0),
    "speed_law": _float_array(SPEED_LAW_SIZE),
    "last_output": schema.Array("<f8", lambda tree: (OUTPUT_SIZE,), finite=False),
    "counters": schema.Array("<i8", lambda tree: (COUNTER_SIZE,), 0, 2 ** 62),
    # the last 2z - 1 lobe records at most (Simulation._take_records); a revolution without gas delivered has
    # undefined (NaN) figures in its records, so these are not checked for finiteness
    "recent_records": schema.Array("<f8", lambda tree: ((None, 2 * _lobes(tree) - 1), RECORD_SIZE), finite=False),
    # the boundary nodes held (mechanics.gas.boundary): T, rho, p, h of the suction node, then of the back node
    "boundary_nodes": _float_array(8),
})
MAP_RUN = schema.Record({name: schema.Real() for name in (
    "time", "angle", "speed_rpm", "work", "acceleration", "suction_pressure", "discharge_pressure", "suction_enthalpy",
    "drawn_mass", "drawn_enthalpy", "delivered_mass", "delivered_enthalpy")})


def undefined_columns(pressure_model: str) -> np.ndarray:
    """Which columns of an output row may be NaN (mechanics.loop.outputs): those the pressure model does not fill, and
    the penetrations and their rates (NaN for a region without a contact candidate)."""
    mask = np.zeros(OUTPUT_SIZE, dtype=bool)
    for output in STEP_OUTPUTS:
        if pressure_model not in output.models or output.name in ("penetration", "penetration_rate"):
            mask[[OUTPUT_INDEX[column] for column in output.columns()]] = True
    return mask


def check_rows(simulation: dict, pressure_model: str) -> None:
    """The last output row and the open lobe window: NaN only where an output row may have no value
    (undefined_columns), or in the whole start row of the window (a run that started between two valleys has none
    until the first valley); everything else finite."""
    undefined = undefined_columns(pressure_model)

    def valid_row(row):
        return np.isfinite(row[~undefined]).all() and not np.isinf(row[undefined]).any()

    window = simulation["window"]
    start = window[WINDOW_START:WINDOW_START + OUTPUT_SIZE]
    for name, valid in (("last_output", valid_row(simulation["last_output"])),
                        ("window", (valid_row(start) or np.isnan(start).all())
                         and np.isfinite(window[WINDOW_ACCUMULATORS:]).all())):
        if not valid:
            raise ValueError(f"state field 'model.simulation.{name}' holds values that are not finite where the "
                             f"{pressure_model} model always has one: allowed NaN only in the columns it leaves "
                             f"undefined{' or in the whole start row' if name == 'window' else ''}")


def check_controls(simulation: dict, machine) -> None:
    """The integrator's controls between advances (mechanics.loop.integrators.advance): the step size finite and within
    what the step-size rules can leave (at most 10 max_step after a DOPRI5 step; a rejection below the smallest step
    16 eps max(|t|, T_c) stops the run), the ABM4 history count and small-error count in their ranges, the previous
    error estimate 0 (none yet) or in [1e-4, 1] (DOPRI5's stiffness estimate: any finite value >= 0, the schema's
    range, since it only lowers a proposed step); the speed law of a known shape. `machine`: the kernel record of the
    state's parameters (mechanics.loop.machine.machine_from_parameters)."""
    control, law = simulation["control"].tolist(), simulation["speed_law"].tolist()
    step, low, high = control[CONTROL_STEP], smallest_step(0.0, machine), 10.0 * machine.max_step
    if not low <= step <= high:
        raise ValueError(f"state field 'control[step]' = {step!r} s is invalid: allowed [{low:g}, {high:g}] s "
                         f"(the smallest step to 10 max_step)")
    for index, name, top in ((CONTROL_HISTORY, "history", ABM_HISTORY), (CONTROL_SMALL_ERRORS, "small_errors", 8)):
        if not (control[index] == int(control[index]) and 0 <= control[index] <= top):
            raise ValueError(f"state field 'control[{name}]' = {control[index]!r} is invalid: allowed an integer in "
                             f"[0, {top}]")
    error = control[CONTROL_PREVIOUS_ERROR]
    if not (error == 0.0 or 1e-4 <= error <= 1.0):
        raise ValueError(f"state field 'control[previous_error]' = {error!r} is invalid: allowed 0 or [1e-4, 1]")
    if law[0] not in SHAPES.values() or law[5] < 0.0:
        raise ValueError(f"state field 'speed_law' = {law!r} is invalid: allowed a shape in "
                         f"{sorted(SHAPES.values())} and a duration >= 0 s")
