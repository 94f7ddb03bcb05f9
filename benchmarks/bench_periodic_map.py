"""Periodic-map tables: build time per speed point (1 vs 2 workers), evaluation cost per 1 ms step against the
detailed model's advance, and accuracy of the table against an independent detailed run (torque waveform and
per-revolution figures, at a grid speed and between grid speeds, at zero and at 0.05 mm clearance, with the
revolution-to-revolution scatter of the detailed model itself).

Usage:  python benchmarks/bench_periodic_map.py [--repeats 3] [--pressure-model polytropic]
"""
import argparse
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.reduced.periodic_map import TORQUE, MapSettings, build_map, run_speed_point
from rotary_vane.mechanics.loop.speed import RPM

from report import heading, table  # benchmarks/ is the script's folder

OPERATING_RPM = 1500.0
STEP = 1e-3
BETWEEN_RPM = 1400.0          # between grid speeds (the refined grid's midpoints are 1446 and 1211)


def build_times(params, speeds, settings, workers, repeats):
    """Median wall time per speed point of a fresh build (empty cache) on `workers` processes."""
    walls = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as folder:
            start = time.perf_counter()
            build_map(params, speeds, settings=settings, workers=workers, cache_dir=Path(folder))
            walls.append((time.perf_counter() - start) / len(speeds))
    return statistics.median(walls)


def step_costs(params, table, speed_rpm, steps, repeats):
    """(detailed, table) median wall time per 1 ms step."""
    detailed, mapped = [], []
    for _ in range(repeats):
        simulation = Simulation(params, constant_speed(speed_rpm), initial_angle=0.0, keep_history=False,
                                table_speed_rpm=OPERATING_RPM)
        simulation.advance(0.1)
        start = time.perf_counter()
        for k in range(steps):
            simulation.advance(0.1 + (k + 1) * STEP, speed_rpm=speed_rpm, interpolate=True)
        detailed.append((time.perf_counter() - start) / steps)
        omega = speed_rpm * RPM
        start = time.perf_counter()
        for k in range(steps):          # what the FMU does per step: every channel, the work, the figures
            angle0, angle1 = k * STEP * omega, (k + 1) * STEP * omega
            table.torque_integral(angle0, angle1, speed_rpm)
            table.values(angle1, speed_rpm)
            table.figures_at(speed_rpm)
        mapped.append((time.perf_counter() - start) / steps)
    return statistics.median(detailed), statistics.median(mapped)


def accuracy(params, table, speed_rpm, settings):
    """Table against an independent detailed run at `speed_rpm` (more revolutions than the table's)."""
    reference = run_speed_point(params, speed_rpm, MapSettings(table_speed_rpm=OPERATING_RPM,
                                                               warmup_revolutions=settings.warmup_revolutions + 2,
                                                               averaged_revolutions=settings.averaged_revolutions))
    torque = reference["mean"][TORQUE]
    angles = (np.arange(table.samples) + 0.5) * table.step
    mapped = np.array([table.value(TORQUE, a, speed_rpm) for a in angles])
    ripple = float(np.std(torque))
    power_error = table.figure("input_power", speed_rpm) / reference["figures"]["input_power"] - 1.0
    return dict(waveform=float(np.sqrt(np.mean((mapped - torque) ** 2))) / ripple,
                scatter=reference["scatter"][TORQUE] / ripple, power=power_error,
                power_scatter=reference["figure_scatter"]["input_power"] / reference["figures"]["input_power"])


def fmu_step_costs(fmu: Path, steps: int, repeats: int, clearance: float, pressure_model: str):
    """Median wall time of fmpy's low-level doStep at h = 1 ms, 1500 rpm, per fidelity (same process, same run)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    description = read_model_description(str(fmu))
    folder = extract(str(fmu))
    references = {v.name: v.valueReference for v in description.modelVariables}
    costs = {}
    for fidelity in ("detailed", "periodic_map"):
        walls = []
        for repeat in range(repeats):
            slave = FMU2Slave(guid=description.guid, unzipDirectory=folder,
                              modelIdentifier=description.coSimulation.modelIdentifier,
                              instanceName=f"{fidelity}{repeat}")
            slave.instantiate()
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.setString([references["fidelity"], references["pressure_model"]], [fidelity, pressure_model])
            slave.setReal([references[n] for n in ("shaft_speed", "slot_clearance", "stator_clearance")],
                          [OPERATING_RPM, clearance, clearance])
            slave.exitInitializationMode()
            for k in range(50):                              # past the first revolutions
                slave.doStep(k * STEP, STEP)
            start = time.perf_counter()
            for k in range(50, 50 + steps):
                slave.doStep(k * STEP, STEP)
            walls.append((time.perf_counter() - start) / steps)
            slave.terminate()
            slave.freeInstance()
        costs[fidelity] = statistics.median(walls)
    shutil.rmtree(folder, ignore_errors=True)           # fmpy's extract made it (40 MB); nothing else removes it
    return costs


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--pressure-model", default="polytropic", choices=("polytropic", "ideal_gas_table",
                                                                            "real_gas"))
    parser.add_argument("--fmu", type=Path, default=None, help="RotaryVaneCompressor.fmu to time (default: build "
                                                                 "one into a temporary folder)")
    args = parser.parse_args(argv)
    settings = MapSettings(table_speed_rpm=OPERATING_RPM)
    speeds = np.linspace(0.1, 1.2, 8) * OPERATING_RPM

    heading(f"Table build ({args.pressure_model}, c = 0, {settings.warmup_revolutions} warm-up + "
            f"{settings.averaged_revolutions} averaged revolutions per speed)")
    params = CompressorParameters(pressure_model=args.pressure_model)
    run_speed_point(params, OPERATING_RPM, settings)             # compile once
    four = speeds[[2, 3, 5, 7]]
    one = build_times(params, four, settings, 1, args.repeats)
    two = build_times(params, four, settings, 2, args.repeats)
    print(table(["workers", "s per speed point", "speed-up"],
                [["1", f"{one:.2f}", "1.00"], ["2", f"{two:.2f}", f"{one / two:.2f}"]]))

    rows, cost_rows = [], []
    for clearance in (0.0, 5e-5):
        params = CompressorParameters(pressure_model=args.pressure_model, slot_clearance=clearance,
                                      stator_clearance=clearance)
        with tempfile.TemporaryDirectory() as folder:
            mapped = build_map(params, settings=settings, operating_rpm=OPERATING_RPM, workers=2,
                               cache_dir=Path(folder))
        print(f"c = {1e3 * clearance:.2f} mm: grid {', '.join(f'{s:.0f}' for s in mapped.speeds)} rpm")
        for speed in (float(speeds[5]), BETWEEN_RPM):
            figures = accuracy(params, mapped, speed, settings)
            rows.append([f"{1e3 * clearance:.2f}", f"{speed:.0f}", "grid" if speed in mapped.speeds else "between",
                         f"{100 * figures['waveform']:.2f}", f"{100 * figures['scatter']:.2f}",
                         f"{100 * figures['power']:+.3f}", f"{100 * figures['power_scatter']:.3f}"])
        detailed, cost = step_costs(params, mapped, OPERATING_RPM, 200, args.repeats)
        cost_rows.append([f"{1e3 * clearance:.2f}", f"{1e6 * detailed:.1f}", f"{1e6 * cost:.1f}",
                          f"{detailed / cost:.1f}"])
    heading("Accuracy of the table against an independent detailed run")
    print(table(["c [mm]", "rpm", "speed", "torque waveform RMS diff [% ripple RMS]",
                 "detailed rev-to-rev scatter [% ripple RMS]", "input power [%]", "power rev scatter [%]"], rows))
    heading(f"Cost per {STEP * 1e3:g} ms step at {OPERATING_RPM:g} rpm (median of {args.repeats})")
    print(table(["c [mm]", "detailed [us]", "table [us]", "ratio"], cost_rows))

    with tempfile.TemporaryDirectory() as folder:
        fmu = args.fmu
        if fmu is None:
            import subprocess
            subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", folder], check=True,
                           capture_output=True)
            fmu = Path(folder) / "RotaryVaneCompressor.fmu"
        rows = []
        for clearance in (0.0, 5e-5):
            costs = fmu_step_costs(fmu, 200, args.repeats, clearance, args.pressure_model)
            rows.append([f"{1e3 * clearance:.2f}", f"{1e6 * costs['detailed']:.0f}",
                         f"{1e6 * costs['periodic_map']:.0f}", f"{costs['detailed'] / costs['periodic_map']:.1f}"])
    heading(f"FMU through fmpy's low-level doStep, h = {STEP * 1e3:g} ms, {OPERATING_RPM:g} rpm "
            f"(median of {args.repeats})")
    print(table(["c [mm]", "detailed [us/step]", "periodic_map [us/step]", "ratio"], rows))


if __name__ == "__main__":
    main()
