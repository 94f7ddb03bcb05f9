"""Start-up of a real-gas run in a fresh process (docs/model.md §7.1): prints figures, asserts nothing.

Run from anywhere:  python benchmarks/bench_startup.py [--repeats N]

The FMU must return its first doStep within 1 s of instantiation in a fresh process. This measures the library path
behind it for the default real-gas run (R134a, z = 3, 1500 rpm, c = 0.05 mm), each case in a fresh subprocess started
with `sys.executable`, split into phases, wall and CPU time each:

    import      `import rotary_vane.mechanics`
    parameters  `CompressorParameters(pressure_model="real_gas", ...)` (validation of the operating point)
    Simulation  `Simulation(params, constant_speed(1500))` (property table, chamber constants, references)
    advance     `sim.advance(1e-3)`, the first 1 ms

and the phase after which CoolProp was in sys.modules ("-": never). Cases, all with one temporary cache folder
(ROTARY_VANE_CACHE_DIR) whose numba cache a first, unreported process fills:

    warm cache            every cache filled by an earlier process
    empty property cache  the numba cache warm, the folder of property tables and operating points removed

Figures are the median over the repeats; the machine is shared, so expect +-10 % noise on wall times.
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
from pathlib import Path

from report import heading, table  # benchmarks/ is the script's folder

PHASES = ("import", "parameters", "Simulation", "advance")

CHILD = """
import json, sys, time
start_wall, start_cpu = time.perf_counter(), time.process_time()
marks, coolprop_after = [], None
def mark(phase):
    global coolprop_after
    marks.append((time.perf_counter(), time.process_time()))
    if coolprop_after is None and "CoolProp" in sys.modules:
        coolprop_after = phase
from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
mark("import")
params = CompressorParameters(pressure_model="real_gas", slot_clearance=5e-5, stator_clearance=5e-5)
mark("parameters")
sim = Simulation(params, constant_speed(1500.0), keep_history=False)
mark("Simulation")
sim.advance(1e-3)
mark("advance")
walls = [wall for wall, _ in marks]
cpus = [cpu for _, cpu in marks]
print(json.dumps({"wall": [b - a for a, b in zip([start_wall] + walls, walls)],
                  "cpu": [b - a for a, b in zip([start_cpu] + cpus, cpus)],
                  "coolprop_after": coolprop_after or "-"}))
"""


def run_child(cache_dir: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", CHILD], env=dict(os.environ, ROTARY_VANE_CACHE_DIR=str(cache_dir)),
                          capture_output=True, text=True, timeout=1800)
    if done.returncode != 0:
        sys.exit(f"the measuring process failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def summary(name: str, runs: list[dict]) -> list[list[str]]:
    """Rows 'case, clock': median seconds per phase and in total, and where CoolProp came in."""
    rows = []
    for clock in ("wall", "cpu"):
        phases = [statistics.median(run[clock][k] for run in runs) for k in range(len(PHASES))]
        total = statistics.median(sum(run[clock]) for run in runs)
        rows.append([f"{name}, {clock}", *(f"{seconds:.3f}" for seconds in phases), f"{total:.3f}",
                     ",".join(sorted({run["coolprop_after"] for run in runs}))])
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="fresh processes per case")
    arguments = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-startup-") as folder:
        cache_dir = Path(folder)
        run_child(cache_dir)                                   # compiles the kernels into the numba cache
        warm = [run_child(cache_dir) for _ in range(arguments.repeats)]
        empty = []
        for _ in range(arguments.repeats):
            shutil.rmtree(cache_dir / "properties", ignore_errors=True)
            empty.append(run_child(cache_dir))
    heading(f"Fresh process, default real-gas run (R134a, z = 3, 1500 rpm, c = 0.05 mm): seconds, median of "
            f"{arguments.repeats}")
    print(table(["case, clock", *PHASES, "total", "CoolProp after"],
                summary("warm cache", warm) + summary("empty property cache", empty)))


if __name__ == "__main__":
    main()
