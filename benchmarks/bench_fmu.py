"""What the compressor costs, as users run it (issue 9): the FMU through fmpy and the core it wraps, as ratios to the
reference core, plus the first-step latency of a fresh process. Prints tables only; asserts nothing.

Run from anywhere:  python benchmarks/bench_fmu.py [--fmu PATH] [--repeats N] [--stop-time T] [--quick]

Operating point: z = 3, 1500 rpm, slot = stator clearance = 0.05 mm, `--stop-time` (1 s) simulated after a warm-up
run that loads the compiled kernels. Walls count the stepping only (the core after `Simulation()`, the doStep loop
after exitInitializationMode), except `simulate_fmu`, whose wall includes the FMU's initialization (what its user
waits for). Every case runs in its own process; the median of `--repeats` runs is
reported with the range. The *reference core* is the Level 0.5 model (`pressure_model = "ideal_gas_table"`) at the
reference tolerances (REFERENCE_NUMERICS: rtol 1e-6, max_step 2e-5 s) advanced in one call; every wall is also given
as a ratio to it and as a real-time factor (simulated / wall time, > 1 is faster than real time).

1. Core cases (mechanics.Simulation, keep_history=False): both pressure models at the reference and the default
   tolerances in one advance, and stepped per communication step exactly as the FMU's do_step does (new speed
   held, per-step shaft torque), with the integrator's accepted steps per revolution and the cost per step.
2. FMU cases (fmpy): `simulate_fmu` (what a user of fmpy gets: the recorder reads every output after every step)
   and a bare loop of the low-level `fmi2DoStep`; the glue per communication step is (bare doStep loop - core
   stepped alike) / steps.
3. First-step latency: a fresh process with a warm cache, and with an empty cache folder (ROTARY_VANE_CACHE_DIR),
   from `import fmpy` to the end of the first doStep (h = 1 ms), by phase; each case `--repeats` times (an empty
   folder each time), medians with the range of instantiate -> first doStep, and the CPU time of that span (what
   it would take on an idle machine). `--latency-only` skips 1-2, and prints the machine's load averages before
   and after.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
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
LEVEL_HALF, REAL_GAS = "ideal_gas_table", "real_gas"
REFERENCE = "reference"                   # REFERENCE_NUMERICS
DEFAULT = "default"                       # the declared defaults
WORKER_FLAG = "--worker"
# (label, kind, pressure model, tolerances, communication step or None for one advance)
CASES = (
    ("reference core: Level 0.5, reference tol., one advance", "core", LEVEL_HALF, REFERENCE, None),
    ("core Level 0.5, default tol., one advance", "core", LEVEL_HALF, DEFAULT, None),
    ("core real gas, reference tol., one advance", "core", REAL_GAS, REFERENCE, None),
    ("core real gas, default tol., one advance", "core", REAL_GAS, DEFAULT, None),
    ("core Level 0.5, default tol., stepped h = 0.1 ms", "core", LEVEL_HALF, DEFAULT, 1e-4),
    ("core real gas, default tol., stepped h = 1 ms", "core", REAL_GAS, DEFAULT, 1e-3),
    ("FMU Level 0.5 doStep loop, h = 0.1 ms", "doStep", LEVEL_HALF, DEFAULT, 1e-4),
    ("FMU real gas doStep loop, h = 1 ms", "doStep", REAL_GAS, DEFAULT, 1e-3),
    ("FMU Level 0.5 fmpy simulate_fmu, h = 0.1 ms", "simulate_fmu", LEVEL_HALF, DEFAULT, 1e-4),
    ("FMU real gas fmpy simulate_fmu, h = 1 ms", "simulate_fmu", REAL_GAS, DEFAULT, 1e-3),
)


def parameters(model: str, tolerances: str) -> dict:
    from rotary_vane.mechanics import REFERENCE_NUMERICS
    values = dict(pressure_model=model, slot_clearance=CLEARANCE, stator_clearance=CLEARANCE)
    return {**values, **(REFERENCE_NUMERICS if tolerances == REFERENCE else {})}


# workers (each in its own process) -------------------------------------------------------------------------
def core_worker(args: dict) -> dict:
    from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
    from rotary_vane.mechanics.loop.layout import WORK_IN
    params = CompressorParameters(**parameters(args["model"], args["tolerances"]))
    h, stop = args["step"], args["stop_time"]

    def one_run(end: float):
        # from the FMU's start (initial_rotor_angle = 0), so the stepped core integrates exactly what the FMU does
        sim = Simulation(params, constant_speed(RPM), keep_history=False, initial_angle=0.0)
        start = time.perf_counter()
        if h is None:
            sim.advance(end)
        else:                                            # as fmu_src.compressor: speed input, per-step torque
            for k in range(1, round(end / h) + 1):
                work, angle = sim.state[WORK_IN], sim.rotor_angle
                sim.advance(k * h, speed_rpm=RPM, interpolate=True)
                (sim.state[WORK_IN] - work) / (sim.rotor_angle - angle)
        return time.perf_counter() - start, int(sim.counters[0])

    one_run(0.01)
    runs = [one_run(stop) for _ in range(args["repeats"])]
    return {"walls": [w for w, _ in runs], "accepted": runs[-1][1]}


def fmu_worker(args: dict) -> dict:
    from fmpy import extract, read_model_description, simulate_fmu
    from fmpy.simulation import instantiate_fmu
    unzipdir = extract(args["fmu"])
    description = read_model_description(unzipdir)
    refs = {v.name: v.valueReference for v in description.modelVariables}
    fmu = instantiate_fmu(unzipdir, description, "CoSimulation")
    h, stop = args["step"], args["stop_time"]
    reals = {k: v for k, v in parameters(args["model"], args["tolerances"]).items() if k != "pressure_model"}
    start_values = dict(reals, shaft_speed=RPM, pressure_model=args["model"])

    def one_run(end: float) -> float:
        start = time.perf_counter()
        if args["kind"] == "simulate_fmu":
            simulate_fmu(unzipdir, model_description=description, fmu_instance=fmu, stop_time=end,
                         output_interval=h, start_values=start_values)
        else:
            fmu.setupExperiment(startTime=0.0)
            fmu.setReal([refs[n] for n in reals] + [refs["shaft_speed"]], list(reals.values()) + [RPM])
            fmu.setString([refs["pressure_model"]], [args["model"]])
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            do_step, component = fmu.fmi2DoStep, fmu.component
            start = time.perf_counter()
            for k in range(round(end / h)):
                do_step(component, k * h, h, 1)
            fmu.terminate()
        wall = time.perf_counter() - start
        fmu.reset()
        return wall

    one_run(0.01)
    walls = [one_run(stop) for _ in range(args["repeats"])]
    fmu.freeInstance()
    shutil.rmtree(unzipdir, ignore_errors=True)         # fmpy's extract made it (40 MB); nothing else removes it
    return {"walls": walls}


def latency_worker(args: dict) -> dict:
    t0 = time.perf_counter()
    from fmpy import extract, read_model_description
    from fmpy.simulation import instantiate_fmu
    t1, cpu1 = time.perf_counter(), time.process_time()
    unzipdir = extract(args["fmu"])
    description = read_model_description(unzipdir)
    fmu = instantiate_fmu(unzipdir, description, "CoSimulation")
    t2 = time.perf_counter()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    t3 = time.perf_counter()
    fmu.doStep(0.0, 1e-3)
    t4, cpu4 = time.perf_counter(), time.process_time()
    fmu.terminate()
    fmu.freeInstance()
    shutil.rmtree(unzipdir, ignore_errors=True)
    return {"import fmpy": t1 - t0, "extract + instantiate": t2 - t1, "initialize": t3 - t2,
            "first doStep": t4 - t3, "instantiate -> first doStep": t4 - t1,
            "CPU instantiate -> first doStep": cpu4 - cpu1}


def run_worker(arguments: dict, env: dict | None = None) -> dict:
    done = subprocess.run([sys.executable, str(Path(__file__).resolve()), WORKER_FLAG, json.dumps(arguments)],
                          cwd=tempfile.gettempdir(), env=dict(os.environ, **(env or {})), capture_output=True,
                          text=True, timeout=3600)
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"worker {arguments} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return json.loads(lines[-1])


def build_fmu(out_dir: Path, *options: str) -> Path:
    done = subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", str(out_dir), *options],
                          cwd=REPO_ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"FMU build failed:\n{done.stdout}\n{done.stderr}")
    return out_dir / f"{MODEL}.fmu"


# report -------------------------------------------------------------------------------------------------------
def stepping(fmu: Path, stop: float, repeats: int) -> None:
    heading(f"1-2. cost of {stop:g} s simulated, z = 3, {RPM:.0f} rpm, c = {1e3 * CLEARANCE:g} mm (median of {repeats} "
            f"runs, each case in its own process)")
    results = {}
    for label, kind, model, tolerances, step in CASES:
        worker_kind = "core" if kind == "core" else "fmu"
        results[label] = run_worker({"worker": worker_kind, "kind": kind, "model": model, "tolerances": tolerances,
                                     "step": step, "stop_time": stop, "repeats": repeats, "fmu": str(fmu)})
    reference = statistics.median(results[CASES[0][0]]["walls"])
    revolutions = stop * RPM / 60.0
    rows = []
    for label, kind, model, tolerances, step in CASES:
        walls = results[label]["walls"]
        wall = statistics.median(walls)
        accepted = results[label].get("accepted")
        rows.append([label, f"{1e3 * wall:.1f}", f"{1e3 * min(walls):.1f}-{1e3 * max(walls):.1f}",
                     f"{stop / wall:.2f}", f"{wall / reference:.2f}",
                     f"{accepted / revolutions:.0f}" if accepted else "-",
                     f"{1e6 * wall / accepted:.2f}" if accepted else "-"])
    print(table(["case", "wall [ms]", "range [ms]", "real-time factor", "/ reference core", "steps/rev",
                 "us/step"], rows))
    for fmu_label, core_label, step in (("FMU Level 0.5 doStep loop, h = 0.1 ms",
                                         "core Level 0.5, default tol., stepped h = 0.1 ms", 1e-4),
                                        ("FMU real gas doStep loop, h = 1 ms",
                                         "core real gas, default tol., stepped h = 1 ms", 1e-3)):
        glue = (statistics.median(results[fmu_label]["walls"]) - statistics.median(results[core_label]["walls"]))
        print(f"glue per communication step at h = {1e3 * step:g} ms: {1e6 * glue / round(stop / step):.1f} us "
              f"(bare doStep loop minus the core stepped alike)")
    print("targets of issue 9: real-gas FMU through fmpy at h = 1 ms <= 1.0x the reference core; Level 0.5 through "
          "fmpy at h = 0.1 ms <= 1.3x; glue <= 30 us per step")


def latency(fmu: Path, without_kernels: Path | None, repeats: int) -> None:
    heading(f"3. first-step latency of a fresh process (defaults: real gas, R134a; medians of {repeats})")
    phases = ("import fmpy", "extract + instantiate", "initialize", "first doStep", "instantiate -> first doStep",
              "CPU instantiate -> first doStep")
    rows = []
    with tempfile.TemporaryDirectory(prefix="rvc_cache_") as folder:
        def empty():
            return {"ROTARY_VANE_CACHE_DIR": tempfile.mkdtemp(dir=folder)}
        warm = empty()
        cases = [("empty cache folder", fmu, empty),
                 ("warm (the same folder again)", fmu, lambda: warm),
                 ("warm (the user's cache)", fmu, lambda: None)]
        if without_kernels is not None:
            cases.append(("empty cache folder, FMU built --no-kernels", without_kernels, empty))
        run_worker({"worker": "latency", "fmu": str(fmu)}, warm)            # fills the folder the warm case reads
        for label, path, env in cases:
            runs = [run_worker({"worker": "latency", "fmu": str(path)}, env()) for _ in range(repeats)]
            total = [r["instantiate -> first doStep"] for r in runs]
            rows.append([label] + [f"{statistics.median(r[k] for r in runs):.3f}" for k in phases]
                        + [f"{min(total):.3f}-{max(total):.3f}"])
    print(table(["case", "import fmpy [s]", "extract+instantiate [s]", "initialize [s]", "first doStep [s]",
                 "instantiate -> 1st step [s]", "its CPU time [s]", "range [s]"], rows))
    print("targets of issue 9: warm <= 1 s, empty cache <= 5 s (instantiate -> end of the first doStep)")


def worker(text: str) -> None:
    args = json.loads(text)
    result = {"core": core_worker, "fmu": fmu_worker, "latency": latency_worker}[args["worker"]](args)
    print(json.dumps(result), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", type=Path, help="an existing RotaryVaneCompressor.fmu (default: build one)")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per case (median reported)")
    parser.add_argument("--stop-time", type=float, default=1.0, help="simulated time per run [s]")
    parser.add_argument("--quick", action="store_true", help="smoke run: 0.02 s simulated, 1 repeat")
    parser.add_argument("--latency-only", action="store_true", help="only the first-step latency (3.)")
    parser.add_argument(WORKER_FLAG, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.worker)
        return
    stop, repeats = (0.02, 1) if args.quick else (args.stop_time, args.repeats)
    import fmpy
    import numba
    import numpy
    print(f"python {sys.version.split()[0]}, numpy {numpy.__version__}, numba {numba.__version__}, "
          f"fmpy {fmpy.__version__}, {os.cpu_count()} CPUs")
    with tempfile.TemporaryDirectory(prefix="rvc_fmu_") as folder:
        fmu = args.fmu.resolve() if args.fmu else build_fmu(Path(folder))
        if not fmu.is_file():
            parser.error(f"'--fmu' = {str(args.fmu)!r} is not a file")
        without_kernels = None if args.fmu else build_fmu(Path(folder) / "no_kernels", "--no-kernels")
        print(f"FMU: {fmu}")
        if not args.latency_only:
            stepping(fmu, stop, repeats)
        print(f"load averages (1, 5, 15 min) before: {os.getloadavg()}")
        latency(fmu, without_kernels, repeats)
        print(f"load averages after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
