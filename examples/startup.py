"""The thesis's start-up case through the compressor FMU and fmpy: speed ramp from rest, vane kinematics vs time.

The shaft speed follows the cycloidal ramp of docs/model.md §3.2 from rest to omega_ss over t_r (default 1500 rpm over
0.4 s), then stays constant; the run covers 0-1.2 s (thesis Fig. 5.2):

    t < t_r:  omega(t) = omega_ss (t/t_r - sin(2 pi t/t_r)/(2 pi)),        t >= t_r:  omega(t) = omega_ss

The FMU input `shaft_speed` [rpm] is, with interpolate_speed = true (the FMU's default, set here explicitly), the
speed at the END of each communication step: the FMU moves the speed linearly from its last value to the input
over the step. fmpy applies an input signal at the START of each step (it sets u(t_k) before doStep(t_k, h)), so
the signal given to fmpy carries omega(t_k + h) at t_k. The rotor then turns through the trapezoidal integral of
the sampled ramp (the test checks the FMU's shaft_angle against the closed-form angle of docs/model.md §3.2).

Plots (thesis Figs 5.33-5.47): s_r, v_r, a_r, v_theta, a_theta (docs/model.md §3.4) vs time over 0-0.5 s, 0-0.4 s and
0.4-0.5 s, one PNG per window (startup_0.0-0.5s.png, ...). v_theta and a_theta are plotted when the FMU has the
outputs vane_tangential_velocity and vane_tangential_acceleration; otherwise their panels say so. Also written:
result.csv (every output at every communication point) and a table of peak values per window (printed and in
summary.json).

Usage:  python examples/startup.py [--speed 1500] [--ramp-time 0.4] [--stop-time 1.2] [--step 1e-4]
"""
from __future__ import annotations

import argparse
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")                      # files only, no window
import matplotlib.pyplot as plt            # noqa: E402
import numpy as np                         # noqa: E402

from rotary_vane.examples import fmu_harness as harness              # noqa: E402
from rotary_vane.examples.cli_types import number_parser  # noqa: E402

WINDOWS = ((0.0, 0.5), (0.0, 0.4), (0.4, 0.5))      # s, the thesis's start-up figures
# (label, FMU output, scale to the plotted unit, plotted unit)
QUANTITIES = (
    ("s_r", "vane_displacement", 1e3, "mm"),
    ("v_r", "vane_velocity", 1.0, "m/s"),
    ("a_r", "vane_acceleration", 1.0, "m/s2"),
    ("v_theta", "vane_tangential_velocity", 1.0, "m/s"),
    ("a_theta", "vane_tangential_acceleration", 1.0, "m/s2"),
)


def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="Start-up of RotaryVaneCompressor.fmu with fmpy: cycloidal speed ramp from rest (docs/model.md §3.2), "
                    "vane kinematics vs time over 0-0.5, 0-0.4 and 0.4-0.5 s (thesis Figs 5.33-5.47).",
        formatter_class=harness.HelpFormatter)
    parser.add_argument("--speed", type=number_parser("rpm"), default=1500.0,
                        help="steady speed omega_ss reached at the end of the ramp [rpm]")
    parser.add_argument("--ramp-time", type=number_parser("s"), default=0.4,
                        help="ramp duration t_r [s] (cycloidal ramp from rest)")
    parser.add_argument("--stop-time", type=number_parser("s"), default=1.2, help="simulated time [s]")
    parser.add_argument("--clearance", type=number_parser("m", low_inclusive=True), default=5e-5,
                        help="clearance [m]: sets slot_clearance (vane-slot, total) and stator_clearance "
                             "(vane-stator, radial); 5e-5 m = 0.05 mm")
    parser.add_argument("--step", type=number_parser("s", 0.0, 0.01), default=1e-4,
                        help="communication step [s] (fmpy's output_interval); the thesis's curves need about "
                             "1e-4 s to show the vane's impacts")
    harness.add_common_options(parser, "startup")
    args = parser.parse_args(argv)
    if args.step > args.stop_time / 10.0:
        raise harness.InputError(f"--step = {args.step:g} s is too large: allowed (0, stop time/10] = "
                                 f"(0, {args.stop_time / 10.0:g}] s")
    return args


def ramp_speed(t, speed, ramp_time):
    """omega(t) of the cycloidal ramp (docs/model.md §3.2), in the unit of `speed`; t may be an array."""
    t = np.asarray(t, dtype=float)
    u = np.minimum(t / ramp_time, 1.0)
    return speed * (u - np.sin(2.0 * math.pi * u) / (2.0 * math.pi))


def speed_signal(speed, ramp_time, stop_time, step):
    """fmpy input: at each communication point t_k the speed of the END of the step, omega(t_k + h) [rpm]."""
    count = round(stop_time / step)
    times = np.arange(count + 1) * step
    signal = np.zeros(count + 1, dtype=[("time", np.float64), ("shaft_speed", np.float64)])
    signal["time"] = times
    signal["shaft_speed"] = ramp_speed(times + step, speed, ramp_time)
    return signal


def window_peaks(result, available) -> list[dict]:
    """Per window: the largest |value| of each quantity the FMU provides (NaN where it does not)."""
    rows = []
    for start, end in WINDOWS:
        inside = (result["time"] >= start) & (result["time"] <= end)
        row = {"window": f"{start:g}-{end:g} s", "points": int(inside.sum())}
        for label, name, _, _ in QUANTITIES:
            row[label] = float(np.max(np.abs(result[name][inside]))) if name in available and inside.any() \
                else math.nan
        rows.append(row)
    return rows


def print_peaks(rows) -> None:
    units = {label: unit for label, _, _, unit in QUANTITIES}
    header = f"{'window':>10} {'points':>7}" + "".join(f"{'max|' + label + '| [' + units[label] + ']':>21}"
                                                      for label in units)
    print(header)
    for row in rows:
        cells = "".join(f"{row[label] * (1e3 if label == 's_r' else 1.0):21.4g}" for label in units)
        print(f"{row['window']:>10} {row['points']:7d}{cells}")


def plot_window(result, available, start, end, path, title):
    inside = (result["time"] >= start - 1e-12) & (result["time"] <= end + 1e-12)
    t = result["time"][inside]
    fig, axes = plt.subplots(len(QUANTITIES) + 1, 1, figsize=(9, 12), sharex=True)
    step_speed = np.diff(result["shaft_angle"]) / np.diff(result["time"]) / harness.RPM
    axes[0].plot(result["time"][1:][inside[1:]], step_speed[inside[1:]], lw=1.0)
    axes[0].set_ylim(0.0, 1.1 * max(float(np.max(step_speed)), 1.0))
    axes[0].set_ylabel("speed [rpm]\n(mean over each step)")
    for ax, (label, name, scale, unit) in zip(axes[1:], QUANTITIES):
        if name in available:
            ax.plot(t, scale * result[name][inside], lw=0.6)
        else:
            ax.text(0.5, 0.5, f"{label}: not an output of this FMU (needs '{name}')", ha="center", va="center",
                    transform=ax.transAxes, color="0.4")
        ax.set_ylabel(f"{label} [{unit}]")
    for ax in axes:
        ax.grid(True, alpha=0.4)
    axes[0].set_title(title, fontsize=10)
    axes[-1].set_xlim(start, end)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    args = parse_arguments(argv)
    from fmpy import read_model_description
    from fmpy.util import write_csv
    fmu_dir = harness.ensure_fmus(args.fmu_dir)
    fmu = fmu_dir / f"{harness.COMPRESSOR}.fmu"
    out = harness.output_folder(args.out)
    model_description = read_model_description(str(fmu))
    harness.check_start_values(model_description, {"shaft_speed": args.speed})     # the ramp's top speed
    variables = harness.model_variables(model_description)
    available = {name for _, name, _, _ in QUANTITIES if name in variables}
    missing = [name for _, name, _, _ in QUANTITIES if name not in available]
    if missing:
        print(f"note: {fmu.name} has no output {', '.join(missing)}; those panels stay empty")
    values = {"shaft_speed": 0.0, "slot_clearance": args.clearance, "stator_clearance": args.clearance,
              "interpolate_speed": True}
    print(f"simulating {fmu.name}: ramp 0 -> {args.speed:g} rpm over {args.ramp_time:g} s, {args.stop_time:g} s in "
          f"steps of {args.step:g} s, start values {values}")
    log = harness.FmuLog(args.verbose)
    result = harness.simulate(fmu, stop_time=args.stop_time, step=args.step, start_values=values, log=log,
                              input=speed_signal(args.speed, args.ramp_time, args.stop_time, args.step),
                              progress=harness.ProgressBar(args.stop_time, "startup"))
    write_csv(out / "result.csv", result)
    peaks = window_peaks(result, available)
    print_peaks(peaks)
    written = ["result.csv", "summary.json"]
    for start, end in WINDOWS:
        if start >= args.stop_time:
            print(f"window {start:g}-{end:g} s is beyond the stop time {args.stop_time:g} s: not plotted")
            continue
        name = f"startup_{start:.1f}-{end:.1f}s.png"
        plot_window(result, available, start, min(end, args.stop_time), out / name,
                    f"RotaryVaneCompressor.fmu start-up: 0 -> {args.speed:g} rpm over {args.ramp_time:g} s "
                    f"(cycloidal), c = {1e3 * args.clearance:g} mm, step {args.step:g} s")
        written.append(name)
    (out / "summary.json").write_text(json.dumps(dict(
        speed_rpm=args.speed, ramp_time=args.ramp_time, stop_time=args.stop_time, step=args.step,
        start_values=values, missing_outputs=missing, window_peaks=peaks, files=written), indent=2))
    print(f"wrote {out}/" + ", ".join(written))
    return 0


if __name__ == "__main__":
    sys.exit(harness.run_main(main))
