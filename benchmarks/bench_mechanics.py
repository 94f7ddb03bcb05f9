"""Benchmark of the mechanics time loop (docs/model.md §8): prints figures, asserts nothing.

Run from anywhere:  python benchmarks/bench_mechanics.py [--revolutions N] [--repeats R] [--quick]

Every run is the mechanics with the Level 0.5 pressure table (pressure_model "ideal_gas_table") at the reference
numerics (REFERENCE_NUMERICS: rtol 1e-6, max_step 2e-5 s), named explicitly: the library's defaults are now the
real-gas chambers at rtol 3e-5 (benchmarks/bench_real_gas.py and bench_tolerances.py measure those).

1. numba loop, z = 3, 1500 rpm, c = slot = stator clearance in {0, 0.05, 0.2} mm, dopri5 and abm4:
   wall per revolution, real-time factor, steps and RHS evaluations per revolution, cost per step/evaluation.
2. scipy DOP853 driven step by step on the same numba right-hand side (c = 0.05 mm), entered from Python through
   mechanics.loop.integrators.evaluate_state (the kernel's entry that Simulation.evaluate uses; it also writes the
   output row), with the loop's own kernel functions for what follows an accepted step (_update_memory, _cross_valley)
   and the loop's absolute tolerances (_tolerance).
3. numba start-up: cold (empty ROTARY_VANE_CACHE_DIR, the project's kernel cache) and cached, plus the import of
   numpy/numba/scipy alone.
4. Summary: real-time factor of the default integrator at c = 0.05 mm.

Dropped: the same loop in pure Python (NUMBA_DISABLE_JIT=1). The restructured kernel reads its constants as a
record, `ctx.machine[0]`; compiled, that is a numba record, but in pure Python the row of the plain structured
array the Simulation passes (mechanics.loop.machine.machine_array) is a numpy.void without attribute access, so the
first right-hand side fails ("'numpy.void' object has no attribute 'tip_centre'"). Measuring it would need a change
in mechanics/ or patching the Simulation from here; neither belongs in a benchmark.
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
REFERENCE_CLEARANCE_MM = 0.05              # scipy and headline case
PRESSURE_MODEL = "ideal_gas_table"         # Level 0.5: the mechanics loop without the chamber states
TARGET_REAL_TIME_FACTOR = 30.0
COUNTER_NAMES = ("accepted", "rejected", "evaluations", "valley_crossings", "mode_changes", "restarts")


# helpers ----------------------------------------------------------------------------------------------
def parameters(clearance_mm: float, integrator: str):
    """The benchmarked machine: Level 0.5 table, reference numerics (module docstring)."""
    from rotary_vane.mechanics import REFERENCE_NUMERICS, CompressorParameters
    c = clearance_mm * 1e-3
    return CompressorParameters(lobes=LOBES, slot_clearance=c, stator_clearance=c, integrator=integrator,
                                pressure_model=PRESSURE_MODEL, **REFERENCE_NUMERICS)


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
    from rotary_vane.mechanics import REFERENCE_NUMERICS
    heading(f"1. numba time loop: z = {LOBES}, {RPM:.0f} rpm, {PRESSURE_MODEL}, "
            f"rtol {REFERENCE_NUMERICS['relative_tolerance']:g}, max_step {REFERENCE_NUMERICS['max_step']:g} s, "
            f"{SETTLE_REVOLUTIONS} settling revolutions, {revolutions} timed, median of {repeats}")
    headers = ["c [mm]", "integrator", "ms/rev", "min-max", "x real time", "acc/rev", "rej/rev", "rej %",
               "RHS/rev", "us/acc step", "us/RHS", "modechg/rev", "restart/rev"]
    print(table(headers, numba_rows(results)))
    print("valley crossings per revolution: "
          + ", ".join(f"{r['clearance_mm']:.2f} mm {r['integrator']}: {per_revolution(r, 'valley_crossings'):.0f}"
                      for r in results if "error" not in r))


# 2. scipy DOP853 on the same right-hand side ------------------------------------------------------------
def tolerance_vector(sim) -> np.ndarray:
    """The loop's absolute tolerance per state component (docs/model.md §8.2; integrators._tolerance at y = 0)."""
    from rotary_vane.mechanics.loop.integrators import _tolerance
    machine, chambers = sim.machine, sim.gas.chambers[0]
    return np.array([_tolerance(i, 0.0, machine, chambers) for i in range(sim.state.size)])


def scipy_revolution(sim, t_start: float, y_start: np.ndarray, memory: np.ndarray) -> dict:
    """One revolution with scipy.integrate.DOP853 stepped by hand on the kernel's right-hand side, with the
    simulation's rtol, atol, max_step and first step; after each accepted step the memory is updated and, past a
    valley, the next lobe made the active one by the loop's own kernel functions."""
    from scipy.integrate import DOP853

    from rotary_vane.mechanics.loop.integrators import _cross_valley, _update_memory, context, evaluate_state
    from rotary_vane.mechanics.loop.layout import MEM_LOBE_START, WORK_IN
    from rotary_vane.mechanics.loop.outputs import OUTPUT_SIZE
    from rotary_vane.mechanics.loop.speed import rotor_motion

    arrays = sim._kernel_context()                # the context arrays the kernel entries take (as Simulation passes)
    kernel_context = context(*arrays)             # the KernelContext that _cross_valley takes
    params, law = sim.params, sim.speed_law
    real_gas = params.pressure_model == "real_gas"
    memory = memory.copy()
    dydt = np.empty(y_start.size)
    out = np.empty(OUTPUT_SIZE)
    lobe = 2.0 * math.pi / LOBES
    stats = {"solver_calls": 0, "bookkeeping_calls": 0, "failed_evaluations": 0, "valley_crossings": 0,
             "mode_changes": 0, "steps": 0}

    def fun(t, y):
        stats["solver_calls"] += 1
        if evaluate_state(t, y, memory, out, dydt, *arrays) != 0:
            stats["failed_evaluations"] += 1
        return dydt.copy()          # the solver keeps references to returned arrays (FSAL)

    start = time.perf_counter()
    solver = DOP853(fun, t_start, y_start.copy(), t_bound=t_start + REVOLUTION, rtol=params.relative_tolerance,
                    atol=tolerance_vector(sim), max_step=params.max_step, first_step=params.initial_step)
    message = None
    while solver.status == "running":
        message = solver.step()
        if solver.status == "failed":
            break
        stats["steps"] += 1
        evaluate_state(solver.t, solver.y, memory, out, dydt, *arrays)   # output row at the new point
        stats["bookkeeping_calls"] += 1
        if _update_memory(out, memory, sim.machine):
            stats["mode_changes"] += 1
        if rotor_motion(solver.t, law)[0] >= memory[MEM_LOBE_START] + lobe:   # stepped over a valley
            _cross_valley(solver.t, solver.y, memory, kernel_context, real_gas)
            stats["valley_crossings"] += 1
            solver.f = fun(solver.t, solver.y)     # refresh the FSAL derivative, as the numba loop does
    wall = time.perf_counter() - start
    # DOP853: 12 evaluations per step attempt (11 stages + f at the new point), 1 at construction
    attempts = (stats["solver_calls"] - 1 - stats["valley_crossings"]) / 12.0
    return {"wall": wall, "status": solver.status, "message": message, "t_end": solver.t,
            "rejected": round(attempts) - stats["steps"],
            "input_power": (solver.y[WORK_IN] - y_start[WORK_IN]) / (solver.t - t_start), **stats}


def evaluate_call_cost(sim, calls: int = 20000) -> float:
    """µs per call of the numba `evaluate_state` from Python (dispatch, unboxing of the context arrays, building the
    context records, one right-hand side with its output row)."""
    from rotary_vane.mechanics.loop.integrators import evaluate_state
    from rotary_vane.mechanics.loop.outputs import OUTPUT_SIZE
    y, memory = sim.state.copy(), sim.memory.copy()
    dydt, out = np.empty(y.size), np.empty(OUTPUT_SIZE)
    args = (memory, out, dydt, *sim._kernel_context())
    evaluate_state(sim.time, y, *args)
    start = time.perf_counter()
    for _ in range(calls):
        evaluate_state(sim.time, y, *args)
    return 1e6 * (time.perf_counter() - start) / calls


def compare_scipy(numba_reference: dict | None) -> None:
    from rotary_vane.mechanics.loop.layout import WORK_IN
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
          f"points; one numba evaluate_state() called from Python costs {call_cost:.2f} us (dispatch, unboxing of "
          f"the context arrays, output row)")
    print(f"valley crossings {s['valley_crossings']}, mode changes {s['mode_changes']}, "
          f"RHS calls with a nonzero status (ignored by scipy) {s['failed_evaluations']}")
    print("note: DOP853 steps over valley crossings (memory switched after the step), the numba loop lands on "
          "them;\n      scipy rejects no step for a contact that opened too deep or an invalid state (status "
          "ignored);\n      rejected steps for scipy are inferred from its 12 evaluations per attempt.")


# 3. start-up -------------------------------------------------------------------------------------------
STARTUP_CODE = """
import json, time
t0 = time.perf_counter()
import rotary_vane.mechanics as mechanics
t1 = time.perf_counter()
sim = mechanics.Simulation(mechanics.CompressorParameters(pressure_model=PRESSURE_MODEL,
                                                          **mechanics.REFERENCE_NUMERICS))
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
    from rotary_vane.kernels.compile_cache import CACHE_ENVIRONMENT_VARIABLE
    heading(f"3. start-up: import mechanics + Simulation({PRESSURE_MODEL}) + advance(1e-4), fresh processes")
    imports, import_wall = run_subprocess(["-c", IMPORT_CODE], {})
    rows = [["import numpy / numba / scipy(+integrate)",
             f"{imports['numpy']:.3f} / {imports['numba']:.3f} / {imports['scipy']:.3f}", "", "",
             f"{imports['total']:.3f}", f"{import_wall:.3f}"]]
    with tempfile.TemporaryDirectory(prefix="kernel_cache_") as cache:
        for label in (f"cold (empty {CACHE_ENVIRONMENT_VARIABLE})", f"cached (same {CACHE_ENVIRONMENT_VARIABLE})"):
            r, wall = run_subprocess(["-c", f"PRESSURE_MODEL = {PRESSURE_MODEL!r}" + STARTUP_CODE],
                                     {CACHE_ENVIRONMENT_VARIABLE: cache})
            rows.append([label, f"{r['import']:.3f}", f"{r['build']:.3f}", f"{r['advance']:.3f}",
                         f"{r['total']:.3f}", f"{wall:.3f}"])
    print(table(["case", "import [s]", "Simulation() [s]", "advance [s]", "total [s]", "process [s]"], rows))
    print("(mechanics imports numpy and numba, not scipy; 'process' includes interpreter start-up and exit)")


# 4. summary --------------------------------------------------------------------------------------------
def summary(results: list[dict]) -> None:
    heading("4. summary")
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
                        help="smoke run: 1 revolution, 1 repeat")
    args = parser.parse_args()
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
    startup_costs()
    summary(results)
    if source_fingerprint() != fingerprint:
        print(f"\n!! mechanics/ or thermo/ changed during the run ({fingerprint} -> {source_fingerprint()}): "
              f"subprocess figures (part 3) may belong to a different version than parts 1, 2")


if __name__ == "__main__":
    main()
