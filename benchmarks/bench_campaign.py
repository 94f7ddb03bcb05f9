"""Benchmark of the dask campaign runner examples/campaign.py (issue 6): the clearance study on 1 and 2 workers.

Run from anywhere:  python benchmarks/bench_campaign.py [--fmu PATH] [--workers 1,2] [--stop-time 0.5] [--repeats 3]

The study: slot clearance = stator clearance in {0, 0.02, 0.05, 0.1, 0.2} mm x {1000, 1500, 2000} rpm = 15 points,
0.5 s simulated each, communication step 1 ms. A one-point campaign first fills the numba cache (not timed).
For each worker count a LocalCluster of worker processes is started (timed: "cluster start"), then the campaign
runs on it through `run_campaign(scheduler=address)` into a new store ("first wall": each worker instantiates the
FMU and loads the compiled kernels at its first point), then the same campaign `repeats` times again, each into
another new store on the same workers ("warm wall", the median: the cost of a campaign once the workers are up).
Per-point figures come from the rows (wall time measured in the worker around one point). Speed-up = wall with
1 worker / wall with n workers.
Prints tables only and asserts nothing; the machine's load average is printed, absolute times are noisy.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from report import heading, table  # benchmarks/ is the script's folder

REPO_ROOT = Path(__file__).resolve().parents[1]
from rotary_vane.examples import campaign  # noqa: E402

CLEARANCES_MM = (0.0, 0.02, 0.05, 0.1, 0.2)
SPEEDS_RPM = (1000.0, 1500.0, 2000.0)


def build_fmu(out_dir: Path) -> Path:
    done = subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", str(out_dir)], cwd=REPO_ROOT,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"FMU build failed:\n{done.stdout}\n{done.stderr}")
    return out_dir / "RotaryVaneCompressor.fmu"


def clearance_study(stop_time: float) -> list[dict]:
    return campaign.grid({("slot_clearance", "stator_clearance"): [c * 1e-3 for c in CLEARANCES_MM],
                          "shaft_speed": list(SPEEDS_RPM)}, fixed={"stop_time": stop_time, "communication_step": 1e-3})


def timed_campaign(fmu: Path, points: list[dict], store: Path, address: str) -> tuple[float, list[dict]]:
    start = time.perf_counter()
    report = campaign.run_campaign(fmu, points, store, scheduler=address, progress=False)
    wall = time.perf_counter() - start
    if report.done != len(points):
        raise RuntimeError(f"{report.failed} points failed: {report.failures[:3]}")
    return wall, campaign.read_store(store)


def measure(fmu: Path, points: list[dict], workers: int, repeats: int, folder: Path) -> dict:
    from distributed import Client, LocalCluster
    start = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.wait_for_workers(workers)
        cluster_start = time.perf_counter() - start
        first_wall, first_rows = timed_campaign(fmu, points, folder / f"first_{workers}.csv", cluster.scheduler_address)
        warm = [timed_campaign(fmu, points, folder / f"warm_{workers}_{k}.csv", cluster.scheduler_address)
                for k in range(repeats)]
    return dict(workers=workers, cluster_start=cluster_start, first_wall=first_wall,
                warm_wall=statistics.median(wall for wall, _ in warm), warm_walls=[wall for wall, _ in warm],
                first_points=[float(r["wall_time"]) for r in first_rows],
                warm_points=[float(r["wall_time"]) for _, rows in warm for r in rows],
                warm_cpu=[float(r["cpu_time"]) for _, rows in warm for r in rows], rows=warm[0][1])


def print_timings(results: list[dict], points: int) -> None:
    heading(f"Clearance study, {points} points: wall time and speed-up")
    base = results[0]
    rows = []
    for r in results:
        rows.append([str(r["workers"]), f"{r['cluster_start']:.2f}", f"{r['first_wall']:.2f}",
                     f"{r['warm_wall']:.2f}", f"{r['warm_wall'] / points:.3f}",
                     f"{base['first_wall'] / r['first_wall']:.2f}", f"{base['warm_wall'] / r['warm_wall']:.2f}",
                     f"{sum(r['warm_points']) / sum(r['warm_walls']):.2f}"])
    print(table(["workers", "cluster start [s]", "first wall [s]", "warm wall [s]", "warm wall/point [s]",
                 "speed-up first", "speed-up warm", "busy workers (warm)"], rows))
    print("busy workers = sum of the per-point walls / sum of the campaign walls, warm repeats (the mean number "
          "of workers computing)")
    heading("Per-point time measured in the worker [s]")
    rows = []
    for r in results:
        for label, times in (("first wall", r["first_points"]), ("warm wall", r["warm_points"]),
                             ("warm CPU", r["warm_cpu"])):
            rows.append([f"{r['workers']} worker(s), {label}", f"{min(times):.3f}", f"{statistics.median(times):.3f}",
                         f"{max(times):.3f}", f"{sum(times):.2f}"])
    print(table(["campaign", "min", "median", "max", "sum"], rows))
    print("warm: all repeats together; CPU: the worker thread's CPU time (wall above CPU: waiting for a CPU)")
    print("first: the largest point times include the worker's FMU instantiation and kernel load")


def print_study(rows: list[dict]) -> None:
    heading("The study's results (last completed revolution, from the store)")
    ordered = sorted(rows, key=lambda r: (float(r["shaft_speed"]), float(r["slot_clearance"])))
    print(table(["speed [rpm]", "c [mm]", "P_in [W]", "P_out [W]", "P_fric [W]", "eta_m [%]", "F_max [N]", "modes",
                 "point [s]"],
                [[f"{float(r['shaft_speed']):.0f}", f"{float(r['slot_clearance']) * 1e3:.2f}",
                  f"{float(r['input_power']):.1f}", f"{float(r['output_power']):.1f}",
                  f"{float(r['friction_power']):.1f}", f"{100 * float(r['mechanical_efficiency']):.2f}",
                  f"{float(r['max_contact_force']):.0f}", r["contact_mode_count"], f"{float(r['wall_time']):.3f}"]
                 for r in ordered]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", type=Path, help="an existing RotaryVaneCompressor.fmu (default: build one)")
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts; the first is the base")
    parser.add_argument("--stop-time", type=float, default=0.5, help="simulated time per point [s]")
    parser.add_argument("--repeats", type=int, default=3, help="warm campaigns per worker count (median wall)")
    args = parser.parse_args()
    counts = [int(text) for text in args.workers.split(",")]
    import dask
    import distributed
    import fmpy
    print(f"python {sys.version.split()[0]}, dask {dask.__version__}, distributed {distributed.__version__}, "
          f"fmpy {fmpy.__version__}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    points = clearance_study(args.stop_time)
    with tempfile.TemporaryDirectory(prefix="rvc_bench_campaign_") as temporary:
        folder = Path(temporary)
        fmu = args.fmu.resolve() if args.fmu else build_fmu(folder / "fmu")
        print(f"FMU: {fmu}; {len(points)} points of {args.stop_time} s")
        campaign.run_campaign(fmu, points[:1], folder / "warm_up.csv", workers=1, progress=False)
        results = [measure(fmu, points, workers, args.repeats, folder) for workers in counts]
    print_timings(results, len(points))
    print_study(results[0]["rows"])
    print(f"\nload average at the end {os.getloadavg()[0]:.2f} (other processes share the CPUs)")


if __name__ == "__main__":
    main()
