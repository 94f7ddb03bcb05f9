"""The compressor FMU alone at constant speed, through fmpy as a user runs it (the README's main job).

Builds the FMUs if they are missing or stale, simulates RotaryVaneCompressor.fmu at a constant shaft speed
(default 1500 rpm for 1 s, communication step 1 ms), prints a short summary of the last completed revolution and
writes, under out/standalone/ by default:

* result.csv         every output at every communication point (fmpy.util.write_csv);
* summary.json       the printed summary as numbers;
* torque_power.png   shaft torque (end of step and step mean) and the per-revolution powers vs time;
* kinematics.png     vane displacement, velocity, acceleration and tilt vs rotor angle over the last revolution;
* contact_forces.png the normal force of each contact region c1..c6 vs rotor angle over the last revolution.

The FMU reports end-of-step values at the communication points (every `--step` seconds) and exact figures over
the last completed revolution (powers, efficiency, peak contact force, computed at every internal step). Plots
against the rotor angle therefore show samples: use a smaller --step for more detail.

Usage:  python examples/standalone.py [--speed 1500] [--clearance 5e-5] [--lobes 3] [--duration 1] [--step 1e-3]
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
from rotary_vane.mechanics.contact.regions import REGION_COUNT  # noqa: E402

GAS_OUTPUTS = ("discharge_mass_flow", "discharge_temperature")     # from the real-gas model
REGIONS = range(1, REGION_COUNT + 1)            # c1..c8 (docs/model.md §1.3): leading, trailing in turn


def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="Simulate RotaryVaneCompressor.fmu alone at constant shaft speed with fmpy, print a summary "
                    "of the last completed revolution, write result.csv, summary.json and PNG plots.",
        formatter_class=harness.HelpFormatter)
    parser.add_argument("--speed", type=number_parser("rpm"), default=1500.0,
                        help="constant shaft speed [rpm] (the FMU input shaft_speed; its range is checked against "
                             "the FMU's modelDescription)")
    parser.add_argument("--clearance", type=number_parser("m", low_inclusive=True), default=5e-5,
                        help="clearance [m]: sets both slot_clearance (vane-slot, total) and stator_clearance "
                             "(vane-stator, radial), as in the thesis; 5e-5 m = 0.05 mm")
    parser.add_argument("--lobes", type=int, default=3, help="number of stator lobes z (compression cycles per "
                                                            "revolution)")
    parser.add_argument("--fluid", default=None,
                        help="working fluid name (the FMU's String parameter 'fluid', from the real-gas model); "
                             "default: the FMU's own default")
    parser.add_argument("--pressure-model", default="real_gas",
                        choices=("real_gas", "ideal_gas_table", "polytropic"),
                        help="chamber gas: real_gas (Level 1, real fluid in chambers coupled to the vane; gives "
                             "mass flow and discharge temperature), ideal_gas_table (Level 0.5, faster) or "
                             "polytropic (Level 0)")
    parser.add_argument("--duration", type=number_parser("s"), default=1.0,
                        help="simulated time [s]; at least 2 revolutions (the first settles the start, the "
                             "summary is over the last completed one)")
    parser.add_argument("--step", type=number_parser("s", 0.0, 0.05), default=1e-3,
                        help="communication step [s] (fmpy's output_interval): the FMU is called and sampled "
                             "every STEP seconds")
    harness.add_common_options(parser, "standalone")
    args = parser.parse_args(argv)
    revolution = 60.0 / args.speed
    if args.duration < 2.0 * revolution:
        raise harness.InputError(f"--duration = {args.duration:g} s is too short: allowed >= 2 revolutions = "
                                 f"{2.0 * revolution:g} s at {args.speed:g} rpm")
    if args.step > args.duration / 2.0:
        raise harness.InputError(f"--step = {args.step:g} s is too large: allowed (0, duration/2] = "
                                 f"(0, {args.duration / 2.0:g}] s")
    return args


def start_values(args, fmu) -> dict:
    """The FMU's start values from the options, checked against its modelDescription."""
    values = {"shaft_speed": args.speed, "slot_clearance": args.clearance, "stator_clearance": args.clearance,
              "lobes": args.lobes, "pressure_model": args.pressure_model}
    if args.fluid is not None:
        if not harness.has_variables(fmu, "fluid"):
            raise harness.InputError(f"--fluid {args.fluid!r}: {fmu.name} has no parameter 'fluid' (it comes with "
                                     f"the real-gas model); leave --fluid out")
        values["fluid"] = args.fluid
    from fmpy import read_model_description
    harness.check_start_values(read_model_description(str(fmu)), values)
    return values


# summary ----------------------------------------------------------------------------------------------------
def mode_label(mask: int) -> str:
    """Contact-mode bit mask -> 'c1+c5' (bit k-1 set for region ck); 'free' for no contact."""
    return "+".join(f"c{k}" for k in REGIONS if mask >> (k - 1) & 1) or "free"


def last_revolution(result) -> np.ndarray:
    """Indices of the communication points within the last 2 pi of rotor angle."""
    angle = result["shaft_angle"]
    return np.flatnonzero(angle >= angle[-1] - 2.0 * math.pi)


def summarise(result, speed_rpm: float, gas_outputs: bool) -> dict:
    """The summary: the FMU's figures over the last completed revolution at the stop time, plus what only the
    communication points show (the region of the largest sampled contact force, the modes seen).

    Mean shaft torque over that revolution = input power / omega (W_rev = P_in T_rev and T_rev = 2 pi / omega
    at constant speed)."""
    end = result[-1]
    window = last_revolution(result)
    sampled_peaks = [float(np.max(result[f"contact_force_{k}"][window])) for k in REGIONS]
    busiest = int(np.argmax(sampled_peaks))
    summary = {
        "speed_rpm": speed_rpm,
        "stop_time": float(end["time"]),
        "mean_shaft_torque": float(end["input_power"]) / (speed_rpm * harness.RPM),
        "input_power": float(end["input_power"]),
        "output_power": float(end["output_power"]),
        "indicated_power": float(end["indicated_power"]),
        "gap_power": float(end["gap_power"]),
        "friction_power": float(end["friction_power"]),
        "damping_power": float(end["damping_power"]),
        "energy_ledger_residual": float(end["energy_ledger_residual"]),
        "mechanical_efficiency": float(end["mechanical_efficiency"]),
        "max_contact_force": float(end["max_contact_force"]),
        "max_slot_force": float(end["max_slot_force"]),
        "max_tip_force": float(end["max_tip_force"]),
        "revolution_mode_count": int(end["revolution_mode_count"]),
        "revolution_mode_count_extended": int(end["revolution_mode_count_extended"]),
        "sampled_peak_region": f"c{busiest + 1}",
        "sampled_peak_force": sampled_peaks[busiest],
        "sampled_peak_forces": sampled_peaks,
        "contact_mode_count": int(end["contact_mode_count"]),
        "sampled_modes": sorted({mode_label(int(m)) for m in result["contact_mode"][window]}),
        "discharge_mass_flow": float(end["discharge_mass_flow"]) if gas_outputs else None,
        "discharge_temperature": float(end["discharge_temperature"]) if gas_outputs else None,
    }
    return summary


def print_summary(s: dict) -> None:
    def gas(value, unit, digits):
        return "n/a (needs --pressure-model real_gas)" if value is None else f"{value:.{digits}g} {unit}"
    print(f"\nRotaryVaneCompressor.fmu at {s['speed_rpm']:g} rpm, t = {s['stop_time']:g} s; "
          f"figures over the last completed revolution:")
    print(f"  mean shaft torque        {s['mean_shaft_torque']:10.4f} N.m   (input power / omega)")
    print(f"  input power              {s['input_power']:10.2f} W")
    print(f"  output power (to gas)    {s['output_power']:10.2f} W     = indicated {s['indicated_power']:.2f} W "
          f"(p dV on the chambers) + gap sweep {s['gap_power']:.2f} W")
    print(f"  friction power           {s['friction_power']:10.2f} W")
    print(f"  contact damping power    {s['damping_power']:10.3f} W")
    print(f"  energy ledger residual   {100.0 * s['energy_ledger_residual']:10.4f} %     (shaft work not accounted "
          f"for, docs/model.md §6.4)")
    print(f"  mechanical efficiency    {100.0 * s['mechanical_efficiency']:10.2f} %")
    print(f"  peak contact force       {s['max_contact_force']:10.1f} N     rotor c1-c4, c7/c8 {s['max_slot_force']:.1f} N, "
          f"tip c5/c6 {s['max_tip_force']:.1f} N (every internal step); largest at the communication points: "
          f"{s['sampled_peak_region']} ({s['sampled_peak_force']:.1f} N)")
    print(f"  distinct contact modes   {s['revolution_mode_count']:10d}       (regions; "
          f"{s['revolution_mode_count_extended']} with the slot-mouth candidate, docs/model.md §4.6); whole run "
          f"{s['contact_mode_count']}; at the communication points: {', '.join(s['sampled_modes'])}")
    print(f"  discharge mass flow      {gas(s['discharge_mass_flow'], 'kg/s', 5)}")
    print(f"  discharge temperature    {gas(s['discharge_temperature'], 'K', 5)}")


# plots ------------------------------------------------------------------------------------------------------
def angle_axis(result, window):
    """Rotor angle in [0, 360) deg of the window's points, and the order that sorts them by it."""
    degrees = np.degrees(np.mod(result["shaft_angle"][window], 2.0 * math.pi))
    order = np.argsort(degrees)
    return degrees[order], window[order]


def finish(fig, axes, path, xlabel):
    for ax in np.ravel(axes):
        ax.grid(True, alpha=0.4)
    np.ravel(axes)[-1].set_xlabel(xlabel)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_torque_power(result, path, title):
    t = result["time"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    top.plot(t, result["shaft_torque"], lw=0.7, color="0.6", label="shaft_torque (end of step)")
    top.plot(t, result["shaft_torque_mean"], lw=1.2, label="shaft_torque_mean (shaft work / angle over the step)")
    top.set_ylabel("torque [N.m]")
    top.legend(loc="upper right", fontsize=8)
    top.set_title(title, fontsize=10)
    for name in ("input_power", "output_power", "friction_power"):
        bottom.step(t, result[name], where="post", label=name)
    bottom.set_ylabel("power [W]\n(mean over the last completed revolution)")
    bottom.legend(loc="center right", fontsize=8)
    finish(fig, [top, bottom], path, "time [s]")


def plot_kinematics(result, path, title):
    degrees, rows = angle_axis(result, last_revolution(result))
    panels = (("vane_displacement", 1e3, "s_r [mm]"), ("vane_velocity", 1.0, "v_r [m/s]"),
              ("vane_acceleration", 1.0, "a_r [m/s2]"), ("vane_tilt", 1e3, "tilt [mrad]"))
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 9), sharex=True)
    for ax, (name, scale, label) in zip(axes, panels):
        ax.plot(degrees, scale * result[name][rows], ".-", lw=0.8, ms=3)
        ax.set_ylabel(label)
    axes[0].set_title(title, fontsize=10)
    axes[-1].set_xlim(0, 360)
    axes[-1].set_xticks(range(0, 361, 60))
    finish(fig, axes, path, "rotor angle [deg] (last revolution, values at the communication points)")


def plot_contact_forces(result, path, title):
    degrees, rows = angle_axis(result, last_revolution(result))
    fig, axes = plt.subplots(REGION_COUNT // 2, 2, figsize=(10, 2.5 * REGION_COUNT // 2), sharex=True)
    for k, ax in zip(REGIONS, axes.ravel(order="F")):
        ax.plot(degrees, result[f"contact_force_{k}"][rows], ".-", lw=0.8, ms=3)
        ax.set_ylabel(f"c{k} normal force [N]")
        ax.set_xlim(0, 360)
        ax.set_xticks(range(0, 361, 60))
    fig.suptitle(title, fontsize=10)
    axes[-1, 0].set_xlabel("rotor angle [deg] (last revolution, at the communication points)")
    finish(fig, axes, path, "rotor angle [deg] (last revolution, at the communication points)")


# main -------------------------------------------------------------------------------------------------------
def main(argv=None) -> int:
    args = parse_arguments(argv)
    from fmpy.util import write_csv
    fmu_dir = harness.ensure_fmus(args.fmu_dir)
    fmu = fmu_dir / f"{harness.COMPRESSOR}.fmu"
    out = harness.output_folder(args.out)
    values = start_values(args, fmu)
    gas_outputs = harness.has_variables(fmu, *GAS_OUTPUTS) and args.pressure_model == "real_gas"
    log = harness.FmuLog(args.verbose)
    print(f"simulating {fmu.name}: {args.duration:g} s at {args.speed:g} rpm, communication step {args.step:g} s, "
          f"start values {values}")
    result = harness.simulate(fmu, stop_time=args.duration, step=args.step, start_values=values, log=log,
                              progress=harness.ProgressBar(args.duration, "standalone"))
    summary = summarise(result, args.speed, gas_outputs)
    summary["start_values"] = values
    summary["step"] = args.step
    print_summary(summary)
    write_csv(out / "result.csv", result)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    title = (f"RotaryVaneCompressor.fmu, {args.speed:g} rpm, c = {1e3 * args.clearance:g} mm, z = {args.lobes}, "
             f"step {args.step:g} s")
    plot_torque_power(result, out / "torque_power.png", title)
    plot_kinematics(result, out / "kinematics.png", title)
    plot_contact_forces(result, out / "contact_forces.png", title)
    print(f"\nwrote {out}/result.csv, summary.json, torque_power.png, kinematics.png, contact_forces.png")
    return 0


if __name__ == "__main__":
    sys.exit(harness.run_main(main))
