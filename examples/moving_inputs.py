"""RotaryVaneCompressor.fmu between an evaporator and a condenser that move: the start of a refrigeration
compressor through fmpy, with the suction and discharge conditions as FMU inputs (README "Suction and discharge
conditions as inputs").

From equal pressures p_s = p_d = 0.6 MPa at the start speed (--start-speed, default 0 rpm: standstill), the
shaft speed ramps linearly to 1500 rpm in 0.5 s while the suction pressure falls linearly to 0.2928 MPa and the
discharge pressure rises linearly to 1.3179 MPa over 2 s, the suction gas 10 K above its dew point throughout
(suction_temperature from CoolProp's dew line here, in the script: the FMU computes nothing from CoolProp in its
time loop); then everything is held for 1 s. The reference is a run started at the final pressures and speed,
for as long. Compared: the input power and discharge mass flow of the last completed revolution (the FMU's
per-revolution outputs). Conservation: the sums of the step means (suction_mass_flow_mean,
discharge_mass_flow_mean, discharge_enthalpy_mean x delivered mass of the step) times the step against the
cumulative outputs drawn_mass, delivered_mass, delivered_enthalpy.

Writes under out/moving_inputs/: moving_inputs.csv (every communication point of the moving run),
moving_inputs.png (speed, pressures, torque, mass flows, discharge enthalpy) and summary.json.

Usage:  python examples/moving_inputs.py [--step 1e-3] [--start-speed 0] [--hold 1.0]
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")                      # files only, no window
import matplotlib.pyplot as plt            # noqa: E402
import numpy as np                         # noqa: E402

from rotary_vane.examples import fmu_harness as harness              # noqa: E402

START_PRESSURE = 0.6e6                      # Pa, both sides at the start
FINAL_SUCTION, FINAL_DISCHARGE = 0.2928e6, 1.3179e6     # Pa
SPEED = 1500.0                              # rpm
SPEED_RAMP, PRESSURE_RAMP = 0.5, 2.0        # s
SUPERHEAT = 10.0                            # K above the dew point of the suction pressure
RECORDED = ("shaft_torque_mean", "shaft_work", "input_power", "discharge_mass_flow", "suction_mass_flow",
            "leading_chamber_pressure", "trailing_chamber_pressure", "drawn_mass", "delivered_mass",
            "delivered_enthalpy", "suction_mass_flow_mean", "discharge_mass_flow_mean", "discharge_enthalpy_mean")
AGREEMENT = 0.01                            # relative: final figures against the reference run


def ramp(t, start, end, duration):
    return start + (end - start) * np.clip(t / duration, 0.0, 1.0)


def input_signals(stop_time: float, step: float, start_speed: float) -> np.ndarray:
    """fmpy's input array: speed, pressures and the suction temperature at every communication point."""
    from CoolProp.CoolProp import PropsSI
    times = np.arange(0.0, stop_time + 0.5 * step, step)
    suction = ramp(times, START_PRESSURE, FINAL_SUCTION, PRESSURE_RAMP)
    signals = np.zeros(times.size, dtype=[("time", np.float64), ("shaft_speed", np.float64),
                                          ("suction_pressure", np.float64), ("discharge_pressure", np.float64),
                                          ("suction_temperature", np.float64)])
    signals["time"] = times
    signals["shaft_speed"] = ramp(times, start_speed, SPEED, SPEED_RAMP)
    signals["suction_pressure"] = suction
    signals["discharge_pressure"] = ramp(times, START_PRESSURE, FINAL_DISCHARGE, PRESSURE_RAMP)
    signals["suction_temperature"] = [PropsSI("T", "P", p, "Q", 1.0, "R134a") + SUPERHEAT for p in suction]
    return signals


def run(fmu: Path, stop_time: float, step: float, start_values: dict, signals, log, label: str):
    started = time.perf_counter()
    result = harness.simulate(fmu, stop_time=stop_time, step=step, start_values=start_values, log=log,
                              input=signals, progress=harness.ProgressBar(stop_time, label))
    return result, time.perf_counter() - started


def conservation(result, step: float) -> dict:
    """Relative differences between the sums of the step means x step and the cumulative outputs at the end."""
    delivered = np.diff(result["delivered_mass"], prepend=0.0)
    sums = {"drawn_mass": np.sum(result["suction_mass_flow_mean"][1:]) * step,
            "delivered_mass": np.sum(result["discharge_mass_flow_mean"][1:]) * step,
            "delivered_enthalpy": np.sum((result["discharge_enthalpy_mean"] * delivered)[1:])}
    return {name: float(abs(total / result[name][-1] - 1.0)) for name, total in sums.items()}


def with_inputs(result, signals) -> dict:
    """The recorded outputs and the inputs (fmpy records outputs only) at the communication points, by name."""
    columns = {name: result[name] for name in result.dtype.names}
    for name in signals.dtype.names[1:]:
        columns[name] = np.interp(result["time"], signals["time"], signals[name])
    return columns


def plot(result, path: Path) -> None:
    t = result["time"]
    figure, axes = plt.subplots(4, 1, figsize=(9, 11), sharex=True)
    axes[0].plot(t, result["shaft_speed"], label="shaft speed input [rpm]")
    axes[0].set_ylabel("rpm")
    axes[1].plot(t, result["suction_pressure"] / 1e5, label="suction pressure input")
    axes[1].plot(t, result["discharge_pressure"] / 1e5, label="discharge pressure input")
    axes[1].plot(t, result["leading_chamber_pressure"] / 1e5, lw=0.4, alpha=0.6, label="leading chamber")
    axes[1].set_ylabel("bar")
    axes[2].plot(t, result["shaft_torque_mean"], lw=0.5, label="shaft torque, step mean [N m]")
    axes[2].plot(t, result["input_power"] / 100.0, label="input power, last revolution [100 W]")
    axes[3].plot(t, result["suction_mass_flow_mean"] * 1e3, lw=0.5, label="suction mass flow, step mean")
    axes[3].plot(t, result["discharge_mass_flow_mean"] * 1e3, lw=0.5, label="discharge mass flow, step mean")
    axes[3].plot(t, result["discharge_mass_flow"] * 1e3, label="discharge mass flow, last revolution")
    axes[3].set_ylabel("g/s")
    axes[3].set_xlabel("time [s]")
    for axis in axes:
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8, loc="best")
    axes[0].set_title("RotaryVaneCompressor.fmu: start with moving suction and discharge conditions (fmpy)")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=harness.HelpFormatter)
    harness.add_common_options(parser, "moving_inputs")
    parser.add_argument("--step", type=float, default=1e-3, help="communication step [s]")
    parser.add_argument("--start-speed", type=float, default=0.0, help="shaft speed at t = 0 [rpm]")
    parser.add_argument("--hold", type=float, default=1.0, help="time everything is held after the ramps [s]")
    args = parser.parse_args(argv)
    fmu = harness.ensure_fmus(args.fmu_dir) / f"{harness.COMPRESSOR}.fmu"
    out = harness.output_folder(args.out)
    stop_time = PRESSURE_RAMP + args.hold
    log = harness.FmuLog()
    start = {"rotor_inertia": 0.0, "shaft_speed": args.start_speed, "suction_pressure": START_PRESSURE,
             "discharge_pressure": START_PRESSURE}
    signals = input_signals(stop_time, args.step, args.start_speed)
    start["suction_temperature"] = float(signals["suction_temperature"][0])
    moving, moving_time = run(fmu, stop_time, args.step, start, signals, log, "moving inputs")
    moving = with_inputs(moving, signals)
    final = {"rotor_inertia": 0.0, "shaft_speed": SPEED, "suction_pressure": FINAL_SUCTION,
             "discharge_pressure": FINAL_DISCHARGE, "suction_temperature": float(signals["suction_temperature"][-1])}
    reference, reference_time = run(fmu, args.hold + SPEED_RAMP, args.step, final, None, log, "reference")
    figures = {name: (float(moving[name][-1]), float(reference[name][-1]),
                      float(moving[name][-1] / reference[name][-1] - 1.0))
               for name in ("input_power", "discharge_mass_flow")}
    summary = {"step": args.step, "start_speed": args.start_speed, "stop_time": stop_time,
               "final_figures (moving, reference, relative difference)": figures,
               "conservation (relative)": conservation(moving, args.step),
               "wall time [s] (moving, reference)": [moving_time, reference_time],
               "warnings (first 10)": [message[3][:300] for message in log.messages if message[0] == 1][:10]}
    with open(out / "moving_inputs.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        names = ["time", "shaft_speed", "suction_pressure", "discharge_pressure", "suction_temperature", *RECORDED]
        writer.writerow(names)
        for row in zip(*(moving[name] for name in names)):
            writer.writerow([repr(float(value)) for value in row])
    plot(moving, out / "moving_inputs.png")
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary, indent=1))
    agreement = all(abs(difference) <= AGREEMENT for _, _, difference in figures.values())
    print(f"final input power and discharge mass flow within {AGREEMENT:.0%} of the reference: {agreement}")
    return 0 if agreement else 1


if __name__ == "__main__":
    sys.exit(harness.run_main(main))
