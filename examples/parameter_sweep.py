"""The declared parameter space, swept: every point either runs one revolution with finite outputs and the energy
ledger closed, or is refused before any work starts with an error naming the parameter (docs/model.md §9, §6.4).

Points (all from the declarations in mechanics.parameters, so a new parameter is swept without editing this file):
* the defaults;
* one at a time: every numeric parameter at its declared minimum and maximum, every choice at each of its values,
  a few fluids, and the shaft speed at its ends, the others at their defaults;
* `--random N` points with every parameter drawn at once (fixed seed): numbers uniform over their range, or
  log-uniform where the range spans more than two decades and starts above 0; choices uniform; speed log-uniform.
  A parameter that a relation ties to others (discharge above suction pressure, a vane that fits its slot, ...)
  is drawn within the range the ones drawn before it allow (mechanics.parameters.RELATION_BOUNDS), so nearly every
  draw is valid; the relations with no closed form (the stator regularity, the fluid's range) still refuse some.
  Candidates are drawn until N pass validation; the others are counted by the parameter their error names, or as
  "no room" (a refusal that names no parameter is kept as a point, and fails). A valid point is never re-drawn for
  being expensive: one whose revolution the library estimates over the budget before any work
  (mechanics.loop.run_cost, docs/model.md §8.3) stays among the N and is *refused* with that estimate.

Each point builds `CompressorParameters` (a ValueError there is a *refusal*: its message must name a parameter),
starts on a valley and runs one revolution at constant speed (at 0 rpm: 10 ms at standstill), then checks every
output column is finite where the model defines it and the revolution's ledger residual is within 0.1 %. A point
that stops at run time (IntegrationError, any other exception, non-finite outputs, an open ledger) is a *failure*;
one that takes longer than `--budget` seconds of CPU time (its own process's: on a shared machine wall time
measures the neighbours) is reported as *slow* with how far it got. Points fan
out over processes with dask. Prints the tally and every failure; `--csv` writes one row per point.

    python examples/parameter_sweep.py                      # one-at-a-time points and 200 random ones
    python examples/parameter_sweep.py --random 1000 --workers 4 --csv out/sweep.csv
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

from rotary_vane.mechanics import CompressorParameters, IntegrationError, Simulation, constant_speed, declarations
from rotary_vane.mechanics.loop.outputs import OUTPUT_NAMES, REAL_GAS_COLUMNS
from rotary_vane.mechanics.parameters import RELATION_BOUNDS
from rotary_vane.mechanics.loop.run_cost import describe_cost, revolution_cost
from rotary_vane.mechanics.performance import revolutions

MAX_SPEED_RPM = 30000.0              # the FMU's declared shaft_speed maximum (fmu_src.compressor.MAX_SHAFT_SPEED)
SPEEDS_RPM = (0.0, 10.0, 1500.0, MAX_SPEED_RPM)
FLUIDS = ("R134a", "R410A", "R744", "Propane", "Air")
LEDGER_BOUND = 1e-3
STANDSTILL_TIME = 0.01               # s simulated at 0 rpm
# the budget is checked after every advance of at most this simulated time [s]: an advance may make up to
# mechanics.simulation.WORK_PER_MS step attempts per ms (seconds of CPU), so a 1/50 revolution at 17 rpm (69 ms) that
# ended at the work bound took 200 s against a 20 s budget
BUDGET_CHECK_INTERVAL = 1e-3
SEED = 20261125
# columns that may be NaN by definition: a region without a candidate point; the chamber states under the tables
MAYBE_NAN = tuple(name for name in OUTPUT_NAMES if name.startswith("penetration_"))
OUTCOMES = ("completed", "refused", "failed", "slow")


def one_at_a_time() -> list[dict]:
    """Defaults; each parameter at its ends or each of its values; each fluid (real gas); each speed."""
    points = [dict(rpm=1500.0)]
    for name, default, meta in declarations():
        if meta.get("fluid"):
            points += [dict(rpm=1500.0, fluid=fluid) for fluid in FLUIDS if fluid != default]
        elif "choices" in meta:
            points += [dict(rpm=1500.0, **{name: value}) for value in meta["choices"] if value != default]
        else:
            points += [dict(rpm=1500.0, **{name: meta[bound]}) for bound in ("min", "max") if meta[bound] != default]
    points += [dict(rpm=rpm) for rpm in SPEEDS_RPM if rpm != 1500.0]
    return points


def _draw(rng, meta: dict, low: float | None = None, high: float | None = None):
    """One value of a numeric parameter in [low, high] (default: its declared ends): integers uniform, numbers
    log-uniform where the declared range spans more than two decades and starts above 0, else uniform."""
    low = meta["min"] if low is None else max(low, meta["min"])
    high = meta["max"] if high is None else min(high, meta["max"])
    if meta["integer"]:
        return int(rng.integers(math.ceil(low), math.floor(high) + 1))
    if meta["min"] > 0.0 and meta["max"] / meta["min"] > 100.0:
        return float(math.exp(rng.uniform(math.log(low), math.log(high))))
    return float(rng.uniform(low, high))


def random_point(rng) -> dict | None:
    """One point with every parameter drawn at once (module docstring): each parameter over its declared range,
    then those a relation ties to others within the range the drawn ones allow (RELATION_BOUNDS, in its order).
    None if a relation leaves no room (an empty range)."""
    point = dict(rpm=float(math.exp(rng.uniform(math.log(10.0), math.log(MAX_SPEED_RPM)))))
    metadata = {}
    for name, _, meta in declarations():
        metadata[name] = meta
        if meta.get("fluid"):
            point[name] = str(rng.choice(FLUIDS))
        elif "choices" in meta:
            point[name] = str(rng.choice(meta["choices"]))
        else:
            point[name] = _draw(rng, meta)
    for name, bounds in RELATION_BOUNDS:
        allowed = bounds(point)
        if "choices" in metadata[name]:
            if point[name] not in allowed:
                point[name] = str(rng.choice(allowed))
            continue
        low, high = (metadata[name]["min"] if allowed[0] is None else allowed[0],
                     metadata[name]["max"] if allowed[1] is None else allowed[1])
        if not max(low, metadata[name]["min"]) < min(high, metadata[name]["max"]):
            return None
        point[name] = _draw(rng, metadata[name], low, high)
    return point


def valid_random_points(count: int, seed: int = SEED) -> tuple[list[dict], dict]:
    """`count` random points that pass validation, and the candidates drawn before them that were refused: by the
    parameter named, or "no room" for a draw whose relations left an empty range (module docstring)."""
    rng = np.random.default_rng(seed)
    points, refusals = [], {}
    while len(points) < count:
        point = random_point(rng)
        reason = "no room" if point is None else None
        if point is not None:
            try:
                CompressorParameters(**{k: v for k, v in point.items() if k != "rpm"})
            except ValueError as error:
                reason = next((n for n, _, _ in declarations() if f"'{n}'" in str(error)), None)
        if reason is not None:
            refusals[reason] = refusals.get(reason, 0) + 1
            continue
        points.append(point)
    return points, refusals


def run_point(point: dict, budget: float = 120.0) -> dict:
    """Run one point (module docstring); returns {outcome, detail, ledger_residual, steps, cpu, progress}."""
    values = {k: v for k, v in point.items() if k != "rpm"}
    rpm = point["rpm"]
    result = dict(outcome="completed", detail="", ledger_residual=math.nan, steps=0, cpu=0.0, progress=0.0)
    try:
        params = CompressorParameters(**values)
    except ValueError as error:
        named = any(f"'{name}'" in str(error) for name, _, _ in declarations())
        return dict(result, outcome="refused" if named else "failed",
                    detail=str(error) if named else f"refused without naming a parameter: {error}")
    if rpm > 0.0 and (cost := revolution_cost(params, rpm)).seconds > budget:     # said before any work (§8.3)
        return dict(result, outcome="refused", detail=describe_cost(cost, f"one revolution at {rpm:g} rpm")
                    + f": over the budget of {budget:g} s")
    try:
        simulation = Simulation(params, constant_speed(rpm), initial_angle=0.0, keep_history=False)
    except ValueError as error:                     # refused at construction: before any work
        named = any(f"'{name}'" in str(error) for name, _, _ in declarations())
        return dict(result, outcome="refused" if named else "failed",
                    detail=str(error) if named else f"refused without naming a parameter: {error}")
    except Exception as error:                      # noqa: BLE001 - a crash is what the sweep looks for
        return dict(result, outcome="failed", detail=f"at construction, {type(error).__name__}: {error}")
    start = time.process_time()
    try:
        end = STANDSTILL_TIME if rpm == 0.0 else 60.0 / rpm * 1.0001     # just past the valley at 2 pi
        slices = max(50, math.ceil(end / BUDGET_CHECK_INTERVAL))
        for k in range(1, slices + 1):
            simulation.advance(end * k / slices)
            result["progress"] = k / slices
            if time.process_time() - start > budget and k < slices:
                return dict(result, outcome="slow", cpu=time.process_time() - start,
                            steps=int(simulation.counters[0]),
                            detail=f"{k}/{slices} of the run in {budget:g} s")
    except IntegrationError as error:
        return dict(result, outcome="failed", cpu=time.process_time() - start,
                    detail=f"IntegrationError at t = {error.time:.6g} s: {error.reason}")
    except Exception as error:                      # noqa: BLE001 - a crash is what the sweep looks for
        return dict(result, outcome="failed", cpu=time.process_time() - start,
                    detail=f"{type(error).__name__}: {error}")
    result.update(cpu=time.process_time() - start, steps=int(simulation.counters[0]))
    allowed_nan = set(MAYBE_NAN) | (set(REAL_GAS_COLUMNS) if params.pressure_model != "real_gas" else set())
    bad = [name for name, value in zip(OUTPUT_NAMES, simulation.last_output)
           if not math.isfinite(value) and name not in allowed_nan]
    if bad:
        return dict(result, outcome="failed", detail=f"non-finite outputs: {', '.join(bad)}")
    if rpm == 0.0:
        return result
    summaries = revolutions(simulation)
    if not summaries:
        return dict(result, outcome="failed", detail="no complete revolution")
    residual = summaries[-1].ledger_residual
    result["ledger_residual"] = residual
    if not abs(residual) <= LEDGER_BOUND:
        return dict(result, outcome="failed", detail=f"ledger residual {residual:.3g} beyond {LEDGER_BOUND:g}")
    return result


def sweep(points: list[dict], workers: int, budget: float) -> list[dict]:
    """run_point over all points on `workers` processes (dask), in point order."""
    import dask
    from dask import delayed
    jobs = [delayed(run_point)(point, budget) for point in points]
    if workers == 1:
        return list(dask.compute(*jobs, scheduler="synchronous"))
    return list(dask.compute(*jobs, scheduler="processes", num_workers=workers))


def describe(point: dict) -> str:
    return ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in point.items())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=200, help="number of random points")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--budget", type=float, default=120.0, help="CPU-time budget per point [s]")
    parser.add_argument("--csv", type=Path, help="write one row per point")
    args = parser.parse_args(argv)
    Simulation(CompressorParameters(pressure_model="ideal_gas_table")).advance(1e-5)     # compile once
    drawn, random_refusals = valid_random_points(args.random, args.seed)
    print(f"random points: {len(drawn) + sum(random_refusals.values())} drawn, {sum(random_refusals.values())} "
          f"invalid (by the parameter named, or no room: " + ", ".join(f"{k} {v}" for k, v in sorted(
              random_refusals.items(), key=lambda item: -item[1])) + f"), {len(drawn)} run")
    points = one_at_a_time() + drawn
    started = time.perf_counter()
    results = sweep(points, args.workers, args.budget)
    tally = {outcome: sum(r["outcome"] == outcome for r in results) for outcome in OUTCOMES}
    print(f"{len(points)} points in {time.perf_counter() - started:.0f} s on {args.workers} worker(s): "
          + ", ".join(f"{n} {k}" for k, n in tally.items()))
    residuals = [abs(r["ledger_residual"]) for r in results if r["outcome"] == "completed"
                 and math.isfinite(r["ledger_residual"])]
    if residuals:
        print(f"ledger residual over the completed revolutions: median {np.median(residuals):.2e}, "
              f"largest {max(residuals):.2e}")
    refusals = {}
    for r in results:
        if r["outcome"] == "refused":
            name = r["detail"].split("'")[1] if "'" in r["detail"] else "over the budget"
            refusals[name] = refusals.get(name, 0) + 1
    if refusals:
        print("refused, by the parameter named: " + ", ".join(f"{k} {v}" for k, v in sorted(
            refusals.items(), key=lambda item: -item[1])))
    for point, r in zip(points, results):
        if r["outcome"] in ("failed", "slow"):
            print(f"{r['outcome'].upper()}: {describe(point)}\n    {r['detail']}")
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        with args.csv.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["point", "outcome", "detail", "ledger_residual", "steps", "cpu", "progress"])
            for point, r in zip(points, results):
                writer.writerow([describe(point), r["outcome"], r["detail"], r["ledger_residual"], r["steps"],
                                 f"{r['cpu']:.3f}", r["progress"]])
    return 1 if tally["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
