"""CPU per accepted step of the mechanics time loop, two checkouts side by side: prints figures, asserts nothing.

Run from anywhere:
    python benchmarks/bench_step_cost.py --baseline-python OLD_VENV/bin/python [--candidate-python PY]
                                         [--repeats N] [--sweep-points FILE --index I ...]

Each interpreter imports the checkout its venv was installed from (the editable install), so the two venvs are the
two versions. Cases: the defaults (real-gas chambers), the Level 0.5 table (pressure_model "ideal_gas_table"), the
defaults with the Johnson line contact (stiffness_model "johnson_line", docs/model.md §5.2), and any points of a
parameter-sweep file (examples/parameter_sweep.py's `points` list, run at their constant speed from angle 0 as the
sweep runs them). Every timed run is a fresh process (the kernels loaded by a short warm-up advance, then a timed
advance over --time seconds of simulated time) and the baseline and candidate runs alternate, in turn first, so a
change in the machine's load falls on both. Reported per case: the medians of CPU time (process time) per accepted step and per
right-hand side, the candidate over baseline ratio, and the accepted steps and rejections of each, which agree
exactly where the candidate is bit-identical.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

from report import heading, table  # benchmarks/ is the script's folder

WORKER_FLAG = "--worker"
WARM_UP = 1e-3                # s of simulated time before the timed advance (loads the kernels)
BUILT_IN_CASES = {
    "defaults (real gas)": {},
    "Level 0.5 table": {"pressure_model": "ideal_gas_table"},
    "Johnson line contact": {"stiffness_model": "johnson_line"},
}


def worker(case: dict) -> dict:
    """One case in this process: warm-up, then the timed advance; CPU per accepted step and per evaluation."""
    import time
    from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
    values = dict(case["values"])
    rpm = values.pop("rpm", None)
    params = CompressorParameters(**values)
    if rpm is None:
        simulation = Simulation(params, keep_history=False)
    else:
        simulation = Simulation(params, constant_speed(rpm), initial_angle=0.0, keep_history=False)
    simulation.advance(WARM_UP)
    before = simulation.counters.copy()
    start = time.process_time()
    simulation.advance(WARM_UP + case["time"])
    cpu = time.process_time() - start
    accepted, rejected, evaluations = (int(v) for v in (simulation.counters - before)[:3])
    return dict(cpu=cpu, accepted=accepted, rejected=rejected, evaluations=evaluations)


def run_worker(python: str, case: dict) -> dict:
    completed = subprocess.run([python, __file__, WORKER_FLAG, json.dumps(case)], capture_output=True, text=True,
                               check=True)
    return json.loads(completed.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline-python", required=True, help="interpreter of the baseline checkout's venv")
    parser.add_argument("--candidate-python", default=sys.executable, help="interpreter of the candidate's venv")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--time", type=float, default=0.1, help="simulated seconds per timed run")
    parser.add_argument("--sweep-points", help="a parameter-sweep JSON file ({'points': [...]})")
    parser.add_argument("--index", type=int, nargs="*", default=[], help="indices of its points to run")
    parser.add_argument("--no-built-in", action="store_true", help="only the sweep points")
    args = parser.parse_args()
    cases = {} if args.no_built_in else dict(BUILT_IN_CASES)
    if args.sweep_points:
        with open(args.sweep_points) as handle:
            points = json.load(handle)["points"]
        cases.update({f"sweep point #{i}": points[i] for i in args.index})
    heading(f"CPU per accepted step, {args.repeats} interleaved fresh runs of {args.time:g} s each, medians")
    rows = []
    for label, values in cases.items():
        case = dict(values=values, time=args.time)
        runs = {"baseline": [], "candidate": []}
        sides = [("baseline", args.baseline_python), ("candidate", args.candidate_python)]
        for repeat in range(args.repeats):
            for side, python in (sides if repeat % 2 == 0 else sides[::-1]):      # neither side always runs first
                runs[side].append(run_worker(python, case))
        per_step = {side: statistics.median(r["cpu"] / r["accepted"] for r in result) * 1e6
                    for side, result in runs.items()}
        per_evaluation = {side: statistics.median(r["cpu"] / r["evaluations"] for r in result) * 1e6
                          for side, result in runs.items()}
        base, cand = runs["baseline"][0], runs["candidate"][0]
        rows.append([label, f"{per_step['baseline']:.2f}", f"{per_step['candidate']:.2f}",
                     f"{per_step['candidate'] / per_step['baseline']:.3f}",
                     f"{per_evaluation['baseline']:.3f}", f"{per_evaluation['candidate']:.3f}",
                     f"{base['accepted']}/{base['rejected']}", f"{cand['accepted']}/{cand['rejected']}"])
    print(table(["case", "baseline us/step", "candidate us/step", "ratio", "baseline us/RHS", "candidate us/RHS",
                 "baseline steps/rej.", "candidate steps/rej."], rows))


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == WORKER_FLAG:
        print(json.dumps(worker(json.loads(sys.argv[2]))))
    else:
        main()
