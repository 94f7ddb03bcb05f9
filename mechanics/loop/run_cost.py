"""How long a run will take, said before it starts (docs/model.md §8.3).

Four time scales bound the step size:
* max_step;
* on the stiff contacts, the error control, to about a tenth of the contact period T_c
  (mechanics.loop.machine.contact_period) at the default rtol, scaling as rtol^(1/5) (a 5th-order error estimate):
  h_c = T_c/10 (rtol / 3e-5)^(1/5);
* in a persistent contact, the stability of the explicit stages against the contact damping of §5.2: the force
  F (1 + 0.75 (1 - c_e^2) v/v_floor) is a damper of rate lambda_d = 0.75 (1 - c_e^2) F / (m3 v_floor) on the vane;
* in a sticking slot contact, the same against the friction law's slope at zero slip (§5.3), mu_eff'(0) F / m3
  = lambda_f (3 mu/v_0 for Threlfall, mu/(v_1 - v_0) for Ambrosio).
F is the representative contact load p_d t L, the back-chamber pressure on the vane's bottom face, which the tip and
slot contacts carry (a persistent contact at 16 rpm carried 0.4-3 kN against the 23 N of (p_d - p_s) h L). Neither
damper nor friction is stiff on every step, so they enter with the share of steps they limit, fitted to the 190
revolutions of the 200-point sweep of §11.5 (DAMPING_SHARE, FRICTION_SHARE).
A vane thrown off its profile (mechanics.loop.vane_throw: lift ratio > 1) lands once a lobe with the Hertz impact
force F_i for a time t_i; under F_i the friction law's slope is lambda_i = mu_eff'(0) F_i / m3, and a share c of
the impact (IMPACT_SHARE) is spent at it: c t_i lambda_i steps per impact, z n of them per second (n revolutions per
second). A chamber of the real-gas model open to the suction port relaxes on p_s at a rate lambda_r(phi) that an
explicit method keeps within its stability reach r (mechanics.loop.chamber_relaxation): (z/2 pi) int lambda_r/r dphi
steps per second, nothing fitted. A simulated duration D takes about

    N = D (1/max_step + 1/h_c + a lambda_d + b lambda_f + z n c t_i lambda_i + (z/2 pi) int lambda_r/r dphi)

accepted steps, at least D/max_step (the bound no run can beat: h <= max_step for every method). At 10 rpm a
revolution is 6 s of simulated time: 300 000 steps at the default max_step of 20 us, and 6e8 at max_step = 1e-8 s.
The seconds are N times the measured cost of one step (STEP_SECONDS, one worker on the shared 2-core machine of
§11.5); they scale with the machine. Over the sweep's revolutions estimated/measured seconds has a median of 1.1 and
is within 0.1-2.2 for 80 % of them; the tail it misses (up to 1000 times more steps) is stiffness the representative
load does not capture (docs/model.md §8.3).
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .chamber_relaxation import chamber_relaxation_rate
from .machine import machine_from_parameters
from .vane_throw import vane_throw
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
# steps per unit of lambda_d and lambda_f (module docstring): the least median |log(measured/estimated steps)| over
# the sweep's revolutions (0.52 without the two terms, 0.40 with them)
DAMPING_SHARE = 0.1
FRICTION_SHARE = 1e-3
# share of a thrown vane's impact spent at the friction slope under the impact force (module docstring): the least
# median |log(measured/estimated steps)| over the completed revolutions of the §11.5 sweep (0.410 without the term,
# 0.387 with it; on the 17 thrown vanes among them 1.92 and 1.34)
IMPACT_SHARE = 0.1


class RunCost(NamedTuple):
    steps: float              # expected accepted steps
    fewest_steps: float       # duration / max_step: no run takes fewer
    seconds: float            # expected compute time at STEP_SECONDS
    limit: str = "max_step"   # the parameters behind the largest share of the steps


def friction_slope(params: CompressorParameters) -> float:
    """d mu_eff / d|v_t| at zero slip, or over the ramp (docs/model.md §5.3) [s/m]."""
    if params.friction_model == "threlfall":
        return 3.0 * params.friction_coefficient / params.friction_velocity
    return params.friction_coefficient / (params.friction_velocity_full - params.friction_velocity)


def relaxation_limit(params: CompressorParameters) -> str:
    """The parameters behind the chambers' relaxation through the suction port, with their values."""
    dwell = f", bottom_dwell = {params.bottom_dwell:.3g} rad" if params.displacement_law == "harmonic_dwell" else ""
    return (f"suction_port_area = {params.suction_port_area:.3g} m2 against the small chamber volumes (dead_volume = "
            f"{params.dead_volume:.3g} m3, stroke = {params.stroke:.3g} m{dwell}): the chambers' relaxation through "
            "the suction port")


def step_rates(params: CompressorParameters, rpm: float) -> dict[str, float]:
    """Expected accepted steps per simulated second at `rpm` from each bound of the module docstring, by the
    parameters that set it."""
    machine = machine_from_parameters(params)
    throw = vane_throw(params, rpm)
    impacts_per_second = params.lobes * rpm / 60.0 if throw.lift_ratio > 1.0 else 0.0
    contact_step = machine.contact_period / CONTACT_STEPS_PER_PERIOD \
        * (params.relative_tolerance / DEFAULT_RTOL) ** 0.2
    load_per_mass = params.discharge_pressure * params.vane_thickness * params.axial_length / machine.vane_mass
    return {"max_step": 1.0 / params.max_step,
            "relative_tolerance and the contact stiffness": 1.0 / contact_step,
            "onset_velocity_floor and restitution": DAMPING_SHARE * 0.75 * (1.0 - params.restitution ** 2)
            * load_per_mass / params.onset_velocity_floor,
            "friction_velocity": FRICTION_SHARE * friction_slope(params) * load_per_mass,
            "the vane thrown off its profile (stroke, lobes, speed) and friction_velocity": impacts_per_second
            * IMPACT_SHARE * throw.impact_time * friction_slope(params) * throw.impact_force / machine.vane_mass,
            relaxation_limit(params): chamber_relaxation_rate(params, rpm)}


def run_cost(params: CompressorParameters, duration: float, rpm: float) -> RunCost:
    """The expected cost of simulating `duration` seconds at `rpm` (module docstring)."""
    rates = step_rates(params, rpm)
    steps = duration * float(sum(rates.values()))
    per_step = STEP_SECONDS[(params.pressure_model == "real_gas", params.integrator)]
    return RunCost(float(steps), duration / params.max_step, float(steps * per_step), max(rates, key=rates.get))


def revolution_cost(params: CompressorParameters, rpm: float) -> RunCost:
    """run_cost of one revolution at `rpm` (> 0)."""
    return run_cost(params, 60.0 / rpm, rpm)


def describe_cost(cost: RunCost, what: str) -> str:
    return (f"{what} takes about {cost.steps:.3g} steps (at least {cost.fewest_steps:.3g} = duration / max_step), "
            f"about {cost.seconds:.3g} s of compute (docs/model.md §8.3); most steps are set by {cost.limit}")


def slow_run_notice(params: CompressorParameters, rpm: float, limit_seconds: float = 10.0) -> str | None:
    """The sentence that says up front how long one revolution at `rpm` takes, if longer than `limit_seconds`."""
    if not rpm > 0.0 or not math.isfinite(rpm):
        return None
    cost = revolution_cost(params, rpm)
    if cost.seconds <= limit_seconds:
        return None
    return describe_cost(cost, f"one revolution at {rpm:g} rpm") + ": relaxing them shortens it"
