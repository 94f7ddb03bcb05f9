"""Dormand-Prince against the additive Runge-Kutta ARK5(4)8L[2]SA with the chamber states implicit (issue 25,
docs/model.md §8.2-§8.3): the cost per revolution (accepted / rejected steps, right-hand sides, Newton iterations,
Jacobians of the chamber rates, CPU time) and the error of the per-revolution figures against the rtol = 1e-9
Dormand-Prince run, z = 3, 1500 rpm, c = 0, 0.05, 0.2 mm, both pressure models. Prints one table; asserts nothing.
(Carried over from the branch that measured the Rosenbrock-W method ROS34PW2, §8.3.)

Run from anywhere:  python benchmarks/bench_integrators.py [--clearances 0 0.05 0.2] [--models ...]
                    [--settings dopri5:3e-5:2e-5 ark548:3e-5:2e-5 ark548:1e-4:1e-4 ...]

A setting is method:rtol:h_max. Each run settles for 0.2 s, then 10 revolutions are measured and averaged (the
figures of tests/mechanics/test_numerics.py: powers, eta_m, peak contact force, discharge mass flow within
0.05 % / 1 %, the discharge temperature within 0.01 K); "within" says whether every figure is inside those bounds
(at c = 0.2 mm the motion is chaotic: compare with the floor of benchmarks/bench_tolerances.py, not the bounds).
The CPU time is process time of the 10 revolutions on a shared machine (compare within one run).
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from report import heading, table  # benchmarks/ is the script's folder

SPEED, WARM_UP, DURATION = 1500.0, 0.2, 0.6
REVOLUTIONS = (DURATION - WARM_UP) * SPEED / 60.0
RELATIVE = {"input_power": 5e-4, "output_power": 5e-4, "friction_power": 5e-4, "mechanical_efficiency": 5e-4,
            "max_contact_force": 1e-2, "discharge_mass_flow": 5e-4}
TEMPERATURE = 0.01
REFERENCE = "dopri5:1e-9:2e-5"


def run(model, clearance, setting):
    from rotary_vane.mechanics import CompressorParameters, IntegrationError, Simulation, constant_speed
    from rotary_vane.mechanics.performance import revolutions
    from rotary_vane.mechanics.loop.integrators import (ACCEPTED, EVALUATIONS, JACOBIANS, NEWTON_ITERATIONS,
                                                        REJECTED)
    method, rtol, max_step = setting.split(":")
    params = CompressorParameters(slot_clearance=clearance, stator_clearance=clearance, pressure_model=model,
                                  integrator=method, relative_tolerance=float(rtol), max_step=float(max_step),
                                  initial_step=min(1e-6, float(max_step)))
    Simulation(params).advance(1e-4)                          # load the compiled kernels outside the timing
    simulation = Simulation(params, constant_speed(SPEED), keep_history=False)
    try:
        simulation.advance(WARM_UP)
        counters = simulation.counters.copy()
        start = time.process_time()
        simulation.advance(DURATION)
        cpu = time.process_time() - start
    except IntegrationError as error:
        return dict(failed=str(error))
    counts = (simulation.counters - counters) / REVOLUTIONS
    summaries = [s for s in revolutions(simulation) if s.start_time >= WARM_UP]
    means = {name: float(np.mean([getattr(s, name) for s in summaries]))
             for name in [*RELATIVE, "discharge_temperature"]}
    return dict(accepted=counts[ACCEPTED], rejected=counts[REJECTED], rhs=counts[EVALUATIONS],
                newton=counts[NEWTON_ITERATIONS], jacobians=counts[JACOBIANS], ms=cpu / REVOLUTIONS * 1e3,
                means=means)


def worst_errors(result, reference):
    """(worst relative error of the powers and eta_m, of the peak force, of the mass flow; |dT_d| [K]; within)."""
    errors = {name: abs(result["means"][name] - reference["means"][name]) / abs(reference["means"][name])
              if reference["means"][name] != 0.0 else abs(result["means"][name])
              for name in RELATIVE if math.isfinite(reference["means"][name])}
    temperature = abs(result["means"]["discharge_temperature"] - reference["means"]["discharge_temperature"])
    within = all(errors[name] <= RELATIVE[name] for name in errors) and not temperature > TEMPERATURE
    powers = max(errors[n] for n in ("input_power", "output_power", "friction_power", "mechanical_efficiency"))
    return powers, errors["max_contact_force"], errors.get("discharge_mass_flow", math.nan), temperature, within


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clearances", type=float, nargs="+", default=[0.0, 0.05, 0.2], help="mm")
    parser.add_argument("--models", nargs="+", default=["ideal_gas_table", "real_gas"])
    parser.add_argument("--settings", nargs="+", default=["dopri5:3e-5:2e-5", "ark548:3e-5:2e-5",
                                                          "ark548:1e-4:1e-4"])
    args = parser.parse_args()
    heading(f"Cost per revolution and error against {REFERENCE} at {SPEED:g} rpm ({REVOLUTIONS:g} revolutions)")
    rows = []
    for model in args.models:
        for clearance in args.clearances:
            reference = run(model, clearance * 1e-3, REFERENCE)
            for setting in args.settings:
                result = run(model, clearance * 1e-3, setting)
                if "failed" in result:
                    rows.append([model, f"{clearance:g}", setting, "failed: " + result["failed"][:60]] + [""] * 9)
                else:
                    powers, force, flow, temperature, within = worst_errors(result, reference)
                    rows.append([model, f"{clearance:g}", setting,
                                 f"{result['accepted']:.0f} / {result['rejected']:.0f}", f"{result['rhs']:.0f}",
                                 f"{result['newton']:.0f}", f"{result['jacobians']:.0f}", f"{result['ms']:.1f}",
                                 f"{powers:.1e}", f"{force:.2%}", f"{flow:.1e}", f"{temperature:.4f}",
                                 "yes" if within else "no"])
                print(" | ".join(rows[-1]), flush=True)
    print(table(["model", "c [mm]", "method:rtol:h_max", "accepted / rejected", "RHS", "Newton", "Jacobians",
                 "CPU ms/rev", "powers, eta_m", "peak force", "mass flow", "T_d [K]", "within"], rows))


if __name__ == "__main__":
    main()
