"""Benchmark of the real-gas property table (docs/model.md §7.3): prints figures,
asserts nothing.

Run from anywhere:  python benchmarks/bench_properties.py [--quick] [--calls N]

1. Table evaluation inside numba (R134a, docs/model.md §7.1 envelope): ns per `table_properties` call over N random states
   (random access over the whole table) and along a chamber-like path (neighbouring states, as in the time loop),
   `table_status` alone, and the bare loop; the cost of 2 chambers x 6 stages per step.
2. CoolProp HEOS from Python: AbstractState.update(DmassT) + p, h, c_v, (dp/dT)_rho, and `Fluid.properties`.
3. Per fluid (R134a, Air, CO2, R410A, R1234yf, R290; --quick: R134a): envelope, build and cache-load time, file
   size, memory, refused cells, worst relative error against HEOS at random accepted states (uniform over the
   envelope and just inside the dome / top-density limit).
Tables go to a temporary cache folder, never the user's.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]

import numba  # noqa: E402
import numpy as np  # noqa: E402
from report import best_of, build_and_load_times, heading, table  # noqa: E402  (benchmarks/ is the script's folder)

from rotary_vane.thermo.fluid import Fluid, coolprop, typical_operating_point  # noqa: E402
from rotary_vane.thermo.property_table import (PROPERTY_NAMES, STATUS_INACCURATE_CELL, STATUS_OK,  # noqa: E402
                                   build_property_table, dome_log_density_limit, envelope_for, property_table_for,
                                   property_table_path, table_properties, table_status)

STAGES_PER_STEP = 6            # Dormand-Prince right-hand sides per step
CHAMBERS = 2                   # leading and trailing chamber of the active lobe
FLUIDS = ("R134a", "Air", "CO2", "R410A", "R1234yf", "R290")


# 1. numba ----------------------------------------------------------------------------------------------------
@numba.njit
def evaluate_all(temperatures, densities, property_table):
    total = 0.0
    refused = 0
    for k in range(temperatures.size):
        pressure, enthalpy, heat_capacity, slope, status = table_properties(temperatures[k], densities[k],
                                                                            property_table)
        if status == 0:
            total += pressure + enthalpy + heat_capacity + slope
        else:
            refused += 1
    return total, refused


@numba.njit
def status_all(temperatures, densities, property_table):
    total = 0
    for k in range(temperatures.size):
        total += table_status(temperatures[k], densities[k], property_table)
    return total


@numba.njit
def bare_loop(temperatures, densities):
    total = 0.0
    for k in range(temperatures.size):
        total += temperatures[k] * densities[k]
    return total


def chamber_path(fluid: Fluid, calls: int):
    """A compression/expansion cycle between the suction state and the isentropic discharge state, sampled at
    `calls` points over 20 cycles (neighbouring calls are close, as in a time loop)."""
    p_s, t_s, p_d = typical_operating_point(fluid)
    suction_density = fluid.density(t_s, p_s)
    end = fluid.state_at_pressure_entropy(p_d, fluid.properties(t_s, suction_density).entropy)
    phase = 0.5 * (1.0 - np.cos(np.linspace(0.0, 40.0 * math.pi, calls)))
    temperatures = t_s + phase * (end.temperature - t_s)
    densities = np.exp(np.log(suction_density) + phase * (np.log(end.density) - np.log(suction_density)))
    return temperatures, densities


def numba_costs(fluid: Fluid, property_table, envelope, calls: int, rng) -> dict:
    random_t = rng.uniform(envelope.temperature_min, envelope.temperature_max, calls)
    random_rho = np.exp(rng.uniform(math.log(envelope.density_min), math.log(envelope.density_max), calls))
    path_t, path_rho = chamber_path(fluid, calls)
    evaluate_all(random_t[:10], random_rho[:10], property_table)          # compile
    status_all(random_t[:10], random_rho[:10], property_table)
    bare_loop(random_t[:10], random_rho[:10])
    refused_random = evaluate_all(random_t, random_rho, property_table)[1]
    refused_path = evaluate_all(path_t, path_rho, property_table)[1]
    return {
        "random": best_of(evaluate_all, random_t, random_rho, property_table) / calls,
        "path": best_of(evaluate_all, path_t, path_rho, property_table) / calls,
        "status": best_of(status_all, path_t, path_rho, property_table) / calls,
        "bare": best_of(bare_loop, path_t, path_rho) / calls,
        "refused_random": refused_random / calls, "refused_path": refused_path / calls,
    }


def report_numba(costs: dict, calls: int) -> None:
    heading(f"1. table evaluation inside numba, R134a (docs/model.md §7.1 envelope), {calls:.0e} states, best of 5")
    rows = [["table_properties, random states over the envelope", f"{1e9 * costs['random']:.1f}",
             f"{100 * costs['refused_random']:.0f} %"],
            ["table_properties, chamber-like path", f"{1e9 * costs['path']:.1f}",
             f"{100 * costs['refused_path']:.0f} %"],
            ["table_status alone, same path", f"{1e9 * costs['status']:.1f}", ""],
            ["bare loop (read T, rho; no table)", f"{1e9 * costs['bare']:.1f}", ""]]
    print(table(["case", "ns/call", "refused"], rows))
    per_step = CHAMBERS * STAGES_PER_STEP * costs["path"]
    print(f"per time step ({CHAMBERS} chambers x {STAGES_PER_STEP} stages = {CHAMBERS * STAGES_PER_STEP} calls, "
          f"path figure): {1e9 * per_step:.0f} ns")


# 2. CoolProp ----------------------------------------------------------------------------------------------------
def coolprop_costs(fluid: Fluid, temperatures, densities) -> dict:
    CP = coolprop()
    state = CP.AbstractState("HEOS", fluid.name)

    def raw():
        for t, rho in zip(temperatures, densities):
            state.update(CP.DmassT_INPUTS, rho, t)
            state.p(), state.hmass(), state.cvmass(), state.first_partial_deriv(CP.iP, CP.iT, CP.iDmass)

    def wrapped():
        for t, rho in zip(temperatures, densities):
            fluid.properties(t, rho)

    count = len(temperatures)
    return {"raw": best_of(raw, repeats=3) / count, "wrapped": best_of(wrapped, repeats=3) / count}


def report_coolprop(costs: dict, table_cost: float, count: int) -> None:
    heading(f"2. CoolProp HEOS from Python, R134a, {count} states on the same path, best of 3")
    rows = [["AbstractState.update(DmassT) + p, h, c_v, (dp/dT)_rho", f"{1e6 * costs['raw']:.2f}",
             f"{costs['raw'] / table_cost:.0f} x"],
            ["Fluid.properties (checks, phase test, + s, c_p)", f"{1e6 * costs['wrapped']:.2f}",
             f"{costs['wrapped'] / table_cost:.0f} x"]]
    print(table(["call", "us/call", "/ numba table"], rows))


# 3. per fluid ---------------------------------------------------------------------------------------------------
def worst_errors(fluid: Fluid, property_table, temperatures, densities):
    """Worst relative error per property over the accepted states, and how many were accepted."""
    worst = np.zeros(4)
    accepted = 0
    for t, rho in zip(temperatures, densities):
        *values, status = table_properties(t, rho, property_table)
        if status != STATUS_OK:
            continue
        accepted += 1
        e = fluid.properties(t, rho)
        reference = np.array([e.pressure, e.enthalpy, e.isochoric_heat_capacity, e.pressure_temperature_derivative])
        worst = np.maximum(worst, np.abs(np.array(values) / reference - 1.0))
    return worst, accepted


def refused_gas_cells(property_table) -> int:
    """Refused cells that reach the accepted gas region (probed at 3 x 3 points per cell): the rest lie inside the
    dome or its margin."""
    count = 0
    for i, j in np.argwhere(~property_table.accurate_cell):
        probes = [(property_table.temperature_min + (i + t) / property_table.inverse_temperature_step,
                   math.exp(property_table.log_density_min + (j + s) / property_table.inverse_log_density_step))
                  for t in (0.01, 0.5, 0.99) for s in (0.01, 0.5, 0.99)]
        count += any(table_status(t, rho, property_table) == STATUS_INACCURATE_CELL for t, rho in probes)
    return count


def fluid_figures(name: str, cache_dir: Path, samples: int, rng) -> dict:
    fluid = Fluid(name)
    envelope = envelope_for(fluid, *typical_operating_point(fluid))
    property_table, build, load = build_and_load_times(property_table_for, fluid, envelope, cache_dir=cache_dir)
    path = property_table_path(fluid, envelope, cache_dir=cache_dir)
    memory = sum(v.nbytes for v in property_table if isinstance(v, np.ndarray))
    t = rng.uniform(envelope.temperature_min, envelope.temperature_max, samples)
    uniform = worst_errors(fluid, property_table, t,
                           np.exp(rng.uniform(math.log(envelope.density_min), math.log(envelope.density_max), samples)))
    top = np.array([min(dome_log_density_limit(fluid, x, envelope.superheat_margin), math.log(envelope.density_max))
                    for x in t])
    near = worst_errors(fluid, property_table, t, np.exp(top - rng.uniform(0.0, 0.05, samples)))
    return {"name": name, "envelope": envelope, "build": build, "load": load, "file": path.stat().st_size,
            "memory": memory, "refused_cells": int((~property_table.accurate_cell).sum()),
            "refused_gas_cells": refused_gas_cells(property_table),
            "cells": property_table.accurate_cell.size,
            "worst": np.maximum(uniform[0], near[0]), "accepted": uniform[1] + near[1]}


def report_fluids(results: list[dict], samples: int) -> None:
    heading("3. per fluid: envelope_for(operating point), 160 x 160 table, temporary cache folder")
    rows = [[r["name"], f"{r['envelope'].temperature_min:.0f}-{r['envelope'].temperature_max:.0f}",
             f"{r['envelope'].density_min:.3g}-{r['envelope'].density_max:.3g}", f"{r['build']:.2f}",
             f"{1e3 * r['load']:.1f}", f"{r['file'] / 1e6:.1f}", f"{r['memory'] / 1e6:.1f}",
             f"{r['refused_cells']}/{r['cells']}", str(r["refused_gas_cells"])] for r in results]
    print(table(["fluid", "T [K]", "rho [kg/m^3]", "build [s]", "load [ms]", "file [MB]", "memory [MB]",
                 "refused cells", "of them in gas"], rows))
    print("(build: HEOS node evaluations + the cell check; refused cells lie inside the dome's margin except the "
          "'in gas' ones, which reach accepted states)")
    print(f"\nworst relative error against HEOS at accepted states ({samples} uniform + {samples} just inside the "
          "dome / top-density limit per fluid)")
    rows = [[r["name"], str(r["accepted"])] + [f"{e:.1e}" for e in r["worst"]] for r in results]
    print(table(["fluid", "accepted"] + list(PROPERTY_NAMES), rows))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="R134a only, 1e5 calls, fewer accuracy samples")
    parser.add_argument("--calls", type=float, default=1e6, help="table calls per timing (default 1e6)")
    args = parser.parse_args()
    calls = int(1e5 if args.quick else args.calls)
    samples = 300 if args.quick else 1500
    CP = coolprop()
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, numba {numba.__version__}, CoolProp "
          f"{CP.get_global_param_string('version')}, {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f} (timings on a busy machine are inflated)")
    rng = np.random.default_rng(2024)
    start = time.perf_counter()
    warm_up = Fluid("R134a")
    build_property_table(warm_up, envelope_for(warm_up, *typical_operating_point(warm_up)), 8, 8)
    print(f"first 8 x 8 build in this process (numba compile or cache load of the build kernels, CoolProp import): "
          f"{time.perf_counter() - start:.2f} s; build times below exclude it")
    with tempfile.TemporaryDirectory() as folder:
        results = [fluid_figures(name, Path(folder), samples, rng) for name in (FLUIDS[:1] if args.quick else FLUIDS)]
        r134a = Fluid("R134a")
        envelope = results[0]["envelope"]
        property_table = property_table_for(r134a, envelope, cache_dir=Path(folder))
        costs = numba_costs(r134a, property_table, envelope, calls, rng)
        report_numba(costs, calls)
        path_t, path_rho = chamber_path(r134a, 20000)
        heos = coolprop_costs(r134a, path_t, path_rho)
        report_coolprop(heos, costs["path"], path_t.size)
        report_fluids(results, samples)
    heading("4. summary")
    print(f"table {1e9 * costs['path']:.0f} ns/call in numba vs HEOS {1e6 * heos['raw']:.2f} us/call from Python: "
          f"{heos['raw'] / costs['path']:.0f} x; {CHAMBERS * STAGES_PER_STEP} calls per step cost "
          f"{1e9 * CHAMBERS * STAGES_PER_STEP * costs['path']:.0f} ns")


if __name__ == "__main__":
    main()
