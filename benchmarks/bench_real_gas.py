"""Level 1 (real-gas chambers) against Level 0.5 at z = 3, 1500 rpm, c = 0.05 mm, R134a (issue 3).

Prints, per pressure model: wall per revolution, real-time factor, accepted/rejected steps and right-hand sides per
revolution, cost per right-hand side; and the cost of the Level 1 parts of one right-hand side measured inside
numba, with their share of it: the chamber geometry (volumes by Green's theorem and their rates, one function since
the rates come from the unit-pressure gas loads, mechanics.geometry.chamber_geometry), the chamber model
(thermo.chamber_model .chamber_rates: fluid states, the nozzle flows of ports and leaks, the balances) and, of it, the
two property-table states; the rest of the right-hand side (the vane: pose, contacts, gas loads, equations of motion) by
difference. Both models run at the reference numerics (REFERENCE_NUMERICS: rtol 1e-6, max_step 2e-5 s), named explicitly
since the library's default tolerance is now rtol 3e-5 (bench_tolerances.py). Figures only.
"""
import argparse
import math
import statistics
import time

import numpy as np
from numba import njit

from rotary_vane.mechanics import REFERENCE_NUMERICS, CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.geometry.chamber_geometry import chamber_geometry
from rotary_vane.mechanics.loop.dynamics import chamber_inputs_at, evaluate, pose_stages
from rotary_vane.mechanics.loop.integrators import ACCEPTED, EVALUATIONS, REJECTED, context
from rotary_vane.mechanics.loop.layout import GAS_BLOCK, MEM_LOBE_START
from rotary_vane.mechanics.loop.outputs import OUTPUT_SIZE
from rotary_vane.thermo.chamber_model import LEADING_TEMPERATURE, chamber_fluid_states, chamber_rates
from rotary_vane.thermo.flow_paths import PATH

from report import heading, table  # benchmarks/ is the script's folder

RPM = 1500.0
CLEARANCE = 5e-5


def run_model(model: str, revolutions: float, repeats: int):
    """(wall per revolution [s], counters per revolution, simulation) for a fresh warm-started run."""
    params = CompressorParameters(pressure_model=model, slot_clearance=CLEARANCE, stator_clearance=CLEARANCE,
                                  **REFERENCE_NUMERICS)
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


# timing loops: `arrays` are the context arrays the kernel entries take; each loop nudges an input by a negligible
# amount per call so that the compiler cannot hoist the call out of the loop
@njit
def _time_evaluate(n, t, y, memory, dydt, out, arrays):
    """The whole right-hand side as the integrator's stages call it (report=False)."""
    ctx = context(*arrays)
    total = 0.0
    for i in range(n):
        evaluate(t + 1e-13 * i, y, ctx, memory, dydt, out, False)
        total += dydt[3]
    return total


@njit
def _time_geometry(n, t, y, memory, arrays):
    """The chamber geometry (volumes and rates) of the pose at (t, y), its pose stages computed once."""
    ctx = context(*arrays)
    pose, _, tip, sides, basis = pose_stages(t, y, ctx, memory)
    machine = ctx.machine[0]
    total = 0.0
    for i in range(n):
        total += chamber_geometry(pose, tip, sides, basis, memory[MEM_LOBE_START] + 1e-12 * i, machine,
                                  ctx.sectors).volume_leading
    return total


@njit
def _time_chamber_model(n, t, y, memory, rates, arrays, states_only):
    """The chamber model at the chamber inputs of (t, y) (computed once), y's leading temperature nudged: its rates
    (chamber_rates) or, if `states_only`, just the property-table states of both chambers (chamber_fluid_states)."""
    ctx = context(*arrays)
    inputs = chamber_inputs_at(t, y, ctx, memory)
    c = ctx.chambers[0]
    temperature = y[GAS_BLOCK + LEADING_TEMPERATURE]
    total = 0.0
    for i in range(n):
        y[GAS_BLOCK + LEADING_TEMPERATURE] = temperature + 1e-9 * i
        if states_only:
            total += chamber_fluid_states(y, GAS_BLOCK, inputs, c, ctx.properties)[0].pressure
        else:
            chamber_rates(0.0, y, GAS_BLOCK, inputs, c, ctx.properties, ctx.nozzles, rates, ctx.flow_work[0])
            total += ctx.flow_work[0].mass_flow[PATH.discharge]
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
    heading(f"Level 1 vs Level 0.5: z = 3, {RPM:g} rpm, c = {CLEARANCE * 1e3:g} mm, R134a, dopri5, "
            f"rtol {REFERENCE_NUMERICS['relative_tolerance']:g}, max_step {REFERENCE_NUMERICS['max_step']:g} s")
    rows, level1 = [], None
    for model in ("ideal_gas_table", "real_gas"):
        wall, counts, sim = run_model(model, args.revolutions, args.repeats)
        rhs_cost = wall / counts[EVALUATIONS] * 1e6
        rows.append([model, f"{wall * 1e3:.2f}", f"{60.0 / RPM / wall:.2f}x", f"{counts[ACCEPTED]:.0f}",
                     f"{counts[REJECTED]:.0f}", f"{counts[EVALUATIONS]:.0f}", f"{rhs_cost:.3f}"])
        if model == "real_gas":
            level1 = sim
    print(table(["model", "ms/rev", "real time", "accepted/rev", "rejected/rev", "RHS/rev", "us/RHS in loop"],
                rows))
    print_rhs_parts(level1)


def print_rhs_parts(sim):
    """The parts of one Level 1 right-hand side at the simulation's current state, measured inside numba."""
    t, y, memory = sim.time, sim.state.copy(), sim.memory.copy()
    arrays = sim._kernel_context()          # the context arrays the kernel entries take, as Simulation passes them
    evaluate_ns = per_call(_time_evaluate, t, y, memory, np.empty(y.size), np.empty(OUTPUT_SIZE), arrays)
    geometry_ns = per_call(_time_geometry, t, y, memory, arrays)
    chamber_ns = per_call(_time_chamber_model, t, y.copy(), memory, np.empty(y.size), arrays, False)
    states_ns = per_call(_time_chamber_model, t, y.copy(), memory, np.empty(y.size), arrays, True)
    rest_ns = evaluate_ns - geometry_ns - chamber_ns
    heading("One Level 1 right-hand side, measured inside numba")
    print(table(["part", "ns", "share"], [
        ["whole evaluate (report=False)", f"{evaluate_ns:.0f}", "100%"],
        ["chamber geometry (volumes and rates)", f"{geometry_ns:.0f}", f"{geometry_ns / evaluate_ns:.0%}"],
        ["chamber model (states, flows, balances)", f"{chamber_ns:.0f}", f"{chamber_ns / evaluate_ns:.0%}"],
        ["  of which 2 property-table states", f"{states_ns:.0f}", f"{states_ns / evaluate_ns:.0%}"],
        ["rest: vane stages (by difference)", f"{rest_ns:.0f}", f"{rest_ns / evaluate_ns:.0%}"],
    ]))


if __name__ == "__main__":
    main()
