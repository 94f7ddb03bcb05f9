"""Level 1 (real-gas chambers) against Level 0.5 at z = 3, 1500 rpm, c = 0.05 mm, R134a (issue 3).

Prints, per pressure model: wall per revolution, real-time factor, accepted/rejected steps and right-hand sides per
revolution, cost per right-hand side; and the cost of the Level 1 parts of one right-hand side measured inside
numba (two property-table evaluations, chamber volumes, volume rates) with their share of it. Figures only.
"""
import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit


from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed  # noqa: E402
from rotary_vane.mechanics.chambers import chamber_volume_rates, chamber_volumes  # noqa: E402
from rotary_vane.mechanics.dynamics import evaluate  # noqa: E402
from rotary_vane.mechanics.layout import OUTPUT_SIZE  # noqa: E402
from rotary_vane.thermo.property_table import table_properties  # noqa: E402

from report import heading, table  # noqa: E402

RPM = 1500.0
CLEARANCE = 5e-5


def run_model(model: str, revolutions: float, repeats: int):
    """(wall per revolution [s], counters per revolution, simulation) for a fresh warm-started run."""
    params = CompressorParameters(pressure_model=model, slot_clearance=CLEARANCE, stator_clearance=CLEARANCE)
    period = 60.0 / RPM
    walls, counts, sim = [], None, None
    for _ in range(repeats):
        sim = Simulation(params, constant_speed(RPM), keep_history=False)
        sim.advance(2 * period)                       # settle (and compile on the first call)
        before = sim.counters.copy()
        start = time.perf_counter()
        sim.advance(sim.time + revolutions * period)
        walls.append((time.perf_counter() - start) / revolutions)
        counts = (sim.counters - before) / revolutions
    return statistics.median(walls), counts, sim


@njit
def _time_properties(n, temperature, density, table_data):
    total = 0.0
    for i in range(n):
        total += table_properties(temperature + 1e-6 * i, density, table_data)[0]
    return total


@njit
def _time_volumes(n, y, theta, closest, lobe_start, m):
    total = 0.0
    for i in range(n):
        total += chamber_volumes(y[0], y[1], y[2] + 1e-12 * i, theta, closest, lobe_start, m)[0]
    return total


@njit
def _time_rates(n, y, theta, omega, closest, m):
    total = 0.0
    for i in range(n):
        total += chamber_volume_rates(y[0], y[1], y[2] + 1e-12 * i, y[3], y[4], y[5], theta, omega, closest, m)[0]
    return total


@njit
def _time_evaluate(n, t, y, m, law, gas, memory, dydt, out):
    total = 0.0
    for i in range(n):
        evaluate(t + 1e-13 * i, y, m, law, gas, memory, dydt, out, False)
        total += dydt[3]
    return total


def per_call(function, *args, n=200_000):
    """ns per call of a timing loop (best of 3, after a warm-up call)."""
    function(10, *args)
    best = math.inf
    for _ in range(3):
        start = time.perf_counter()
        function(n, *args)
        best = min(best, (time.perf_counter() - start) / n)
    return best * 1e9


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--revolutions", type=float, default=10.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    heading(f"Level 1 vs Level 0.5: z = 3, {RPM:g} rpm, c = {CLEARANCE * 1e3:g} mm, R134a, dopri5")
    rows, level1 = [], None
    for model in ("ideal_gas_table", "real_gas"):
        wall, counts, sim = run_model(model, args.revolutions, args.repeats)
        rhs_cost = wall / counts[2] * 1e6
        rows.append([model, f"{wall * 1e3:.2f}", f"{60.0 / RPM / wall:.2f}x", f"{counts[0]:.0f}", f"{counts[1]:.0f}",
                     f"{counts[2]:.0f}", f"{rhs_cost:.3f}"])
        if model == "real_gas":
            level1 = sim
    print(table(["model", "ms/rev", "real time", "accepted/rev", "rejected/rev", "RHS/rev", "us/RHS in loop"],
                rows))
    sim = level1
    y = sim.state.copy()
    theta = sim.rotor_angle
    omega = sim.rotor_speed
    closest = theta
    evaluate_ns = per_call(_time_evaluate, sim.time, y, sim.machine, sim.speed_law, sim.gas, sim.memory.copy(),
                           np.empty(y.size), np.empty(OUTPUT_SIZE))
    properties_ns = 2 * per_call(_time_properties, float(y[10]), float(y[11]), sim.gas.properties)
    volumes_ns = per_call(_time_volumes, y, theta, closest, float(sim.memory[1]), sim.machine)
    rates_ns = per_call(_time_rates, y, theta, omega, closest, sim.machine)
    heading("One Level 1 right-hand side, measured inside numba")
    print(table(["part", "ns", "share"], [
        ["whole evaluate (report=False)", f"{evaluate_ns:.0f}", "100 %"],
        ["2 property-table evaluations", f"{properties_ns:.0f}", f"{properties_ns / evaluate_ns:.0%}"],
        ["chamber volumes (Green)", f"{volumes_ns:.0f}", f"{volumes_ns / evaluate_ns:.0%}"],
        ["chamber volume rates", f"{rates_ns:.0f}", f"{rates_ns / evaluate_ns:.0%}"],
    ]))


if __name__ == "__main__":
    main()
