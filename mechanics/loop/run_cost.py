"""How long a run will take, said before it starts (docs/model.md §8.3).

The step size is bounded by max_step and, on the stiff contacts, by the error control to about a tenth of the
contact period T_c (mechanics.loop.machine.contact_period) at the default rtol, scaling as rtol^(1/5) (a 5th-order error
estimate). So a simulated duration D takes about

    N = D (1/max_step + 1/h_c),   h_c = T_c/10 (rtol / 3e-5)^(1/5)

accepted steps, at least D/max_step (the bound no run can beat: h <= max_step for both methods). At 10 rpm a
revolution is 6 s of simulated time: 300 000 steps at the default max_step of 20 us, and 6e8 at max_step = 1e-8 s.
The seconds are N times the cost of one step measured at the defaults (STEP_SECONDS, one core of the 2-core
machine of README "Speed"); they scale with the machine.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .machine import machine_from_parameters
from ..parameters import CompressorParameters

# measured cost of one accepted step (s), per (pressure model is real gas, method): the median CPU time per accepted
# step of the revolutions completed in the 200-point sweep of docs/model.md §11.5 (one worker on the shared 2-core
# machine; ideal-gas table and polytropic pooled, 14-46 revolutions per method, 2-7 for real gas). The earlier figures,
# measured at the defaults alone (1500 rpm, 0.1 s), were half of these and left 24 of those 200 points over the
# budget they had been estimated within
STEP_SECONDS = {(False, "abm4"): 4.4e-6, (False, "dopri5"): 11e-6, (False, "ark548"): 15e-6,
                (True, "abm4"): 6.8e-6, (True, "dopri5"): 19e-6, (True, "ark548"): 38e-6}
DEFAULT_RTOL = 3e-5
CONTACT_STEPS_PER_PERIOD = 10.0


class RunCost(NamedTuple):
    steps: float              # expected accepted steps
    fewest_steps: float       # duration / max_step: no run takes fewer
    seconds: float            # expected compute time at STEP_SECONDS


def run_cost(params: CompressorParameters, duration: float) -> RunCost:
    """The expected cost of simulating `duration` seconds (module docstring)."""
    period = machine_from_parameters(params).contact_period
    contact_step = period / CONTACT_STEPS_PER_PERIOD * (params.relative_tolerance / DEFAULT_RTOL) ** 0.2
    steps = duration * (1.0 / params.max_step + 1.0 / contact_step)
    per_step = STEP_SECONDS[(params.pressure_model == "real_gas", params.integrator)]
    return RunCost(float(steps), duration / params.max_step, float(steps * per_step))


def revolution_cost(params: CompressorParameters, rpm: float) -> RunCost:
    """run_cost of one revolution at `rpm` (> 0)."""
    return run_cost(params, 60.0 / rpm)


def describe_cost(cost: RunCost, what: str) -> str:
    return (f"{what} takes about {cost.steps:.3g} steps (at least {cost.fewest_steps:.3g} = duration / max_step), "
            f"about {cost.seconds:.3g} s of compute (docs/model.md §8.3)")


def slow_run_notice(params: CompressorParameters, rpm: float, limit_seconds: float = 10.0) -> str | None:
    """The sentence that says up front how long one revolution at `rpm` takes, if longer than `limit_seconds`."""
    if not rpm > 0.0 or not math.isfinite(rpm):
        return None
    cost = revolution_cost(params, rpm)
    if cost.seconds <= limit_seconds:
        return None
    return describe_cost(cost, f"one revolution at {rpm:g} rpm") + ": a larger max_step or relative_tolerance " \
                                                                      "shortens it"
