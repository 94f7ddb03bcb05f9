"""Benchmark of the mechanics time loop (PERFORMANCE.md, docs/model.md §8): prints figures, asserts nothing.

Run from anywhere:  python benchmarks/bench_mechanics.py [--revolutions N] [--repeats R] [--quick]

1. numba loop, z = 3, 1500 rpm, c = slot = stator clearance in {0, 0.05, 0.2} mm, dopri5 and abm4:
   wall per revolution, real-time factor, steps and RHS evaluations per revolution, cost per step/evaluation.
2. scipy DOP853 driven step by step on the same numba right-hand side (c = 0.05 mm).
3. The same loop in pure Python (NUMBA_DISABLE_JIT=1, subprocess).
4. numba start-up: cold (empty NUMBA_CACHE_DIR) and cached, plus the import of numpy/numba/scipy alone.
5. Summary: real-time factor of the default integrator at c = 0.05 mm.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]

import numpy as np  # noqa: E402
from report import heading, table  # noqa: E402  (benchmarks/ is the script's folder)

RPM = 1500.0
REVOLUTION = 60.0 / RPM                    # s of simulated time per revolution (0.04 s)
LOBES = 3
CLEARANCES_MM = (0.0, 0.05, 0.2)
INTEGRATORS = ("dopri5", "abm4")
SETTLE_REVOLUTIONS = 2
REFERENCE_CLEARANCE_MM = 0.05              # scipy, pure-Python and headline case
TARGET_REAL_TIME_FACTOR = 30.0
PURE_PYTHON_FLAG = "--pure-python-one-revolution"
COUNTER_NAMES = ("accepted", "rejected", "evaluations", "valley_crossings", "mode_changes", "restarts")


# helpers ----------------------------------------------------------------------------------------------
def parameters(clearance_mm: float, integrator: str):
    from rotary_vane.mechanics import CompressorParameters
    c = clearance_mm * 1e-3
    return CompressorParameters(lobes=LOBES, slot_clearance=c, stator_clearance=c, integrator=integrator)


def new_simulation(params, keep_history: bool = False):
    from rotary_vane.mechanics import Simulation, constant_speed
    return Simulation(params, speed=constant_speed(RPM), keep_history=keep_history)


def run_subprocess(args: list[str], env_changes: dict[str, str]) -> tuple[dict, float]:
    """Run python with args in the repo root; return (JSON from its last stdout line, outer wall time)."""
    env = dict(os.environ, **env_changes)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, *args], cwd=REPO_ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"subprocess {args[:2]} failed with exit status {done.returncode}:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1]), wall


def source_fingerprint() -> str:
    """Short hash of mechanics/ and thermo/ sources: the figures belong to this version of the code."""
    digest = hashlib.sha256()
    for path in sorted([*REPO_ROOT.glob("mechanics/*.py"), *REPO_ROOT.glob("thermo/*.py")]):
        digest.update(path.name.encode() + path.read_bytes())
    return digest.hexdigest()[:12]


# 1. numba loop ----------------------------------------------------------------------------------------
def warm_up(params) -> None:
    """Compile (or load from cache) the kernels for this parameter set: build + a short advance."""
    new_simulation(params).advance(1e-4)


def timed_window(params, settle_revolutions: int, revolutions: int) -> dict:
    """Settle, then time `revolutions` revolutions with one advance; counter differences over the window."""
    sim = new_simulation(params)
    sim.advance(settle_revolutions * REVOLUTION)
    before = sim.counters.copy()
    start = time.perf_counter()
    sim.advance((settle_revolutions + revolutions) * REVOLUTION)
    wall = time.perf_counter() - start
    counts = dict(zip(COUNTER_NAMES, (sim.counters - before).tolist()))
    return {"wall": wall, "revolutions": revolutions, **counts}


def measure_numba(clearance_mm: float, integrator: str, revolutions: int, repeats: int) -> dict:
    """Median of `repeats` fresh timed windows (the step counts are deterministic)."""
    from rotary_vane.mechanics import IntegrationError
    params = parameters(clearance_mm, integrator)
    try:
        warm_up(params)
        runs = [timed_window(params, SETTLE_REVOLUTIONS, revolutions) for _ in range(repeats)]
    except IntegrationError as error:
        return {"clearance_mm": clearance_mm, "integrator": integrator, "error": str(error)}
    runs.sort(key=lambda r: r["wall"])
    result = dict(runs[len(runs) // 2])
    result.update(clearance_mm=clearance_mm, integrator=integrator,
                  wall_spread=(runs[0]["wall"], runs[-1]["wall"]))
    return result


def per_revolution(result: dict, key: str) -> float:
    return result[key] / result["revolutions"]


def numba_rows(results: list[dict]) -> list[list[str]]:
    rows = []
    for r in results:
        if "error" in r:
            rows.append([f"{r['clearance_mm']:.2f}", r["integrator"], "FAILED: " + r["error"]] + [""] * 10)
            continue
        wall_rev = r["wall"] / r["revolutions"]
        low, high = r["wall_spread"]
        rows.append([
            f"{r['clearance_mm']:.2f}", r["integrator"],
            f"{1e3 * wall_rev:.3f}", f"{1e3 * low / r['revolutions']:.2f}-{1e3 * high / r['revolutions']:.2f}",
            f"{REVOLUTION / wall_rev:.1f}",
            f"{per_revolution(r, 'accepted'):.0f}", f"{per_revolution(r, 'rejected'):.0f}",
            f"{100 * r['rejected'] / max(1, r['accepted'] + r['rejected']):.1f}",
            f"{per_revolution(r, 'evaluations'):.0f}",
            f"{1e6 * r['wall'] / max(1, r['accepted']):.3f}", f"{1e6 * r['wall'] / max(1, r['evaluations']):.3f}",
            f"{per_revolution(r, 'mode_changes'):.0f}", f"{per_revolution(r, 'restarts'):.0f}",
        ])
    return rows


def report_numba(results: list[dict], revolutions: int, repeats: int) -> None:
    heading(f"1. numba time loop: z = {LOBES}, {RPM:.0f} rpm, {SETTLE_REVOLUTIONS} settling revolutions, "
            f"{revolutions} timed, median of {repeats}")
    headers = ["c [mm]", "integrator", "ms/rev", "min-max", "x real time", "acc/rev", "rej/rev", "rej %",
               "RHS/rev", "us/acc step", "us/RHS", "modechg/rev", "restart/rev"]
    print(table(headers, numba_rows(results)))
    print("valley crossings per revolution: "
          + ", ".join(f"{r['clearance_mm']:.2f} mm {r['integrator']}: {per_revolution(r, 'valley_crossings'):.0f}"
                      for r in results if "error" not in r))


# 2. scipy DOP853 on the same right-hand side ------------------------------------------------------------
def tolerance_vector():
    """atol of docs/model.md §8.2: positions 1e-9 m, angle 1e-8 rad, velocities 1e-6 m/s, omega3 1e-4 rad/s, works 1e-6 J."""
    from rotary_vane.mechanics.layout import STATE_SIZE
    return np.array([1e-9, 1e-9, 1e-8, 1e-6, 1e-6, 1e-4] + [1e-6] * (STATE_SIZE - 6))


def scipy_revolution(sim, t_start: float, y_start: np.ndarray, memory: np.ndarray) -> dict:
    """One revolution with scipy.integrate.DOP853 stepped by hand; memory updated after each accepted step."""
    from scipy.integrate import DOP853

    from rotary_vane.mechanics.dynamics import evaluate
    from rotary_vane.mechanics.integrators import _accept, _cross_valley
    from rotary_vane.mechanics.layout import MEM_LOBE_START, OUTPUT_SIZE, STATE_SIZE, WORK_IN
    from rotary_vane.mechanics.speed import rotor_motion

    machine, law, table_p = sim.machine, sim.speed_law, sim.gas
    memory = memory.copy()
    dydt = np.empty(STATE_SIZE)
    out = np.empty(OUTPUT_SIZE)
    lobe = 2.0 * math.pi / LOBES
    stats = {"solver_calls": 0, "bookkeeping_calls": 0, "failed_evaluations": 0, "valley_crossings": 0,
             "mode_changes": 0, "steps": 0}

    def fun(t, y):
        stats["solver_calls"] += 1
        if evaluate(t, y, machine, law, table_p, memory, dydt, out) != 0:
            stats["failed_evaluations"] += 1
        return dydt.copy()          # the solver keeps references to returned arrays (FSAL)

    start = time.perf_counter()
    solver = DOP853(fun, t_start, y_start.copy(), t_bound=t_start + REVOLUTION, rtol=1e-6,
                    atol=tolerance_vector(), max_step=2e-5, first_step=1e-6)
    message = None
    while solver.status == "running":
        message = solver.step()
        if solver.status == "failed":
            break
        stats["steps"] += 1
        evaluate(solver.t, solver.y, machine, law, table_p, memory, dydt, out)   # output at the new point
        stats["bookkeeping_calls"] += 1
        if _accept(out, memory, machine):
            stats["mode_changes"] += 1
        if rotor_motion(solver.t, law)[0] >= memory[MEM_LOBE_START] + lobe:   # stepped over a valley
            _cross_valley(memory, machine)
            stats["valley_crossings"] += 1
            solver.f = fun(solver.t, solver.y)     # refresh the FSAL derivative, as the numba loop does
    wall = time.perf_counter() - start
    # DOP853: 12 evaluations per step attempt (11 stages + f at the new point), 1 at construction
    attempts = (stats["solver_calls"] - 1 - stats["valley_crossings"]) / 12.0
    return {"wall": wall, "status": solver.status, "message": message, "t_end": solver.t,
            "rejected": round(attempts) - stats["steps"],
            "input_power": (solver.y[WORK_IN] - y_start[WORK_IN]) / (solver.t - t_start), **stats}


def evaluate_call_cost(sim, calls: int = 20000) -> float:
    """µs per call of the numba `evaluate` from Python (dispatch + unboxing of the Machine tuple)."""
    from rotary_vane.mechanics.dynamics import evaluate
    from rotary_vane.mechanics.layout import OUTPUT_SIZE, STATE_SIZE
    y, memory = sim.state.copy(), sim.memory.copy()
    dydt, out = np.empty(STATE_SIZE), np.empty(OUTPUT_SIZE)
    args = (sim.machine, sim.speed_law, sim.gas, memory, dydt, out)
    evaluate(sim.time, y, *args)
    start = time.perf_counter()
    for _ in range(calls):
        evaluate(sim.time, y, *args)
    return 1e6 * (time.perf_counter() - start) / calls


def compare_scipy(numba_reference: dict | None) -> None:
    from rotary_vane.mechanics.layout import WORK_IN
    heading(f"2. scipy DOP853 stepped by hand on the numba RHS, c = {REFERENCE_CLEARANCE_MM} mm, dopri5 settle "
            f"1 revolution, then 1 revolution timed")
    params = parameters(REFERENCE_CLEARANCE_MM, "dopri5")
    warm_up(params)
    sim = new_simulation(params)
    sim.advance(REVOLUTION)
    t_start, y_start, memory = sim.time, sim.state.copy(), sim.memory.copy()
    call_cost = evaluate_call_cost(sim)

    before = sim.counters.copy()
    start = time.perf_counter()
    sim.advance(t_start + REVOLUTION)
    numba_wall = time.perf_counter() - start
    numba_counts = dict(zip(COUNTER_NAMES, (sim.counters - before).tolist()))
    numba_power = (sim.state[WORK_IN] - y_start[WORK_IN]) / (sim.time - t_start)

    s = scipy_revolution(sim, t_start, y_start, memory)
    headers = ["integrator", "ms/rev", "x real time", "acc/rev", "rej/rev", "RHS/rev", "us/acc step", "<P_in> [W]"]
    rows = [["numba dopri5 (same window)", f"{1e3 * numba_wall:.2f}", f"{REVOLUTION / numba_wall:.2f}",
             str(numba_counts["accepted"]), str(numba_counts["rejected"]), str(numba_counts["evaluations"]),
             f"{1e6 * numba_wall / numba_counts['accepted']:.2f}", f"{numba_power:.4f}"],
            ["scipy DOP853 + numba RHS", f"{1e3 * s['wall']:.2f}", f"{REVOLUTION / s['wall']:.2f}",
             str(s["steps"]), str(s["rejected"]), str(s["solver_calls"] + s["bookkeeping_calls"]),
             f"{1e6 * s['wall'] / max(1, s['steps']):.2f}", f"{s['input_power']:.4f}"]]
    print(table(headers, rows))
    if s["status"] != "finished":
        print(f"!! DOP853 stopped at t = {s['t_end']:.6f} s: {s['status']} ({s['message']})")
    if numba_reference and "error" not in numba_reference:
        reference = numba_reference["wall"] / numba_reference["revolutions"]
        print(f"scipy / numba dopri5 (table 1 figure, {1e3 * reference:.3f} ms/rev): {s['wall'] / reference:.1f} x")
    print(f"scipy / numba dopri5 (same window):                 {s['wall'] / numba_wall:.1f} x")
    print(f"<P_in> relative difference scipy vs numba: {abs(s['input_power'] / numba_power - 1):.2e}")
    print(f"RHS calls: {s['solver_calls']} by the solver + {s['bookkeeping_calls']} output evaluations at accepted "
          f"points; one numba evaluate() called from Python costs {call_cost:.2f} us (dispatch + unboxing)")
    print(f"valley crossings {s['valley_crossings']}, mode changes {s['mode_changes']}, "
          f"RHS calls with a nonzero status (ignored by scipy) {s['failed_evaluations']}")
    print("note: DOP853 steps over valley crossings (memory switched after the step), the numba loop lands on "
          "them;\n      rejected steps for scipy are inferred from its 12 evaluations per attempt.")


# 3. pure Python ------------------------------------------------------------------------------------------
def pure_python_one_revolution() -> None:
    """Subprocess entry (NUMBA_DISABLE_JIT=1): settle, time one revolution, print JSON."""
    if os.environ.get("NUMBA_DISABLE_JIT") != "1":
        raise SystemExit(f"{PURE_PYTHON_FLAG} needs NUMBA_DISABLE_JIT=1 in the environment")
    params = parameters(REFERENCE_CLEARANCE_MM, "dopri5")
    sim = new_simulation(params)
    sim.advance(SETTLE_REVOLUTIONS * REVOLUTION)
    before = sim.counters.copy()
    start = time.perf_counter()
    sim.advance((SETTLE_REVOLUTIONS + 1) * REVOLUTION)
    wall = time.perf_counter() - start
    print(json.dumps({"wall": wall, **dict(zip(COUNTER_NAMES, (sim.counters - before).tolist()))}))


def compare_pure_python(numba_reference: dict | None) -> None:
    heading(f"3. pure Python (NUMBA_DISABLE_JIT=1), c = {REFERENCE_CLEARANCE_MM} mm, dopri5, "
            f"revolution {SETTLE_REVOLUTIONS + 1} timed")
    result, _ = run_subprocess([str(Path(__file__).resolve()), PURE_PYTHON_FLAG], {"NUMBA_DISABLE_JIT": "1"})
    print(f"pure Python: {result['wall']:.2f} s/rev ({REVOLUTION / result['wall']:.4f} x real time), "
          f"{result['accepted']} accepted, {result['rejected']} rejected, {result['evaluations']} RHS, "
          f"{1e6 * result['wall'] / result['evaluations']:.1f} us/RHS")
    if numba_reference and "error" not in numba_reference:
        wall_rev = numba_reference["wall"] / numba_reference["revolutions"]
        eval_cost = numba_reference["wall"] / numba_reference["evaluations"]
        print(f"pure Python / numba: {result['wall'] / wall_rev:.0f} x per revolution, "
              f"{result['wall'] / result['evaluations'] / eval_cost:.0f} x per RHS evaluation")


# 4. start-up -------------------------------------------------------------------------------------------
STARTUP_CODE = """
import json, time
t0 = time.perf_counter()
import rotary_vane.mechanics as mechanics
t1 = time.perf_counter()
sim = mechanics.Simulation()
t2 = time.perf_counter()
sim.advance(1e-4)
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "build": t2 - t1, "advance": t3 - t2, "total": t3 - t0}))
"""

IMPORT_CODE = """
import json, time
t0 = time.perf_counter()
import numpy
t1 = time.perf_counter()
import numba
t2 = time.perf_counter()
import scipy, scipy.integrate
t3 = time.perf_counter()
print(json.dumps({"numpy": t1 - t0, "numba": t2 - t1, "scipy": t3 - t2, "total": t3 - t0}))
"""


def startup_costs() -> None:
    heading("4. start-up: import mechanics + Simulation() + advance(1e-4), fresh processes")
    imports, import_wall = run_subprocess(["-c", IMPORT_CODE], {})
    rows = [["import numpy / numba / scipy(+integrate)",
             f"{imports['numpy']:.3f} / {imports['numba']:.3f} / {imports['scipy']:.3f}", "", "",
             f"{imports['total']:.3f}", f"{import_wall:.3f}"]]
    with tempfile.TemporaryDirectory(prefix="numba_cache_") as cache:
        for label in ("cold (empty NUMBA_CACHE_DIR)", "cached (same NUMBA_CACHE_DIR)"):
            r, wall = run_subprocess(["-c", STARTUP_CODE], {"NUMBA_CACHE_DIR": cache})
            rows.append([label, f"{r['import']:.3f}", f"{r['build']:.3f}", f"{r['advance']:.3f}",
                         f"{r['total']:.3f}", f"{wall:.3f}"])
    print(table(["case", "import [s]", "Simulation() [s]", "advance [s]", "total [s]", "process [s]"], rows))
    print("(mechanics imports numpy and numba, not scipy; 'process' includes interpreter start-up and exit)")


# 5. summary --------------------------------------------------------------------------------------------
def summary(results: list[dict]) -> None:
    heading("5. summary")
    for r in results:
        if r["integrator"] == "dopri5" and r["clearance_mm"] == REFERENCE_CLEARANCE_MM:
            if "error" in r:
                print(f"default integrator (dopri5) at c = {REFERENCE_CLEARANCE_MM} mm: FAILED ({r['error']})")
            else:
                factor = REVOLUTION * r["revolutions"] / r["wall"]
                print(f"default integrator (dopri5) at c = {REFERENCE_CLEARANCE_MM} mm: {factor:.1f} x faster than "
                      f"real time (target {TARGET_REAL_TIME_FACTOR:.0f}x)")
    for r in results:
        if r["integrator"] == "abm4" and r["clearance_mm"] == REFERENCE_CLEARANCE_MM and "error" not in r:
            print(f"thesis integrator (abm4) at c = {REFERENCE_CLEARANCE_MM} mm: "
                  f"{REVOLUTION * r['revolutions'] / r['wall']:.1f} x faster than real time")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--revolutions", type=int, default=3, help="timed revolutions per window (default 3)")
    parser.add_argument("--repeats", type=int, default=3, help="timed windows per case, median reported")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: 1 revolution, 1 repeat, no pure-Python part")
    parser.add_argument(PURE_PYTHON_FLAG, action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.pure_python_one_revolution:
        pure_python_one_revolution()
        return
    revolutions, repeats = (1, 1) if args.quick else (args.revolutions, args.repeats)

    import numba
    import scipy
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"numba {numba.__version__}, {os.cpu_count()} CPUs; 1 revolution = {1e3 * REVOLUTION:.0f} ms simulated")
    fingerprint = source_fingerprint()
    print(f"mechanics/ + thermo/ source fingerprint {fingerprint}")
    results = [measure_numba(c, integrator, revolutions, repeats)
               for c in CLEARANCES_MM for integrator in INTEGRATORS]
    report_numba(results, revolutions, repeats)
    reference = next(r for r in results if r["integrator"] == "dopri5" and r["clearance_mm"] == REFERENCE_CLEARANCE_MM)
    compare_scipy(reference)
    if not args.quick:
        compare_pure_python(reference)
    startup_costs()
    summary(results)
    if source_fingerprint() != fingerprint:
        print(f"\n!! mechanics/ or thermo/ changed during the run ({fingerprint} -> {source_fingerprint()}): "
              f"subprocess figures (parts 3, 4) may belong to a different version than parts 1, 2")


if __name__ == "__main__":
    main()
