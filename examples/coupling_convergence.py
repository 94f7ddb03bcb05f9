"""Does the iterative co-simulation master converge at every step? DriveMotor.fmu drives RotaryVaneCompressor.fmu
from rest (the system of examples/motor_coupling.py) with the iterative master, for each pressure model, and every
communication step is iterated until the interface speed stops moving.

One step from t_k (both FMUs' states saved with fmi2GetFMUstate, restored before each further iteration): the motor
steps with the load torque T_i, its speed w_i at t_k + h goes to the compressor, which steps and returns
shaft_torque_mean T_(i+1); the step is converged when |w_i - w_(i-1)| <= --speed-tolerance (1e-6 rpm), else
iterated up to --max-iterations (a step not converged by then goes on from its last iterate and is counted, with
the speed change it was left at). The first guess T_1 is the last step's torque; each next one the torque returned
(--update fixed-point, the default) or the secant step on the residual T_returned - T_given through the last two
evaluations (--update secant).

Writes under out/coupling_convergence/: convergence.md (per pressure model: steps, iterations per step median/max,
steps not converged, the largest speed change left at one, the time of the first, wall time) and summary.json
(also every unconverged step).

Usage:  python examples/coupling_convergence.py [--stop-time 1.2] [--step 1e-3] [--speed-tolerance 1e-6]
                                                [--models real_gas ideal_gas_table] [--motor-power 1500]
                                                [--relative-tolerance R] [--integrator dopri5|abm4|ark548]
                                                [--update fixed-point|secant]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from contextlib import closing

import numpy as np

from rotary_vane.examples import fmu_harness as harness
from rotary_vane.examples.cli_types import number_parser
from rotary_vane.examples.motor_coupling import ITERATION_UPDATES, CoupledSystem, CouplingFailure

PRESSURE_MODELS = ("real_gas", "ideal_gas_table")


def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=harness.HelpFormatter)
    parser.add_argument("--stop-time", type=number_parser("s"), default=1.2, help="simulated time from rest [s]")
    parser.add_argument("--step", type=number_parser("s", 0.0, 0.1), default=1e-3, help="communication step [s]")
    parser.add_argument("--speed-tolerance", type=number_parser("rpm"), default=1e-6,
                        help="a step is converged when the interface speed moved by at most this between two "
                             "iterations [rpm]")
    parser.add_argument("--max-iterations", type=int, default=30, help="iterations per step at most")
    parser.add_argument("--models", nargs="+", choices=PRESSURE_MODELS, default=list(PRESSURE_MODELS),
                        help="the compressor's pressure models to run")
    parser.add_argument("--motor-power", type=number_parser("W"), default=1500.0,
                        help="rated power of the induction motor [W] (DriveMotor rated_power)")
    parser.add_argument("--relative-tolerance", type=number_parser("", 0.0, 1.0), default=None,
                        help="the compressor's relative_tolerance (default: the FMU's, 3e-5)")
    parser.add_argument("--integrator", choices=("dopri5", "abm4", "ark548"), default=None,
                        help="the compressor's integrator (default: the FMU's, dopri5; ark548 integrates the chamber "
                             "states implicitly and gives a smooth one-step map under real gas)")
    parser.add_argument("--update", choices=ITERATION_UPDATES, default="fixed-point",
                        help="the next guess of the load torque: the torque the compressor returned (fixed-point) "
                             "or the secant step through the last two evaluations")
    harness.add_common_options(parser, "coupling_convergence")
    args = parser.parse_args(argv)
    if args.max_iterations < 2:
        raise harness.InputError(f"--max-iterations = {args.max_iterations} is invalid: allowed an integer >= 2 "
                                 f"(the speed change needs two iterations)")
    return args


def iterated_step(system: CoupledSystem, t: float, h: float, tolerance: float, max_iterations: int,
                  update: str = "fixed-point"):
    """One communication step of the iterative master to |w_i - w_(i-1)| <= tolerance, the next guess by `update`
    (CoupledSystem.evaluations): (iterations, converged, the last speed change [rpm], the last change of the
    returned torque [N.m])."""
    last_speed, change, torque_change = None, float("inf"), float("inf")
    with closing(system.evaluations(t, h, max_iterations, update)) as evaluations:
        for iteration, speed, given, returned in evaluations:
            torque_change = abs(returned - given)
            if last_speed is not None:
                change = abs(speed - last_speed)
                if change <= tolerance:
                    return iteration, True, change, torque_change
            last_speed = speed
    return max_iterations, False, change, torque_change


def convergence_run(system: CoupledSystem, args) -> dict:
    """The start-up with the iterative master at every step: iterations, steps not converged, wall time."""
    system.motor.start(system.motor_values(args.motor_power))
    settings = {} if args.relative_tolerance is None else {"relative_tolerance": args.relative_tolerance}
    if args.integrator is not None:
        settings["integrator"] = args.integrator
    system.compressor.start({**system.compressor_values(), **settings})
    count = round(args.stop_time / args.step)
    iterations, unconverged, message = [], [], ""
    start = time.perf_counter()
    try:
        for k in range(count):
            used, converged, change, torque_change = iterated_step(system, k * args.step, args.step,
                                                                   args.speed_tolerance, args.max_iterations,
                                                                   args.update)
            iterations.append(used)
            if not converged:
                unconverged.append({"time": k * args.step, "speed_change_rpm": change,
                                    "torque_change_nm": torque_change, "speed_rpm": system.motor.get("shaft_speed")[0]})
    except CouplingFailure as failure:
        message = str(failure)
    return {"pressure_model": system.pressure_model, "steps": len(iterations), "of": count,
            "iterations_median": float(np.median(iterations)) if iterations else None,
            "iterations_max": max(iterations, default=None), "iterations_total": sum(iterations),
            "unconverged": unconverged, "final_speed_rpm": system.motor.get("shaft_speed")[0],
            "wall_s": time.perf_counter() - start, "failure": message}


def table(results: list[dict], args) -> str:
    rtol = "the FMU's default" if args.relative_tolerance is None else f"{args.relative_tolerance:g}"
    method = "the FMU's default" if args.integrator is None else args.integrator
    lines = [f"Iterative master, DriveMotor {args.motor_power:g} W + RotaryVaneCompressor (relative_tolerance "
             f"{rtol}, integrator {method}; next guess: {args.update}) from rest to {args.stop_time:g} s at {args.step:g} s steps; converged: interface speed within "
             f"{args.speed_tolerance:g} rpm between iterations (at most {args.max_iterations} iterations)", "",
             "| pressure model | steps | iterations / step (median / max) | steps not converged | largest speed "
             "change left [rpm] | largest torque change left [N.m] | first at [s] | speed at the end [rpm] | "
             "wall [s] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        worst = max((u["speed_change_rpm"] for u in r["unconverged"]), default=None)
        torque = max((u["torque_change_nm"] for u in r["unconverged"]), default=None)
        first = r["unconverged"][0]["time"] if r["unconverged"] else None
        lines.append(f"| {r['pressure_model']} | {r['steps']} of {r['of']} | {r['iterations_median']:g} / "
                     f"{r['iterations_max']} | {len(r['unconverged'])} | "
                     f"{'-' if worst is None else f'{worst:.2g}'} | {'-' if torque is None else f'{torque:.2g}'} | "
                     f"{'-' if first is None else f'{first:.3f}'} | "
                     f"{r['final_speed_rpm']:.2f} | {r['wall_s']:.0f} |")
        if r["failure"]:
            lines.append(f"\n{r['pressure_model']}: stopped: {r['failure']}")
    return "\n".join(lines)


def main(argv=None) -> int:
    args = parse_arguments(argv)
    fmu_dir = harness.ensure_fmus(args.fmu_dir)
    out = harness.output_folder(args.out)
    log = harness.FmuLog(args.verbose)
    results = []
    for model in args.models:
        with CoupledSystem(fmu_dir, log, 0.0, model) as system:
            system.warm_up()                  # the first steps load or compile the kernels: not timed
            results.append(convergence_run(system, args))
        print(results[-1]["pressure_model"], {k: v for k, v in results[-1].items() if k != "unconverged"},
              flush=True)
    text = table(results, args)
    print(text)
    (out / "convergence.md").write_text(text + "\n")
    (out / "summary.json").write_text(json.dumps({"arguments": {k: str(v) for k, v in vars(args).items()},
                                                  "results": results}, indent=2))
    print(f"\nwrote {out}/convergence.md, summary.json")
    return 0


if __name__ == "__main__":
    sys.exit(harness.run_main(main))
