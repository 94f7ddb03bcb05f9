"""Benchmark of RotaryVaneCompressor.fmu through fmpy against the core it wraps (issue 4): prints tables only.

Run from anywhere:  python benchmarks/bench_fmu.py [--fmu PATH] [--repeats N] [--stop-time T] [--quick]

Operating point: 1500 rpm, c = slot = stator clearance = 0.05 mm, 0.2 s simulated, communication steps 1e-4 s
and 1e-3 s. Every case runs in a fresh process (every FMU run in its own process, as in the tests), first a
warm-up run that loads the compiled kernels, then `repeats` timed runs; the median is reported.

1. Stepping cost. FMU cases (debug logging on, no call logger):
     fmpy simulate_fmu  - simulate_fmu on one instance reset between runs: input handling, doStep, the recorder
                          reading every output after every step (what a user of fmpy gets), setup/init included
     low-level doStep   - fmpy.fmi2.FMU2Slave: a bare loop of doStep
     low-level set+step+get - setReal(shaft_speed), doStep, getReal(shaft_torque_mean) per step (a master's loop)
   Core cases (mechanics.Simulation of this checkout, keep_history=False):
     core stepped as the glue - advance(t + h, speed_rpm, interpolate=True) per step with a RevolutionMonitor,
                          exactly the work the FMU's do_step asks for
     core stepped plain  - advance(t + h) per step, speed law untouched (no integrator restart per step)
     core one advance    - advance(0.2) once, with the RevolutionMonitor
   Walls include the setup (FMU: setupExperiment ... exitInitializationMode; core: Simulation() + monitor).
   Figures: wall per simulated second, ratio to the core stepped as the glue and to the core in one advance (the
   issue's target: the FMU at most 10 % slower than the core - reported, not asserted), wrapper overhead per
   communication step in µs = (FMU wall - core-as-glue wall) / steps, and the integrator's accepted steps and
   right-hand-side evaluations of the core cases (what the communication step costs inside the core).
2. First-step latency of the FMU in fresh processes, by phase, median of 3 processes per case (fmpy unpacks the FMU
   to a new temporary folder each time): an empty ROTARY_VANE_CACHE_DIR with the kernels the FMU ships; an empty
   one with the same sources built `--no-kernels` (numba compiles, as an FMU whose kernels do not fit the machine);
   and that FMU again with the cache the compiling run filled (warm).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from report import heading, table  # benchmarks/ is the script's folder

REPO_ROOT = Path(__file__).resolve().parents[1]
MODEL = "RotaryVaneCompressor"
RPM = 1500.0
CLEARANCE = 0.05e-3                       # m, slot and stator
STEP_SIZES = (1e-4, 1e-3)
WORKER_FLAG = "--worker"
TARGET_SLOWDOWN = 0.10                    # the issue: FMU at most 10 % slower than the core
LATENCY_REPEATS = 3                       # fresh processes per first-step latency case (median)
CRASHES: list[str] = []                  # worker processes that crashed (before or after reporting)
COUNTER_NAMES = ("accepted", "rejected", "evaluations", "valley_crossings", "mode_changes", "restarts")
FMU_CASES = ("fmpy simulate_fmu", "low-level doStep", "low-level set+step+get")
CORE_CASES = ("core stepped as the glue", "core stepped plain", "core one advance")


# helpers ----------------------------------------------------------------------------------------------------
def run_worker(arguments: dict, env_changes: dict[str, str] | None = None, timeout: float = 600.0,
               attempts: int = 3) -> dict:
    """This file as a worker process with `arguments` (JSON); returns its JSON result and the process wall.
    A worker that crashed (a known FMU bug) is recorded in CRASHES and run again, up to `attempts` times."""
    for attempt in range(1, attempts + 1):
        try:
            return _run_worker_once(arguments, env_changes, timeout)
        except WorkerCrash as crash:
            CRASHES.append(str(crash))
            if attempt == attempts:
                raise


class WorkerCrash(RuntimeError):
    pass


def _run_worker_once(arguments: dict, env_changes: dict[str, str] | None, timeout: float) -> dict:
    env = dict(os.environ, **(env_changes or {}))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-X", "faulthandler", str(Path(__file__).resolve()), WORKER_FLAG,
                           json.dumps(arguments)],
                          cwd=tempfile.gettempdir(), env=env, capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - start
    lines = done.stdout.strip().splitlines()
    emitted = bool(lines) and lines[-1].startswith("{")
    name = arguments.get("case", arguments["kind"]) + (f" h = {arguments['step']}" if "step" in arguments else "")
    if done.returncode != 0 and not emitted:
        if done.returncode < 0:
            raise WorkerCrash(f"{name}: killed by signal {-done.returncode} before reporting{stderr_tail(done)}")
        raise RuntimeError(f"worker {name} exited with status {done.returncode}:\n{done.stderr[-2000:]}")
    result = json.loads(lines[-1])
    result["process_wall"] = wall
    if done.returncode != 0:                 # the figures are complete; the process died at exit
        CRASHES.append(f"{name}: exit status {done.returncode} after reporting{stderr_tail(done)}")
    return result


def stderr_tail(done) -> str:
    """The first lines of a crashed worker's fault report (faulthandler), indented."""
    lines = [line for line in done.stderr.splitlines() if line.strip() and not line.startswith("[")]
    fault = next((i for i, line in enumerate(lines) if line.startswith("Fatal Python error")), None)
    picked = lines[fault:fault + 4] if fault is not None else lines[-3:]
    return "".join(f"\n      {line[:160]}" for line in picked)


def build_fmu(out_dir: Path, *options: str) -> Path:
    done = subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", str(out_dir), *options],
                          cwd=REPO_ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"FMU build failed:\n{done.stdout}\n{done.stderr}")
    return out_dir / f"{MODEL}.fmu"


# workers (run in their own processes) --------------------------------------------------------------------------
def fmu_worker(args: dict) -> dict:
    """Time one FMU case: a warm-up run, then `repeats` timed runs on one instance (fmi2Reset between runs)."""
    from fmpy import extract, read_model_description, simulate_fmu
    from fmpy.simulation import instantiate_fmu

    unzipdir = extract(args["fmu"])
    description = read_model_description(unzipdir)
    refs = {v.name: v.valueReference for v in description.modelVariables}
    fmu = instantiate_fmu(unzipdir, description, "CoSimulation", debug_logging=True)
    h, stop, case = args["step"], args["stop_time"], args["case"]
    steps = round(stop / h)
    start_values = {"shaft_speed": RPM, "slot_clearance": CLEARANCE, "stator_clearance": CLEARANCE}

    def initialize():
        fmu.setupExperiment(startTime=0.0)
        fmu.setReal([refs[name] for name in start_values], list(start_values.values()))
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()

    def one_run(timed_steps: int) -> tuple[float, float, float | None]:
        """(wall of setup + stepping, shaft work at the end, wall of the setup alone if measurable)"""
        if case == "fmpy simulate_fmu":
            setup = None
            start = time.perf_counter()
            result = simulate_fmu(unzipdir, model_description=description, fmu_instance=fmu, stop_time=timed_steps * h,
                                  output_interval=h, start_values=start_values, debug_logging=True)
            wall = time.perf_counter() - start
            if abs(result["time"][-1] - timed_steps * h) > 1e-9:
                raise RuntimeError(f"simulate_fmu stopped at {result['time'][-1]} s")
            work = float(result["shaft_work"][-1])
        else:
            start = time.perf_counter()
            initialize()
            setup = time.perf_counter() - start
            do_step, component = fmu.fmi2DoStep, fmu.component
            if case == "low-level doStep":
                for k in range(timed_steps):
                    do_step(component, k * h, h, 1)
                wall = time.perf_counter() - start
            else:
                speed, torque = [refs["shaft_speed"]], [refs["shaft_torque_mean"]]
                for k in range(timed_steps):
                    fmu.setReal(speed, [RPM])
                    do_step(component, k * h, h, 1)
                    fmu.getReal(torque)
                wall = time.perf_counter() - start
            work = fmu.getReal([refs["shaft_work"]])[0]
            fmu.terminate()
        fmu.reset()
        return wall, work, setup

    one_run(max(1, round(0.01 / h)))                     # warm-up: load the kernels, first steps
    walls, setups, work = [], [], None
    for _ in range(args["repeats"]):
        wall, work, setup = one_run(steps)
        walls.append(wall)
        setups.append(setup)
    fmu.freeInstance()
    return {"walls": walls, "setups": setups, "steps": steps, "shaft_work": work}


def core_worker(args: dict) -> dict:
    """Time one core case with mechanics.Simulation of this checkout."""
    from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
    from rotary_vane.mechanics.layout import WORK_IN
    from rotary_vane.mechanics.performance import RevolutionMonitor

    params = CompressorParameters(slot_clearance=CLEARANCE, stator_clearance=CLEARANCE)
    h, stop, case = args["step"], args["stop_time"], args["case"]
    steps = round(stop / h)

    def one_run(end: float):
        start = time.perf_counter()
        monitor = RevolutionMonitor(params)
        sim = Simulation(params, constant_speed(RPM), initial_angle=0.0, keep_history=False, table_speed_rpm=RPM,
                         observers=[monitor])
        setup = time.perf_counter() - start
        count = round(end / h)
        if case == "core one advance":
            sim.advance(end)
        elif case == "core stepped plain":
            for _ in range(count):
                sim.advance(sim.time + h)
        else:                                            # as fmu_src.compressor.CompressorSlave.advance
            for _ in range(count):
                work_before, angle_before = sim.state[WORK_IN], sim.rotor_angle
                sim.advance(sim.time + h, speed_rpm=RPM, interpolate=True)
                (sim.state[WORK_IN] - work_before) / max(sim.rotor_angle - angle_before, 1e-300)
                sim.outputs                              # noqa: B018 - the glue reads the last output row
        wall = time.perf_counter() - start
        return wall, float(sim.state[WORK_IN]), dict(zip(COUNTER_NAMES, sim.counters.tolist())), setup

    one_run(0.01)                                        # warm-up
    walls, setups, work, counters = [], [], None, None
    for _ in range(args["repeats"]):
        wall, work, counters, setup = one_run(stop)
        walls.append(wall)
        setups.append(setup)
    return {"walls": walls, "setups": setups, "steps": steps, "shaft_work": work, "counters": counters}


def latency_worker(args: dict) -> dict:
    """Phases of a fresh process up to the end of the FMU's first do_step."""
    t0 = time.perf_counter()
    from fmpy import extract, read_model_description
    from fmpy.simulation import instantiate_fmu
    t1 = time.perf_counter()
    unzipdir = extract(args["fmu"])
    description = read_model_description(unzipdir)
    t2 = time.perf_counter()
    fmu = instantiate_fmu(unzipdir, description, "CoSimulation", debug_logging=True)
    t3 = time.perf_counter()
    refs = {v.name: v.valueReference for v in description.modelVariables}
    fmu.setupExperiment(startTime=0.0)
    fmu.setReal([refs["shaft_speed"], refs["slot_clearance"], refs["stator_clearance"]], [RPM, CLEARANCE, CLEARANCE])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    t4 = time.perf_counter()
    fmu.doStep(0.0, 1e-3)
    t5 = time.perf_counter()
    fmu.terminate()
    fmu.freeInstance()
    return {"import fmpy": t1 - t0, "extract + read": t2 - t1, "instantiate": t3 - t2, "initialize": t4 - t3,
            "first do_step": t5 - t4, "total": t5 - t0, "unzipdir": str(unzipdir)}


def worker(arguments: str) -> None:
    args = json.loads(arguments)
    kind = args["kind"]
    result = {"fmu": fmu_worker, "core": core_worker, "latency": latency_worker}[kind](args)
    print(json.dumps(result), flush=True)


# report ---------------------------------------------------------------------------------------------------------
def stepping(fmu: Path, stop_time: float, repeats: int) -> None:
    heading(f"1. stepping cost: {stop_time:g} s simulated at {RPM:.0f} rpm, c = {1e3 * CLEARANCE:g} mm, "
            f"median of {repeats} runs after a warm-up, one process per case")
    results: dict[tuple[str, float | None], dict] = {}
    for h in STEP_SIZES:
        for case in FMU_CASES:
            results[(case, h)] = run_worker({"kind": "fmu", "case": case, "fmu": str(fmu), "step": h,
                                             "stop_time": stop_time, "repeats": repeats})
        for case in CORE_CASES[:2]:
            results[(case, h)] = run_worker({"kind": "core", "case": case, "step": h, "stop_time": stop_time,
                                             "repeats": repeats})
    results[("core one advance", None)] = run_worker({"kind": "core", "case": "core one advance",
                                                      "step": STEP_SIZES[-1], "stop_time": stop_time,
                                                      "repeats": repeats})
    one = statistics.median(results[("core one advance", None)]["walls"])
    rows = []
    for (case, h), r in results.items():
        wall = statistics.median(r["walls"])
        glue = statistics.median(results[("core stepped as the glue", h)]["walls"]) if h is not None else None
        is_fmu = case in FMU_CASES
        setup = "incl." if r["setups"][0] is None else f"{1e3 * statistics.median(r['setups']):.1f}"
        rows.append([
            case, "-" if h is None else f"{h:g}", str(r["steps"]) if h is not None else "1", setup,
            f"{wall / stop_time:.3f}", f"{min(r['walls']) / stop_time:.3f}-{max(r['walls']) / stop_time:.3f}",
            f"{wall / glue:.2f}" if glue else "-", f"{wall / one:.2f}",
            f"{1e6 * (wall - glue) / r['steps']:.1f}" if is_fmu else "-",
            str(r["counters"]["accepted"]) if "counters" in r else "-",
            str(r["counters"]["evaluations"]) if "counters" in r else "-",
            f"{r['shaft_work']:.4f}"])
    print(table(["case", "h [s]", "steps", "setup [ms]", "wall/sim s [s]", "min-max", "/ core glue", "/ core 1 adv",
                 "overhead/step [us]", "acc steps", "RHS evals", "W_shaft [J]"], rows))
    print("(walls include the setup: FMU setupExperiment ... exitInitializationMode, core Simulation() + monitor;\n"
          " '/ core glue': ratio to the core advanced per step as the FMU's glue does; 'overhead/step': extra wall "
          "per communication step over that core case;\n 'acc steps', 'RHS evals': the core's integrator in the "
          "last timed run - a restart at every communication step costs steps)")
    for h in STEP_SIZES:
        fmu_wall = statistics.median(results[("fmpy simulate_fmu", h)]["walls"])
        glue = statistics.median(results[("core stepped as the glue", h)]["walls"])
        slowdown = fmu_wall / glue - 1.0
        print(f"h = {h:g} s: FMU through fmpy is {100 * slowdown:+.1f} % vs the core stepped alike, "
              f"{100 * (fmu_wall / one - 1.0):+.1f} % vs the core in one advance "
              f"(target: at most +{100 * TARGET_SLOWDOWN:.0f} %: "
              f"{'met' if slowdown <= TARGET_SLOWDOWN else 'NOT met'} vs the core stepped alike)")


def latency(fmu: Path, compiling_fmu: Path, repeats: int) -> None:
    heading(f"2. first-step latency of the FMU in fresh processes (import fmpy ... end of the first do_step), median "
            f"of {repeats} processes")
    phases = ("import fmpy", "extract + read", "instantiate", "initialize", "first do_step", "total")
    rows, notes = [], []
    with tempfile.TemporaryDirectory(prefix="rvc_cache_") as folder:
        caches = []
        for label, path, warm in (("empty cache, kernels shipped in the FMU", fmu, False),
                                  ("empty cache, built --no-kernels (compiles)", compiling_fmu, False),
                                  ("warm cache, built --no-kernels", compiling_fmu, True)):
            results = []
            for _ in range(repeats):
                if not warm:                         # a new empty cache folder for each process
                    caches.append(Path(folder) / f"cache_{len(caches)}")
                results.append(run_worker({"kind": "latency", "fmu": str(path)},
                                          {"ROTARY_VANE_CACHE_DIR": str(caches[-1])}))
            rows.append([label] + [f"{statistics.median(r[phase] for r in results):.3f}" for phase in phases]
                        + [f"{statistics.median(r['process_wall'] for r in results):.3f}"])
            kernels = sum(1 for _ in caches[-1].rglob("*.nb[ic]"))
            notes.append(f"{label}: {len({r['unzipdir'] for r in results})} unpack folders, {kernels} kernel cache "
                         f"files after the runs")
    print(table(["case", *(f"{phase} [s]" for phase in phases), "process [s]"], rows))
    print("(" + "; ".join(notes) + "; 'process' includes interpreter start-up and exit)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", type=Path, help="an existing RotaryVaneCompressor.fmu (default: build one)")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per case (median reported)")
    parser.add_argument("--stop-time", type=float, default=0.2, help="simulated time per run [s]")
    parser.add_argument("--quick", action="store_true", help="smoke run: 0.02 s simulated, 1 repeat")
    parser.add_argument(WORKER_FLAG, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.worker)
        return
    stop_time, repeats = (0.02, 1) if args.quick else (args.stop_time, args.repeats)
    latency_repeats = 1 if args.quick else LATENCY_REPEATS
    import fmpy
    import numba
    import numpy
    print(f"python {sys.version.split()[0]}, numpy {numpy.__version__}, numba {numba.__version__}, "
          f"fmpy {fmpy.__version__}, {os.cpu_count()} CPUs")
    with tempfile.TemporaryDirectory(prefix="rvc_fmu_") as folder:
        fmu = args.fmu if args.fmu else build_fmu(Path(folder) / "shipped")
        compiling_fmu = build_fmu(Path(folder) / "compiling", "--no-kernels")
        print(f"FMU: {fmu}{' (built from this checkout)' if not args.fmu else ''}; for the compiling cases: "
              f"this checkout built --no-kernels")
        stepping(fmu, stop_time, repeats)
        latency(fmu, compiling_fmu, latency_repeats)
    if CRASHES:
        print(f"\n!! {len(CRASHES)} worker process crash(es); crashed runs were repeated:\n   "
              + "\n   ".join(CRASHES))


if __name__ == "__main__":
    main()
