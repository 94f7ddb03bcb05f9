"""Two builds of the compressor FMU side by side (issue 25): the same doStep loop, interleaved, on one machine.

Run from anywhere:
    python benchmarks/bench_speedup.py --baseline OLD.fmu [--candidate NEW.fmu] [--repeats N] [--stop-time T]

Each case is what a user of the default FMU runs: fmpy's low-level `fmi2DoStep` loop, h = 1 ms, `--stop-time`
(1 s) at 1500 rpm, z = 3, slot = stator clearance c, defaults otherwise; both pressure models, c = 0, 0.05 and
0.2 mm. Every timed run is a fresh process (one FMU loaded, a 10 ms warm-up run that loads its kernels, then the
timed run), and the baseline and candidate runs alternate, so a change in the machine's load falls on both.
Reported: the medians of CPU time (process time) and wall of the doStep loop, the speed-up (baseline / candidate,
from CPU time), the candidate's real-time factor (simulated / wall) and the input power at the end, which should
agree between the builds within the numerics bounds. Without --candidate the current checkout is built.
Prints tables only; asserts nothing.
"""
from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from report import heading, table  # benchmarks/ is the script's folder

REPO_ROOT = Path(__file__).resolve().parents[1]
RPM = 1500.0
STEP = 1e-3                                             # s, communication step
CLEARANCES = (0.0, 0.05e-3, 0.2e-3)                     # m, slot and stator
MODELS = ("real_gas", "ideal_gas_table")
WORKER_FLAG = "--worker"


def worker(args: dict) -> dict:
    """One FMU, one case: warm-up, then the timed doStep loop; CPU time, wall and the input power at the end."""
    from fmpy import extract, read_model_description
    from fmpy.simulation import instantiate_fmu
    unzipdir = extract(args["fmu"])
    description = read_model_description(unzipdir)
    refs = {v.name: v.valueReference for v in description.modelVariables}
    fmu = instantiate_fmu(unzipdir, description, "CoSimulation")
    reals = {"slot_clearance": args["clearance"], "stator_clearance": args["clearance"], "shaft_speed": RPM}

    def one_run(end: float) -> tuple[float, float, float]:
        fmu.setupExperiment(startTime=0.0)
        fmu.setReal([refs[n] for n in reals], list(reals.values()))
        fmu.setString([refs["pressure_model"]], [args["model"]])
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        do_step, component = fmu.fmi2DoStep, fmu.component
        cpu, wall = time.process_time(), time.perf_counter()
        for k in range(round(end / STEP)):
            if do_step(component, k * STEP, STEP, 1) > 1:           # fmi2OK or fmi2Warning
                raise RuntimeError(f"doStep at t = {k * STEP:g} s returned an error status")
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        power = fmu.getReal([refs["input_power"]])[0]
        fmu.terminate()
        fmu.reset()
        return cpu, wall, power

    one_run(0.01)
    cpu, wall, power = one_run(args["stop_time"])
    fmu.freeInstance()
    shutil.rmtree(unzipdir, ignore_errors=True)         # fmpy's extract made it (40 MB); nothing else removes it
    return {"cpu": cpu, "wall": wall, "input_power": power}


def run_worker(fmu: Path, model: str, clearance: float, stop: float) -> dict:
    payload = json.dumps({"fmu": str(fmu), "model": model, "clearance": clearance, "stop_time": stop})
    done = subprocess.run([sys.executable, __file__, WORKER_FLAG, payload], capture_output=True, text=True,
                          check=False)
    if done.returncode != 0:
        raise RuntimeError(f"worker for {fmu.name} ({model}, c = {clearance:g} m) failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def build_fmu(folder: Path) -> Path:
    subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", str(folder)], check=True,
                   cwd=REPO_ROOT, capture_output=True)
    return folder / "RotaryVaneCompressor.fmu"


def compare(baseline: Path, candidate: Path, stop: float, repeats: int) -> None:
    heading(f"doStep loop, h = 1 ms, {stop:g} s at {RPM:.0f} rpm (median of {repeats} interleaved runs)")
    rows = []
    for model in MODELS:
        for clearance in CLEARANCES:
            runs = {"baseline": [], "candidate": []}
            for _ in range(repeats):
                for name, fmu in (("baseline", baseline), ("candidate", candidate)):
                    runs[name].append(run_worker(fmu, model, clearance, stop))
            median = {name: {key: statistics.median(r[key] for r in result) for key in ("cpu", "wall")}
                      for name, result in runs.items()}
            power = {name: result[-1]["input_power"] for name, result in runs.items()}
            rows.append([model, f"{1e3 * clearance:g}",
                         f"{median['baseline']['cpu']:.3f}", f"{median['candidate']['cpu']:.3f}",
                         f"{median['baseline']['cpu'] / median['candidate']['cpu']:.2f}",
                         f"{stop / median['candidate']['wall']:.2f}",
                         f"{power['baseline']:.2f}", f"{power['candidate']:.2f}",
                         f"{power['candidate'] / power['baseline'] - 1:+.1e}"])
            print(f"  {model}, c = {1e3 * clearance:g} mm done", flush=True)
    print(table(["pressure model", "c [mm]", "baseline CPU [s]", "candidate CPU [s]", "speed-up",
                 "candidate x real time", "P_in baseline [W]", "P_in candidate [W]", "P_in rel. diff"], rows))
    print("speed-up = baseline CPU / candidate CPU; x real time = simulated / wall of the candidate's doStep loop")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="the earlier RotaryVaneCompressor.fmu")
    parser.add_argument("--candidate", type=Path, help="the FMU to compare (default: build this checkout's)")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per build and case (median reported)")
    parser.add_argument("--stop-time", type=float, default=1.0, help="simulated time per run [s]")
    parser.add_argument(WORKER_FLAG, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(json.loads(args.worker))), flush=True)
        return
    if args.baseline is None:
        parser.error("--baseline (the earlier RotaryVaneCompressor.fmu) is required")
    for flag, path in (("--baseline", args.baseline), ("--candidate", args.candidate)):
        if path is not None and not path.is_file():
            parser.error(f"{flag} = {str(path)!r} is not a file")
    with tempfile.TemporaryDirectory(prefix="rvc_speedup_") as folder:
        candidate = args.candidate.resolve() if args.candidate else build_fmu(Path(folder))
        print(f"baseline: {args.baseline.resolve()}\ncandidate: {candidate}")
        compare(args.baseline.resolve(), candidate, args.stop_time, args.repeats)


if __name__ == "__main__":
    main()
