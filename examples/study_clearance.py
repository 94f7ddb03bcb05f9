"""Clearance study (thesis ch. 5; docs/model.md §4.6, §6.4, §10-§11): c_R = c_S in {0, 0.02, 0.05, 0.1, 0.2} mm at 1000,
1500 and 2000 rpm, z = 3, Level 0.5 pressure table (the thesis's gas loads, docs/model.md §6.1); and the energy
ledger at 1500 rpm for both pressure models and both leak laws.

Each point runs the library's `Simulation` at constant speed from the nominal pose (docs/model.md §3.3) for 4 revolutions
and reports the last full one (3 settling revolutions; `--quick`: 3 and 2), with `mechanics.performance` (means
from the work integrals, docs/model.md §6.4; dwell-filtered contact modes, docs/model.md §4.6). Points run in a process pool.

Written to `<out>/clearance/` (and printed):
* powers.md / powers.csv: mean input, output, friction and damping power, mechanical efficiency, energy-balance
  residual, peak contact force, peak tilt and distinct modes per point;
* ledger.md: at 1500 rpm, for the Level 0.5 table and real gas (nozzle leak law, and real gas with every open
  leakage path friction-corrected): mechanical, volumetric and isentropic efficiency, the energy ledger of
  docs/model.md §6.4, peak slot and tip force and the contact modes counted both ways (§4.6);
* kinematics.md: max / min / time-rms of s_r, v_r, a_r, v_theta, a_theta (docs/model.md §3.4) and tilt per clearance;
* contact_forces.md: peak normal force per region c1..c6 and the time-mean of the summed normal force;
* constraint_moments.md: max / mean / min of the driving torque T_d = -lambda6 and of the stator contact moment
  lambda3, and the mean stator reaction lambda3 + M_gas,stator that balances <T_d> (docs/model.md §6.2, T11);
* contact_modes.md: per speed, the dwell of every contact mode (label from the bit mask, bit k-1 = region ck) at
  each clearance and the count of modes dwelling at least tau_min;
* powers_vs_clearance.png, powers_all_speeds.png, efficiency_vs_clearance.png (cf. thesis Figs 5.48-5.54);
* contact_regions_<rpm>rpm.png: which regions touch over the revolution, one panel per clearance (cf. Figs 5.21-5.32);
* manifest.json for examples/study_report.py, which this script runs at the end (`<out>/report.md`).

Usage (from the project folder):

    python examples/study_clearance.py                      # 15 points into out/studies/clearance/
    python examples/study_clearance.py --quick --workers 1  # 3 clearances x 3 speeds, 3 revolutions
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import matplotlib

matplotlib.use("Agg")                      # files only, no window
import matplotlib.pyplot as plt            # noqa: E402
import numpy as np                         # noqa: E402

from rotary_vane.mechanics import CompressorParameters, IntegrationError, Simulation, constant_speed  # noqa: E402
from rotary_vane.mechanics.contact.modes import REGION_LABELS, mode_label  # noqa: E402
from rotary_vane.mechanics.performance import WindowSummary  # noqa: E402
from rotary_vane.mechanics.contact.regions import REGION_COUNT  # noqa: E402
from rotary_vane.examples.mechanics_demo import Run, plot_contact_modes, run_one  # noqa: E402
from rotary_vane.examples.study_report import DEFAULT_OUT, markdown_table, write_manifest, write_report  # noqa: E402

LOBES = 3
SPEEDS_RPM = (1000.0, 1500.0, 2000.0)
CLEARANCES_MM = (0.0, 0.02, 0.05, 0.1, 0.2)
QUICK_CLEARANCES_MM = (0.0, 0.05, 0.2)
REVOLUTIONS = 4                            # simulated from theta0 = 0.02 rad: 3 settle, the 4th is reported
QUICK_REVOLUTIONS = 3


# running points --------------------------------------------------------------------------------------------
def study_parameters(clearance_mm: float, lobes: int) -> CompressorParameters:
    """The Level 0.5 pressure table (the thesis's gas loads) and the library's other defaults, c_R = c_S =
    clearance."""
    return CompressorParameters(slot_clearance=clearance_mm * 1e-3, stator_clearance=clearance_mm * 1e-3,
                                lobes=lobes, pressure_model="ideal_gas_table")


LEDGER_RPM = 1500.0
# (pressure model, leak law of the open leakage paths): the friction-corrected law needs the real fluid's viscosity
LEDGER_CASES = (("ideal_gas_table", "nozzle"), ("real_gas", "nozzle"), ("real_gas", "friction_corrected"))
OPEN_LEAK_PATHS = ("end_valley_leak_law", "start_valley_leak_law", "tip_leak_law")


def ledger_parameters(model: str, leak_law: str, clearance_mm: float) -> CompressorParameters:
    """Defaults at clearance c_R = c_S, z = 3, the given pressure model, and every open leakage path on the given
    law (the slot faces stay sealed, docs/model.md §7.4)."""
    laws = {} if leak_law == "nozzle" else dict.fromkeys(OPEN_LEAK_PATHS, leak_law)
    return CompressorParameters(slot_clearance=clearance_mm * 1e-3, stator_clearance=clearance_mm * 1e-3,
                                lobes=LOBES, pressure_model=model, **laws)


def simulate_ledger_point(model: str, leak_law: str, clearance_mm: float, revolutions: int) -> Run:
    return run_one(clearance_mm, ledger_parameters(model, leak_law, clearance_mm), LEDGER_RPM, revolutions)


def describe_ledger_point(task: tuple, run: Run) -> str:
    model, leak_law, clearance_mm, _ = task
    return (f"{model}, {leak_law}, c = {clearance_mm:g} mm: ledger residual "
            f"{100 * run.summary.ledger_residual:+.4f} %, {run.wall_time:.2f} s")


def load_kernels() -> None:
    """Compile or load the numba kernels here, once, so that forked pool workers inherit them."""
    Simulation(CompressorParameters(), constant_speed(1500.0)).advance(1e-5)


class PointFailed(RuntimeError):
    """A study point whose integration stopped; one message, so that it crosses process boundaries."""


def run_task(function, task: tuple):
    """function(*task), an IntegrationError turned into PointFailed naming the task."""
    try:
        return function(*task)
    except IntegrationError as error:
        raise PointFailed(f"point {task}: {error.reason} at t = {error.time:.6g} s") from None


def run_points(function, tasks: list[tuple], workers: int, describe) -> list:
    """function(*task) for every task, on `workers` processes (in this process if 1); results in task order.

    `describe(task, result)` gives the progress line printed as each point finishes. Raises PointFailed."""
    load_kernels()
    if workers == 1:
        results = []
        for task in tasks:
            results.append(run_task(function, task))
            print(f"  {describe(task, results[-1])}", flush=True)
        return results
    results = [None] * len(tasks)
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(run_task, function, task): i for i, task in enumerate(tasks)}
        for future in as_completed(futures):
            i = futures[future]
            results[i] = future.result()
            print(f"  {describe(tasks[i], results[i])}", flush=True)
    return results


def simulate_point(rpm: float, clearance_mm: float, revolutions: int) -> Run:
    """One point: constant speed for `revolutions` revolutions, the last full one kept (mechanics_demo.run_one)."""
    return run_one(clearance_mm, study_parameters(clearance_mm, LOBES), rpm, revolutions)


def describe_point(task: tuple, run: Run) -> str:
    rpm, clearance_mm, _ = task
    return (f"{rpm:g} rpm, c = {clearance_mm:g} mm: eta_m = {100 * run.summary.mechanical_efficiency:.2f} %, "
            f"{run.steps} steps, {run.wall_time:.2f} s")


# window statistics ------------------------------------------------------------------------------------------
def time_mean(values: np.ndarray, time: np.ndarray) -> float:
    """(1/T) int x dt over the window, trapezoidal over the accepted steps (steps cluster at impacts)."""
    return float(np.trapezoid(values, time) / (time[-1] - time[0]))


def time_rms(values: np.ndarray, time: np.ndarray) -> float:
    """sqrt((1/T) int x^2 dt) over the window."""
    return math.sqrt(time_mean(values ** 2, time))


# tables ------------------------------------------------------------------------------------------------------
POWER_HEADERS = ["<P_in> [W]", "<P_out> [W]", "<P_fric> [W]", "<P_damp> [W]", "eta_m [%]", "energy residual [%]",
                 "max F_n [N]", "max tilt [mrad]", "distinct modes"]


def power_cells(summary: WindowSummary) -> list[str]:
    """The power/efficiency summary of one point, in POWER_HEADERS order (docs/model.md §6.4, §4.6)."""
    return [f"{summary.input_power:.2f}", f"{summary.output_power:.2f}", f"{summary.friction_power:.2f}",
            f"{summary.damping_power:.3f}", f"{100 * summary.mechanical_efficiency:.2f}",
            f"{100 * summary.energy_residual:+.4f}", f"{max(summary.max_normal_force):.1f}",
            f"{1e3 * summary.max_tilt:.3f}", f"{len(summary.distinct_modes)}"]


def powers_table(runs: dict) -> str:
    rows = [[f"{rpm:g}", f"{c:g}", *power_cells(run.summary)] for (rpm, c), run in runs.items()]
    return markdown_table(["speed [rpm]", "c [mm]", *POWER_HEADERS], rows,
                          "Mean powers and efficiency over the last revolution")


KINEMATICS = (  # (symbol, history column, scale, unit, format), docs/model.md §3.4
    ("s_r", "vane_displacement", 1e3, "mm", "{:.4f}"),
    ("v_r", "vane_radial_velocity", 1.0, "m/s", "{:.3f}"),
    ("a_r", "vane_radial_acceleration", 1.0, "m/s^2", "{:.0f}"),
    ("v_theta", "vane_tangential_velocity", 1.0, "m/s", "{:.3f}"),
    ("a_theta", "vane_tangential_acceleration", 1.0, "m/s^2", "{:.0f}"),
    ("tilt", "vane_tilt", 1e3, "mrad", "{:.3f}"),
)
STATISTICS = (("max", lambda x, t: float(np.max(x))), ("min", lambda x, t: float(np.min(x))), ("rms", time_rms))


LEDGER_HEADERS = ["pressure model", "leak law", "c [mm]", "eta_m [%]", "eta_v [%]", "eta_is [%]", "<P_in> [W]",
                  "<P_ind> [W]", "<P_gap> [W]", "<P_fric> [W]", "<P_damp> [W]", "stored [W]", "ledger residual [%]",
                  "max slot F [N]", "max tip F [N]", "modes (regions)", "modes (+ candidate)"]


def percent(value: float) -> str:
    return f"{100 * value:.2f}" if math.isfinite(value) else "-"


def ledger_table(ledger_runs: dict) -> str:
    """Efficiencies, the energy ledger (docs/model.md §6.4), peak slot and tip force and both mode counts (§4.6)."""
    rows = []
    for (model, leak_law, clearance_mm), run in ledger_runs.items():
        s = run.summary
        rows.append([model, leak_law, f"{clearance_mm:g}", percent(s.mechanical_efficiency),
                     percent(s.volumetric_efficiency), percent(s.isentropic_efficiency), f"{s.input_power:.2f}",
                     f"{s.indicated_power:.2f}", f"{s.gap_power:.2f}", f"{s.friction_power:.2f}",
                     f"{s.damping_power:.3f}", f"{s.storage_power:+.3f}", f"{100 * s.ledger_residual:+.4f}",
                     f"{s.max_slot_force:.1f}", f"{s.max_tip_force:.1f}", f"{s.mode_count}",
                     f"{s.mode_count_extended}"])
    return markdown_table(LEDGER_HEADERS, rows, f"Energy ledger, efficiencies, peak forces and contact modes at "
                                                f"{LEDGER_RPM:g} rpm, z = {LOBES}, last revolution")


def clearance_headers(clearances) -> list[str]:
    return [f"c = {c:g} mm" for c in clearances]


def kinematics_table(runs: dict, rpm: float, clearances) -> str:
    rows = []
    for symbol, column, scale, unit, fmt in KINEMATICS:
        for name, statistic in STATISTICS:
            cells = [fmt.format(scale * statistic(runs[rpm, c].window[column], runs[rpm, c].window["time"]))
                     for c in clearances]
            rows.append([f"{name} {symbol} [{unit}]", *cells])
    return markdown_table(["quantity", *clearance_headers(clearances)], rows,
                          f"Vane kinematics over the last revolution, {rpm:g} rpm (rms over time)")


def summed_normal_force(run: Run) -> np.ndarray:
    """sum over every region of F_n at every accepted step of the window [N]."""
    return sum(run.window[f"normal_force_{k}"] for k in range(1, REGION_COUNT + 1))


def contact_force_table(runs: dict, rpm: float, clearances) -> str:
    rows = []
    for c in clearances:
        run = runs[rpm, c]
        rows.append([f"{c:g}", *(f"{f:.1f}" for f in run.summary.max_normal_force),
                     f"{max(run.summary.max_normal_force):.1f}",
                     f"{time_mean(summed_normal_force(run), run.window['time']):.1f}"])
    return markdown_table(["c [mm]", *(f"max F_n {label} [N]" for label in REGION_LABELS), "max F_n any [N]",
                           "mean sum F_n [N]"], rows, f"Contact normal forces, {rpm:g} rpm")


def constraint_moment_table(runs: dict, rpm: float, clearances) -> str:
    rows = []
    for c in clearances:
        run = runs[rpm, c]
        torque, stator, t = run.window["driving_torque"], run.window["stator_contact_moment"], run.window["time"]
        rows.append([f"{c:g}", f"{torque.max():.3f}", f"{run.summary.driving_torque:.3f}", f"{torque.min():.3f}",
                     f"{stator.max():.3f}", f"{time_mean(stator, t):.3f}", f"{stator.min():.3f}",
                     f"{run.summary.stator_torque:.3f}"])
    return markdown_table(["c [mm]", "max T_d [N m]", "mean T_d [N m]", "min T_d [N m]", "max lambda3 [N m]",
                           "mean lambda3 [N m]", "min lambda3 [N m]", "mean lambda3 + M_gas,stator [N m]"], rows,
                          f"Driving torque T_d = -lambda6 and stator contact moment lambda3, {rpm:g} rpm")


def mode_order(mask: int) -> tuple:
    """Table order of modes: by the number of regions in contact, then by mask."""
    return bin(mask).count("1"), mask


def contact_mode_table(runs: dict, rpm: float, clearances) -> str:
    dwell = {c: runs[rpm, c].summary.mode_dwell for c in clearances}
    min_dwell = runs[rpm, clearances[0]].params.mode_dwell_time
    masks = sorted(set().union(*dwell.values()), key=mode_order)
    rows = []
    for mask in masks:
        cells = []
        for c in clearances:
            seconds = dwell[c].get(mask)
            text = "-" if seconds is None else f"{1e3 * seconds:.3f}"
            cells.append(text if seconds is None or seconds >= min_dwell else f"({text})")
        rows.append([f"{mode_label(mask)} ({mask})", *cells])
    rows.append([f"distinct modes (dwell >= {1e6 * min_dwell:g} us)",
                 *(f"{len(runs[rpm, c].summary.distinct_modes)}" for c in clearances)])
    return markdown_table(["mode (mask)", *clearance_headers(clearances)], rows,
                          f"Contact-mode dwell [ms] over the last revolution ({60e3 / rpm:.1f} ms), {rpm:g} rpm; "
                          f"in parentheses: below tau_min, not counted")


def write_powers_csv(runs: dict, path: Path) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["speed [rpm]", "c [mm]", *POWER_HEADERS, "mode labels", "wall time [s]"])
        for (rpm, c), run in runs.items():
            labels = " ".join(mode_label(mask) for mask in run.summary.distinct_modes)
            writer.writerow([f"{rpm:g}", f"{c:g}", *power_cells(run.summary), labels, f"{run.wall_time:.3f}"])


# plots -------------------------------------------------------------------------------------------------------
POWERS = (("input_power", "input power P_in", "o-"), ("output_power", "output power P_out", "s-"),
          ("friction_power", "friction power P_fric", "^-"))


def series(runs: dict, rpm: float, clearances, field: str, scale: float = 1.0) -> np.ndarray:
    return np.array([scale * getattr(runs[rpm, c].summary, field) for c in clearances])


def clearance_axis(ax) -> None:
    ax.set_xlabel("clearance c_R = c_S [mm]")
    ax.grid(True, alpha=0.4)


def plot_powers_per_speed(runs: dict, speeds, clearances, path: Path) -> None:
    fig, axes = plt.subplots(1, len(speeds), figsize=(4.6 * len(speeds), 4.4), sharey=True, squeeze=False)
    for ax, rpm in zip(axes[0], speeds):
        for field, label, style in POWERS:
            ax.plot(clearances, series(runs, rpm, clearances, field), style, label=label)
        ax.set_title(f"{rpm:g} rpm")
        clearance_axis(ax)
    axes[0, 0].set_ylabel("mean power over one revolution [W]")
    axes[0, 0].legend(fontsize=9)
    fig.suptitle(f"Input, output and friction power vs clearance, z = {LOBES}, Level 0.5 pressure table")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_powers_all_speeds(runs: dict, speeds, clearances, path: Path) -> None:
    fig, axes = plt.subplots(1, len(POWERS), figsize=(14, 4.4))
    for ax, (field, label, _) in zip(axes, POWERS):
        for rpm in speeds:
            ax.plot(clearances, series(runs, rpm, clearances, field), "o-", label=f"{rpm:g} rpm")
        ax.set_title(label)
        ax.set_ylabel(f"{label.split()[0]} power [W]")
        clearance_axis(ax)
        ax.legend(fontsize=9)
    fig.suptitle(f"Powers vs clearance, all speeds, z = {LOBES}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_efficiency(runs: dict, speeds, clearances, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(7, 4.6))
    for rpm in speeds:
        ax.plot(clearances, series(runs, rpm, clearances, "mechanical_efficiency", 100.0), "o-", label=f"{rpm:g} rpm")
    ax.set_ylabel("mechanical efficiency eta_m = <P_out>/<P_in> [%]")
    clearance_axis(ax)
    ax.legend()
    ax.set_title(f"Mechanical efficiency vs clearance, z = {LOBES}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# captions ----------------------------------------------------------------------------------------------------
def trend(values) -> str:
    """'rises', 'falls' (strictly) or 'is not monotonic' for a sequence of numbers."""
    steps = np.diff(np.asarray(values, dtype=float))
    return "rises" if np.all(steps > 0) else "falls" if np.all(steps < 0) else "is not monotonic"


def span(values, fmt: str = "{:.1f}") -> str:
    return f"{fmt.format(values[0])} -> {fmt.format(values[-1])}"


def captions(runs: dict, speeds, clearances) -> dict[str, str]:
    """One line per output, with the figures that the data show (trends computed, not assumed)."""
    c_text = f"c = {clearances[0]:g} -> {clearances[-1]:g} mm"
    per_speed = "; ".join(
        f"{rpm:g} rpm: P_in {span(series(runs, rpm, clearances, 'input_power'))} W, "
        f"P_out {span(series(runs, rpm, clearances, 'output_power'))} W, "
        f"P_fric {span(series(runs, rpm, clearances, 'friction_power'))} W" for rpm in speeds)
    eta = {rpm: series(runs, rpm, clearances, "mechanical_efficiency", 100.0) for rpm in speeds}
    p_in_zero = [runs[rpm, clearances[0]].summary.input_power for rpm in speeds]
    modes = {rpm: [len(runs[rpm, c].summary.distinct_modes) for c in clearances] for rpm in speeds}
    rms_a_theta = {rpm: [time_rms(runs[rpm, c].window["vane_tangential_acceleration"], runs[rpm, c].window["time"])
                         for c in clearances] for rpm in speeds}
    tilt = {rpm: series(runs, rpm, clearances, "max_tilt") for rpm in speeds}
    peak = {rpm: [max(runs[rpm, c].summary.max_normal_force) for c in clearances] for rpm in speeds}
    mean_force = {rpm: [time_mean(summed_normal_force(runs[rpm, c]), runs[rpm, c].window["time"])
                        for c in clearances] for rpm in speeds}
    torque = {rpm: series(runs, rpm, clearances, "driving_torque") for rpm in speeds}
    result = {
        "powers_vs_clearance.png":
            f"Mean input, output and friction power over the last revolution vs clearance, one panel per speed "
            f"(cf. thesis Figs 5.48-5.54); {c_text}: {per_speed}.",
        "powers_all_speeds.png":
            f"The same powers with all speeds on one axis per power: at c = {clearances[0]:g} mm the input power "
            f"{trend(p_in_zero)} with speed ({' / '.join(f'{p:.1f}' for p in p_in_zero)} W at "
            f"{' / '.join(f'{rpm:g}' for rpm in speeds)} rpm).",
        "efficiency_vs_clearance.png":
            "Mechanical efficiency vs clearance, all speeds: " + "; ".join(
                f"at {rpm:g} rpm it {trend(eta[rpm])} ({span(eta[rpm], '{:.2f}')} %)" for rpm in speeds) + ".",
        "powers.md": "Every point's mean powers, efficiency, energy-balance residual (docs/model.md §6.4: the work "
                     "integrals close to this fraction of W_in), peak contact force and tilt, distinct modes.",
        "powers.csv": "The power table as CSV, with each point's distinct mode labels and wall time.",
        "kinematics.md":
            "Vane kinematics of docs/model.md §3.4 per clearance and speed (cf. thesis table 5.4); from c = "
            f"{clearances[0]:g} to {clearances[-1]:g} mm the time-rms of a_theta " + "; ".join(
                f"{trend(rms_a_theta[rpm])} at {rpm:g} rpm ({span(rms_a_theta[rpm], '{:.0f}')} m/s^2)"
                for rpm in speeds) + "; the peak tilt " + ", ".join(
                f"{trend(tilt[rpm])} at {rpm:g} rpm" for rpm in speeds) + ".",
        "contact_forces.md":
            "Peak normal force per contact region and the time-mean of the summed normal force (cf. thesis table "
            "5.5): peak over all regions " + "; ".join(
                f"{span(peak[rpm])} N at {rpm:g} rpm ({trend(peak[rpm])})" for rpm in speeds)
            + "; the mean summed force " + ", ".join(f"{trend(mean_force[rpm])} at {rpm:g} rpm" for rpm in speeds)
            + f" ({c_text}).",
        "constraint_moments.md":
            "Driving torque T_d = -lambda6 and stator contact moment lambda3 (cf. thesis table 5.6): the mean "
            "driving torque " + ", ".join(f"{trend(torque[rpm])} at {rpm:g} rpm" for rpm in speeds)
            + " with clearance; the mean stator reaction lambda3 + M_gas,stator balances it to within "
            f"{100 * max(run.summary.torque_balance_error for run in runs.values()):.1f} % over all points, "
            f"{100 * max(run.summary.torque_balance_error_with_gaps for run in runs.values()):.1f} % with the "
            "pressure moment on the tip, valley and slot-mouth gaps that no body carries (docs/model.md §11 T11).",
        "contact_modes.md": "Dwell of each contact mode per clearance, one table per speed (cf. thesis tables "
                            "5.7-5.9); distinct modes per clearance: " + "; ".join(
                                f"{rpm:g} rpm {', '.join(map(str, modes[rpm]))}" for rpm in speeds) + ".",
    }
    for rpm in speeds:
        result[region_figure(rpm)] = (
            f"Regions in contact (penetration > 0) over the last revolution at {rpm:g} rpm, one panel per clearance "
            f"(cf. thesis Figs 5.21-5.32): c1/c2 slot mouth, c3/c4 vane bottom corners on the walls, c5/c6 tip on "
            f"its leading/trailing "
            f"quarter; distinct modes {', '.join(map(str, modes[rpm]))} for c = "
            f"{', '.join(f'{c:g}' for c in clearances)} mm.")
    return result


def ledger_caption(ledger_runs: dict) -> str:
    """What the ledger table shows, from its numbers."""
    residual = max(abs(run.summary.ledger_residual) for run in ledger_runs.values())
    gap_share = [run.summary.gap_power / run.summary.input_power for run in ledger_runs.values()]
    return (f"Shaft work split per revolution into indicated work on all chambers, work on the open gaps' sweep, "
            f"friction, contact damping and stored energy (docs/model.md §6.4) for both pressure models and both "
            f"leak laws: the ledger closes to {100 * residual:.3f} % or better at every point; the gap work is "
            f"{100 * min(gap_share):.1f}-{100 * max(gap_share):.1f} % of the shaft power. Peak force per region "
            f"group (rotor c1-c4 and c7/c8, tip c5/c6) and the distinct modes counted by regions and by regions plus the "
            f"slot-mouth candidate (docs/model.md §4.6).")


def region_figure(rpm: float) -> str:
    return f"contact_regions_{rpm:g}rpm.png"


# command line ------------------------------------------------------------------------------------------------
def worker_count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'--workers' = {text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"'--workers' = {value} is invalid: allowed a whole number >= 1")
    return value


def study_arguments(description: str, argv=None) -> argparse.Namespace:
    """The options every study takes: --quick, --out, --workers."""
    parser = argparse.ArgumentParser(description=description,
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="fewer points and revolutions (a smoke run for the tests)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="studies folder; this study writes a sub-folder and report.md is rebuilt here")
    parser.add_argument("--workers", type=worker_count, default=os.cpu_count() or 1,
                        help="worker processes for the simulation points")
    return parser.parse_args(argv)


def write_tables(folder: Path, tables: dict[str, list[str]]) -> None:
    """Write each {file: [tables]} and print it."""
    for name, parts in tables.items():
        text = "\n".join(parts)
        (folder / name).write_text(text)
        print(f"\n{text}")


def main(argv=None) -> int:
    args = study_arguments("Clearance study: powers, efficiency, kinematics, contact forces, constraint moments "
                           "and contact modes vs clearance c_R = c_S at 1000/1500/2000 rpm, z = 3.", argv)
    clearances = QUICK_CLEARANCES_MM if args.quick else CLEARANCES_MM
    revolutions = QUICK_REVOLUTIONS if args.quick else REVOLUTIONS
    speeds = SPEEDS_RPM
    folder = args.out / "clearance"
    folder.mkdir(parents=True, exist_ok=True)
    tasks = [(rpm, c, revolutions) for rpm in speeds for c in clearances]
    workers = min(args.workers, len(tasks))
    print(f"clearance study: {len(tasks)} points (z = {LOBES}, {revolutions} revolutions each, the last reported) "
          f"on {workers} worker(s)")
    start = time.perf_counter()
    try:
        results = run_points(simulate_point, tasks, workers, describe_point)
    except PointFailed as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    runs = {(rpm, c): run for (rpm, c, _), run in zip(tasks, results)}
    ledger_tasks = [(model, law, c, revolutions) for model, law in LEDGER_CASES for c in clearances]
    print(f"energy ledger: {len(ledger_tasks)} points at {LEDGER_RPM:g} rpm")
    try:
        ledger_results = run_points(simulate_ledger_point, ledger_tasks, workers, describe_ledger_point)
    except PointFailed as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    ledger_runs = {(model, law, c): run for (model, law, c, _), run in zip(ledger_tasks, ledger_results)}
    simulated = time.perf_counter() - start

    write_tables(folder, {
        "powers.md": [powers_table(runs)],
        "ledger.md": [ledger_table(ledger_runs)],
        "kinematics.md": [kinematics_table(runs, rpm, clearances) for rpm in speeds],
        "contact_forces.md": [contact_force_table(runs, rpm, clearances) for rpm in speeds],
        "constraint_moments.md": [constraint_moment_table(runs, rpm, clearances) for rpm in speeds],
        "contact_modes.md": [contact_mode_table(runs, rpm, clearances) for rpm in speeds],
    })
    write_powers_csv(runs, folder / "powers.csv")
    plot_powers_per_speed(runs, speeds, clearances, folder / "powers_vs_clearance.png")
    plot_powers_all_speeds(runs, speeds, clearances, folder / "powers_all_speeds.png")
    plot_efficiency(runs, speeds, clearances, folder / "efficiency_vs_clearance.png")
    for rpm in speeds:
        plot_contact_modes([runs[rpm, c] for c in clearances], rpm, folder / region_figure(rpm))
    total = time.perf_counter() - start

    text = captions(runs, speeds, clearances)
    text["ledger.md"] = ledger_caption(ledger_runs)
    order = ["powers_vs_clearance.png", "powers_all_speeds.png", "efficiency_vs_clearance.png",
             "powers.md", "ledger.md", "powers.csv", *(region_figure(rpm) for rpm in speeds), "contact_modes.md",
             "kinematics.md", "contact_forces.md", "constraint_moments.md"]
    settings = (f"z = {LOBES}, harmonic law, Level 0.5 pressure table, Dormand-Prince 5(4); c_R = c_S in "
                f"{{{', '.join(f'{c:g}' for c in clearances)}}} mm at {', '.join(f'{s:g}' for s in speeds)} rpm; "
                f"{revolutions} revolutions from theta0 = 0.02 rad, the last full one reported; {workers} worker(s)"
                + (" (--quick)." if args.quick else "."))
    write_manifest(folder, "clearance", "Clearance study", "python examples/study_clearance.py"
                   + (" --quick" if args.quick else ""), settings,
                   [{"file": name, "caption": text[name]} for name in order],
                   {"simulation (all points)": simulated, "total": total,
                    "slowest point": max(run.wall_time for run in results)})
    report = write_report(args.out)
    print(f"\nwrote {len(order)} figures and tables to {folder}/ in {total:.1f} s; report: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
