"""What moving suction and discharge conditions cost (docs/model.md §7.3.3): the start of examples/moving_inputs.py
(speed 0 -> 1500 rpm in 0.5 s, p_s 0.6 -> 0.2928 MPa and p_d 0.6 -> 1.3179 MPa over 2 s with 10 K of suction
superheat, 1 s held) in the library, stepped as the FMU steps it (1 ms, the inputs passed to every advance and
moved linearly over it, interpolate_speed's default), against the same speed profile with the boundary fixed at the final point; CPU time of each (median of
--repeats, interleaved), and the cost of one set_boundary call.

Usage:  python benchmarks/bench_moving_inputs.py [--repeats 3] [--stop-time 3.0]
"""
from __future__ import annotations

import argparse
import statistics
import time

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.thermo.fluid import Fluid

STEP = 1e-3
SPEED, SPEED_RAMP, PRESSURE_RAMP = 1500.0, 0.5, 2.0
START, FINAL_SUCTION, FINAL_DISCHARGE, SUPERHEAT = 0.6e6, 0.2928e6, 1.3179e6, 10.0


def profile(stop_time: float, moving: bool) -> list[tuple[float, float, float, float]]:
    """(speed, p_s, p_d, T_s) given to each step."""
    fluid = Fluid("R134a")
    rows = []
    for k in range(round(stop_time / STEP)):
        t = k * STEP
        w = min(1.0, t / PRESSURE_RAMP) if moving else 1.0
        suction = START + (FINAL_SUCTION - START) * w
        discharge = START + (FINAL_DISCHARGE - START) * w
        rows.append((SPEED * min(1.0, (t + STEP) / SPEED_RAMP), suction, discharge,
                     fluid.saturation_temperature(suction) + SUPERHEAT))
    return rows


def run(rows) -> float:
    simulation = Simulation(CompressorParameters(rotor_inertia=0.0), constant_speed(0.0), initial_angle=0.0,
                            keep_history=False)
    simulation.set_boundary(rows[0][1], rows[0][2], suction_temperature=rows[0][3])
    started = time.process_time()
    for k, (speed, suction, discharge, temperature) in enumerate(rows):
        simulation.advance((k + 1) * STEP, speed_rpm=speed, interpolate=True,
                           boundary=dict(suction_pressure=suction, discharge_pressure=discharge,
                                         suction_temperature=temperature))
    return time.process_time() - started


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--stop-time", type=float, default=3.0)
    args = parser.parse_args(argv)
    moving, fixed = profile(args.stop_time, True), profile(args.stop_time, False)
    run(fixed[:50])                                    # compile / load the kernels
    times = {"moving": [], "fixed": []}
    for _ in range(args.repeats):
        times["moving"].append(run(moving))
        times["fixed"].append(run(fixed))
    simulation = Simulation(CompressorParameters(), constant_speed(1500.0), keep_history=False)
    started, calls = time.perf_counter(), 200
    for k in range(calls):
        simulation.set_boundary(0.29e6 + 10.0 * (k % 2), 1.3e6, suction_temperature=283.15)
    per_call = (time.perf_counter() - started) / calls
    median = {name: statistics.median(values) for name, values in times.items()}
    print(f"{args.stop_time:g} s simulated at {STEP * 1e3:g} ms steps, CPU s (median of {args.repeats}):")
    for name, values in times.items():
        print(f"  {name:6s} {median[name]:8.2f}   all: {', '.join(f'{v:.2f}' for v in values)}")
    print(f"  moving / fixed = {median['moving'] / median['fixed']:.3f}")
    print(f"set_boundary with a changed input: {per_call * 1e3:.3f} ms per call")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
