"""The compressor FMU's model state as plain data: the arrays of `mechanics.Simulation`.

`snapshot` is taken before every communication step (to restore it if the step fails) and by fmi2GetFMUstate, so
it is cheap: the simulation's arrays are copied (a few tens of kB), the lobe records of the last revolution are
shared (the simulation replaces that array, it never changes it in place). Everything the FMU reports per
revolution is computed again from those records on restore, so the state holds no derived figures.
"""
from __future__ import annotations

import numpy as np

from ..mechanics.simulation import ARRAY_FIELDS, SimulationState


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
