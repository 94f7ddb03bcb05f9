"""Memory and sys.path of a host that instantiates and frees the built FMU many times (fmpy, one process).

One cycle: fmi2Instantiate, setupExperiment, initialization, 10 steps of 1 ms at 1500 rpm, fmi2GetFMUstate /
SetFMUstate / FreeFMUstate, fmi2Terminate, fmi2FreeInstance. The resident set size (VmRSS) after the first 20
cycles (imports, numba kernels, property tables) must not grow by more than 5 MB over the following 280, and
sys.path must not grow at all (pythonfmu inserts the resources folder at every instantiation).
"""
from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

import pytest

import fmu_helpers as H
from test_fmu_compressor import script

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads VmRSS from /proc/self/status")

CYCLES = """
import sys, time, fmu_helpers as H
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
unzipdir = extract($fmu)
description = read_model_description(unzipdir)
speed = [v.valueReference for v in description.modelVariables if v.name == "shaft_speed"]

def rss_kib():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("VmRSS:"))

rows = []
for k in range($cycles):
    start = time.perf_counter()
    fmu = FMU2Slave(guid=description.guid, unzipDirectory=unzipdir,
                    modelIdentifier=description.coSimulation.modelIdentifier, instanceName=f"cycle{k}")
    fmu.instantiate()
    if $full:
        fmu.setupExperiment(startTime=0.0)
        fmu.setReal(speed, [1500.0])
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        for n in range(10):
            fmu.doStep(n * 1e-3, 1e-3)
        state = fmu.getFMUstate()
        fmu.setFMUstate(state)
        fmu.freeFMUstate(state)
        fmu.terminate()
    fmu.freeInstance()
    rows.append((rss_kib(), len(sys.path), time.perf_counter() - start))
H.emit(rows)
"""


def run_cycles(fmu: Path, env: dict, cycles: int, full: bool) -> list:
    return H.run_host(script(CYCLES, fmu=fmu, cycles=cycles, full=full), env=env, timeout=900).check().result


@pytest.mark.slow
def test_300_run_cycles_keep_memory_and_sys_path_flat(built_fmus, env):
    rows = run_cycles(built_fmus / "RotaryVaneCompressor.fmu", env, 300, True)
    rss = [row[0] for row in rows]
    growth_mib = (max(rss[20:]) - rss[20]) / 1024
    print(f"\nRSS after cycle 20: {rss[20] / 1024:.1f} MiB, largest after: {max(rss[20:]) / 1024:.1f} MiB "
          f"(+{growth_mib:.2f} MiB over 280 cycles); median cycle {statistics.median(r[2] for r in rows) * 1e3:.1f} ms")
    assert growth_mib <= 5.0, json.dumps(rss[::20])
    assert len({row[1] for row in rows}) == 1, f"sys.path length per cycle: {[row[1] for row in rows][::20]}"


def test_1000_instantiate_free_cycles_stay_flat(built_fmus, env):
    """The audit's case: 1000 fmi2Instantiate/fmi2FreeInstance cycles in one process; memory (RSS after cycle 20
    grows by at most 5 MB) and sys.path (constant) are asserted, the cycle time is printed (first and last 100)."""
    rows = run_cycles(built_fmus / "RotaryVaneCompressor.fmu", env, 1000, False)
    rss = [row[0] for row in rows]
    first, last = (statistics.median(r[2] for r in part) * 1e3 for part in (rows[:100], rows[-100:]))
    print(f"\n1000 instantiate/free cycles: median cycle first 100 {first:.2f} ms, last 100 {last:.2f} ms; RSS "
          f"{rss[20] / 1024:.1f} MiB after cycle 20, +{(max(rss[20:]) - rss[20]) / 1024:.2f} MiB at most after; "
          f"sys.path {rows[0][1]} entries in every cycle")
    assert (max(rss[20:]) - rss[20]) / 1024 <= 5.0
    assert len({row[1] for row in rows}) == 1
