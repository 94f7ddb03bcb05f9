"""Step attempts (accepted + rejected) per ms of simulated time, at the defaults and at the extremes of the numerical
parameters: what the work bound of one advance (mechanics.simulation.work_bound, the FMU's `work_bound`) must
allow. Prints one line per case; asserts nothing.

Run from anywhere:  python benchmarks/bench_work_bound.py [CASE-SUBSTRING ...]
"""
from __future__ import annotations

import sys
import time

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.loop.integrators import ACCEPTED, EVENT_RETRIES, REJECTED

CASES = {  # label -> (parameters, speed [rpm], simulated time [s])
    "defaults (real_gas, dopri5, 1500 rpm)": (dict(), 1500.0, 0.045),
    "abm4": (dict(integrator="abm4"), 1500.0, 0.045),
    "polytropic": (dict(pressure_model="polytropic"), 1500.0, 0.045),
    "30000 rpm (the input's maximum), ideal_gas_table": (dict(pressure_model="ideal_gas_table"), 30000.0, 0.005),
    "max_step = 1e-8 s (its minimum)": (dict(max_step=1e-8, initial_step=1e-9), 1500.0, 0.002),
    "rtol = 1e-10, tolerance_scale = 1e-3 (their minima)": (dict(relative_tolerance=1e-10, tolerance_scale=1e-3),
                                                            1500.0, 0.005),
    "rtol = 1e-10, tolerance_scale = 1e-3, abm4": (dict(relative_tolerance=1e-10, tolerance_scale=1e-3,
                                                        integrator="abm4"), 1500.0, 0.005),
    "clearances 1 um": (dict(slot_clearance=1e-6, stator_clearance=1e-6), 1500.0, 0.045),
}


def main(selected: list[str]) -> None:
    for label, (values, rpm, duration) in CASES.items():
        if selected and not any(part in label for part in selected):
            continue
        simulation = Simulation(CompressorParameters(**values), constant_speed(rpm), initial_angle=0.0,
                                keep_history=False)
        start = time.perf_counter()
        simulation.advance(duration)
        wall = time.perf_counter() - start
        attempts = int(simulation.counters[ACCEPTED] + simulation.counters[REJECTED]
                       + simulation.counters[EVENT_RETRIES])
        print(f"{label}: {attempts} attempts in {duration * 1e3:g} ms = {attempts / (duration * 1e3):.0f} per ms "
              f"({wall:.2f} s wall, the first case including compilation)", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
