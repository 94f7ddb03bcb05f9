"""Mechanics demo: one sliding vane, z-lobe stator, constant speed, several clearances (docs/model.md §3.4, §4.6, §6.4, §10).

For each clearance c (slot clearance c_R = stator clearance c_S = c, as in the thesis) the script runs the
compressor at constant speed for a few revolutions, summarises the last full revolution and compares the runs:

* a table (printed and written to summary.csv): mean input, output, friction and damping power, mechanical
  efficiency, the energy and torque-balance checks, the peak normal force per contact region c1..c6 and the
  distinct contact modes (dwell-filtered, docs/model.md §4.6);
* plots over the last full revolution against the rotor angle (0-360 deg), one curve per clearance:
  kinematics.png, contact_forces.png, torques.png, contact_modes.png (cf. thesis Figs 5.8-5.32).

Usage (from the project folder, after `pip install -e .`):

    python examples/mechanics_demo.py
    python examples/mechanics_demo.py --clearances 0,0.02,0.05,0.1 --rpm 2000 --out out/demo2000
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")                      # files only, no window
import matplotlib.pyplot as plt            # noqa: E402
import numpy as np                         # noqa: E402

from rotary_vane.examples.cli_types import number_parser, whole_number_parser  # noqa: E402
from rotary_vane.mechanics import CompressorParameters, IntegrationError, Simulation, constant_speed  # noqa: E402
from rotary_vane.mechanics.geometry.displacement import DISPLACEMENT_LAWS, displacement  # noqa: E402
from rotary_vane.mechanics.contact.modes import REGION_LABELS, mode_label  # noqa: E402
from rotary_vane.mechanics.parameters import INTEGRATORS  # noqa: E402
from rotary_vane.mechanics.performance import WindowSummary, revolutions  # noqa: E402
from rotary_vane.mechanics.contact.regions import REGION_COUNT  # noqa: E402

REGIONS = range(1, REGION_COUNT + 1)       # contact regions c1..c8 (docs/model.md §1.3)


# command line --------------------------------------------------------------------------------------------
def clearance_list(text: str) -> list[float]:
    """'0,0.05' -> [0.0, 0.05] (mm); each value finite and >= 0."""
    try:
        values = [float(item) for item in text.split(",") if item.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of numbers in mm") from None
    if not values:
        raise argparse.ArgumentTypeError("give at least one clearance in mm, e.g. 0,0.05")
    for value in values:
        if not math.isfinite(value) or value < 0.0:
            raise argparse.ArgumentTypeError(f"clearance {value!r} mm is invalid: allowed a finite value >= 0 mm")
    return values


def parse_arguments(argv=None) -> tuple[argparse.ArgumentParser, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        description="Run the single-vane rotary compressor at constant speed for one or more clearances, "
                    "print a per-clearance table for the last full revolution and write plots and a CSV.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--clearances", type=clearance_list, default="0,0.05", metavar="MM[,MM...]",
                        help="comma-separated clearances in mm; each sets slot clearance c_R (total, diametral) "
                             "= stator clearance c_S (radial)")
    parser.add_argument("--rpm", type=number_parser("rpm"), default=1500.0, help="constant rotor speed [rpm]")
    parser.add_argument("--lobes", type=int, default=3, help="number of stator lobes z")
    parser.add_argument("--revolutions", type=whole_number_parser(2, "one full revolution to report needs 2, the run starts at 0.02 rad"), default=4,
                        help="revolutions to simulate; the first ones settle the start transient and only the "
                             "last full revolution is reported and plotted")
    parser.add_argument("--integrator", choices=INTEGRATORS, default="dopri5",
                        help="time integrator: adaptive Dormand-Prince 5(4) or the thesis's ABM4 predictor-corrector")
    parser.add_argument("--out", type=Path, default=Path("out/mechanics_demo"),
                        help="folder for the PNG plots and summary.csv")
    return parser, parser.parse_args(argv)


# simulation ----------------------------------------------------------------------------------------------
@dataclass
class Run:
    """One clearance: its parameters, the last full revolution's summary and its history rows."""
    clearance_mm: float
    params: CompressorParameters
    summary: WindowSummary
    window: dict[str, np.ndarray]          # history columns over the last full revolution
    wall_time: float
    steps: int


def make_parameters(clearance_mm: float, lobes: int, integrator: str) -> CompressorParameters:
    c = clearance_mm * 1e-3
    return CompressorParameters(slot_clearance=c, stator_clearance=c, lobes=lobes, integrator=integrator)


def run_one(clearance_mm: float, params: CompressorParameters, rpm: float, revolutions_to_run: int) -> Run:
    """Simulate `revolutions_to_run` revolutions at constant speed and keep the last full one."""
    start = time.perf_counter()
    simulation = Simulation(params, constant_speed(rpm))
    simulation.advance(revolutions_to_run * 60.0 / rpm)
    wall_time = time.perf_counter() - start
    summary = revolutions(simulation)[-1]
    history = simulation.history
    t = history["time"]
    rows = (t >= summary.start_time) & (t <= summary.end_time)
    window = {name: history[name][rows] for name in history.names}
    return Run(clearance_mm, params, summary, window, wall_time, len(history))


def angle_in_revolution(run: Run) -> np.ndarray:
    """Rotor angle [deg] from the start of the reported revolution (0..360)."""
    angle = run.window["rotor_angle"]
    return np.degrees(angle - angle[0])


# table -------------------------------------------------------------------------------------------------
COLUMNS = (  # (header, width, format)
    ("c [mm]", 6, "{:.3f}"), ("<P_in> [W]", 10, "{:.2f}"), ("<P_out> [W]", 11, "{:.2f}"),
    ("<P_fric> [W]", 12, "{:.2f}"), ("<P_damp> [W]", 12, "{:.3f}"), ("eta_m [%]", 9, "{:.2f}"),
    ("E-resid [%]", 11, "{:+.4f}"), ("T-bal [%]", 9, "{:.2f}"), ("T-bal+gaps [%]", 14, "{:.2f}"),
    *((f"Fmax {label} [N]", 12, "{:.1f}") for label in REGION_LABELS),
    ("modes", 5, "{:d}"),
)


def table_row(run: Run) -> tuple[list, str]:
    """Numeric cells of one run (in COLUMNS order) and its mode labels."""
    s = run.summary
    cells = [run.clearance_mm, s.input_power, s.output_power, s.friction_power, s.damping_power,
             100.0 * s.mechanical_efficiency, 100.0 * s.energy_residual, 100.0 * s.torque_balance_error,
             100.0 * s.torque_balance_error_with_gaps,
             *s.max_normal_force, len(s.distinct_modes)]
    labels = ", ".join(mode_label(int(mask)) for mask in s.distinct_modes)
    return cells, labels


def print_table(runs: list[Run]) -> None:
    header = "  ".join(f"{name:>{width}}" for name, width, _ in COLUMNS) + "  mode labels"
    print(header)
    print("-" * len(header))
    for run in runs:
        cells, labels = table_row(run)
        text = "  ".join(f"{fmt.format(value):>{width}}" for (_, width, fmt), value in zip(COLUMNS, cells))
        print(f"{text}  {labels}")
    print("E-resid: energy balance residual / W_in (docs/model.md §6.4); "
          "T-bal: |<T_d> - <lambda3 + M_gas,stator>| / <T_d> (docs/model.md §11 T11); T-bal+gaps adds the pressure "
          "moment on the tip, valley and slot-mouth gaps that no body carries")


GAS_COLUMNS = (  # (header, width, format)
    ("c [mm]", 6, "{:.3f}"), ("model", 15, "{}"), ("<P_in> [W]", 10, "{:.2f}"), ("<P_out> [W]", 11, "{:.2f}"),
    ("eta_m [%]", 9, "{:.2f}"), ("P_ind [W]", 9, "{:.2f}"), ("m_dot [g/s]", 11, "{:.4f}"),
    ("T_dis [K]", 9, "{:.2f}"), ("eta_v [%]", 9, "{:.2f}"), ("eta_is [%]", 10, "{:.2f}"),
    ("mass-resid", 10, "{:+.1e}"), ("energy-resid", 12, "{:+.1e}"),
)


def gas_row(run: Run) -> list:
    """Cells of one run in GAS_COLUMNS order; the chamber figures only for the real-gas model."""
    s = run.summary
    gas = [math.nan] * 6 if run.params.pressure_model != "real_gas" else [
        s.indicated_power, 1e3 * s.discharge_mass_flow, s.discharge_temperature,
        100.0 * s.volumetric_efficiency, 100.0 * s.isentropic_efficiency, s.gas_mass_residual]
    return [run.clearance_mm, run.params.pressure_model, s.input_power, s.output_power,
            100.0 * s.mechanical_efficiency, *gas, s.gas_energy_residual]


def print_gas_comparison(pairs: list[tuple[Run, Run]]) -> None:
    """Level 0.5 (ideal-gas table) next to Level 1 (real-gas chambers) per clearance (issue 3)."""
    header = "  ".join(f"{name:>{width}}" for name, width, _ in GAS_COLUMNS)
    print(header)
    print("-" * len(header))
    for table_run, gas_run in pairs:
        for run in (table_run, gas_run):
            cells = gas_row(run)
            print("  ".join("n/a".rjust(width) if isinstance(value, float) and math.isnan(value)
                            else f"{fmt.format(value):>{width}}" for (_, width, fmt), value in zip(GAS_COLUMNS, cells)))
    print("P_ind: -sum p dV/dt of the two chambers; m_dot: discharge mass flow; T_dis: mixed discharge temperature; "
          "eta_v: delivered mass / (rho_s z L A_lobe); eta_is: m_dot (h_2s - h_1) / <P_in>; residuals: chamber "
          "mass / delivered mass and chamber energy / compression work over the revolution (docs/model.md §11 T19)")


def plot_pv_diagram(runs: list[Run], path: Path) -> None:
    """p-V diagram of the real-gas chambers over the first lobe of the reported revolution: the trailing chamber
    fills (suction), the leading chamber compresses and discharges."""
    fig, ax = plt.subplots(figsize=(8, 5.5))
    for run, color in zip(runs, plt.cm.viridis(np.linspace(0.0, 0.85, len(runs)))):
        lobe = 360.0 / run.params.lobes
        first = angle_in_revolution(run) <= lobe
        for chamber, style in (("leading", "-"), ("trailing", "--")):
            volume = 1e6 * run.window[f"{chamber}_volume"][first]
            pressure = 1e-5 * run.window[f"{chamber}_pressure"][first]
            # a valley crossing hands the chamber over (leading -> trailing, idle -> leading): no line across it
            jumps = np.flatnonzero(np.abs(np.diff(volume)) > 0.5 * np.max(volume)) + 1
            ax.plot(np.insert(volume, jumps, np.nan), np.insert(pressure, jumps, np.nan), style, color=color,
                    lw=1.2, label=f"c = {run.clearance_mm:g} mm, {chamber} chamber")
    p = runs[0].params
    for pressure, name in ((p.suction_pressure, "suction"), (p.discharge_pressure, "discharge")):
        ax.axhline(1e-5 * pressure, color="grey", lw=0.8, ls=":")
        ax.annotate(f"{name} {1e-5 * pressure:.3g} bar", (0.0, 1e-5 * pressure), textcoords="offset points",
                    xytext=(4, 3), fontsize=8, color="grey")
    ax.set_xlabel("chamber volume [cm³]")
    ax.set_ylabel("chamber pressure [bar]")
    ax.set_title(f"Real-gas chambers ({p.fluid}) over one lobe, z = {p.lobes}: p-V diagram")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_csv(runs: list[Run], path: Path) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow([name for name, _, _ in COLUMNS] + ["mode labels", "wall time [s]"])
        for run in runs:
            cells, labels = table_row(run)
            writer.writerow([f"{value:.6g}" for value in cells] + [labels, f"{run.wall_time:.3f}"])


# plots -------------------------------------------------------------------------------------------------
def nominal_kinematics(params: CompressorParameters, rpm: float, angle_deg: np.ndarray):
    """No-clearance nominal s [m], s' omega [m/s], s'' omega^2 [m/s^2] at constant speed (docs/model.md §3.4).

    The reported revolution starts at a whole multiple of 2 pi, so the angle within it is the rotor angle."""
    omega = rpm * 2.0 * math.pi / 60.0
    law = (DISPLACEMENT_LAWS.code(params.displacement_law, "displacement_law"), params.stroke, float(params.lobes),
           params.bottom_dwell, params.top_dwell)
    values = np.array([displacement(theta, *law)[:3] for theta in np.radians(angle_deg)])
    return values[:, 0], values[:, 1] * omega, values[:, 2] * omega ** 2


def finish_axes(axes, xlabel="rotor angle in the revolution [deg]") -> None:
    for ax in np.ravel(axes):
        ax.grid(True, alpha=0.4)
        ax.set_xlim(0.0, 360.0)
        ax.set_xticks(range(0, 361, 60))
    bottom_row = axes[-1] if np.ndim(axes) == 2 else [np.ravel(axes)[-1]]
    for ax in bottom_row:
        ax.set_xlabel(xlabel)


def plot_kinematics(runs: list[Run], rpm: float, path: Path) -> None:
    panels = (  # (history column, scale, y label, nominal index or None)
        ("vane_displacement", 1e3, "s_r [mm]", 0),
        ("vane_radial_velocity", 1.0, "v_r [m/s]", 1),
        ("vane_radial_acceleration", 1.0, "a_r [m/s$^2$]", 2),
        ("vane_tangential_velocity", 1.0, "v_θ [m/s]", None),
        ("vane_tangential_acceleration", 1.0, "a_θ [m/s$^2$]", None),
        ("vane_tilt", 1e3, "tilt φ3−θ [mrad]", None),
    )
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 15), sharex=True)
    grid = np.linspace(0.0, 360.0, 1441)
    nominal = nominal_kinematics(runs[0].params, rpm, grid)
    for ax, (column, scale, ylabel, nominal_index) in zip(axes, panels):
        for run in runs:
            ax.plot(angle_in_revolution(run), scale * run.window[column], lw=1.0, label=f"c = {run.clearance_mm:g} mm")
        if nominal_index is not None:
            ax.plot(grid, scale * nominal[nominal_index], "k--", lw=0.7, label="nominal (no clearance)")
        ax.set_ylabel(ylabel)
        ax.legend(loc="upper right", fontsize=8)
    axes[0].set_title(f"Vane kinematics over the last full revolution, z = {runs[0].params.lobes}, {rpm:g} rpm")
    finish_axes(axes)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_contact_forces(runs: list[Run], rpm: float, path: Path) -> None:
    fig, axes = plt.subplots(REGION_COUNT // 2, 2, figsize=(12, 3.3 * REGION_COUNT // 2), sharex=True)
    for k, ax in zip(REGIONS, axes.T.ravel()):          # left column c1, c3, ... (leading), right c2, c4, ...
        for run in runs:
            ax.plot(angle_in_revolution(run), run.window[f"normal_force_{k}"], lw=1.0,
                    label=f"c = {run.clearance_mm:g} mm")
        ax.set_title(f"region c{k}", fontsize=10)
        ax.set_ylabel("normal force F_n [N]")
        ax.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"Contact normal forces over the last full revolution, {rpm:g} rpm "
                 f"(c1/c2 slot mouth, c3/c4 vane bottom corners on the walls, c5/c6 tip, c7/c8 slot bottom; left leading, right trailing)")
    finish_axes(axes)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_torques(runs: list[Run], rpm: float, path: Path) -> None:
    fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for run in runs:
        angle = angle_in_revolution(run)
        label = f"c = {run.clearance_mm:g} mm"
        stator = run.window["stator_contact_moment"] + run.window["stator_gas_moment"]
        axes[0].plot(angle, stator, lw=1.0, label=f"{label}, mean {run.summary.stator_torque:.3f} N m")
        axes[1].plot(angle, run.window["driving_torque"], lw=1.0,
                     label=f"{label}, mean {run.summary.driving_torque:.3f} N m")
    axes[0].set_ylabel("λ3 [N m]")
    axes[0].set_title("stator reaction moment lambda3 (contact + gas)")
    axes[1].set_ylabel("T_d [N m]")
    axes[1].set_title("driving torque on the rotor T_d = −λ6")
    for ax in axes:
        ax.legend(loc="upper right", fontsize=8)
    fig.suptitle(f"Torques over the last full revolution, {rpm:g} rpm")
    finish_axes(axes)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def contact_intervals(angle: np.ndarray, active: np.ndarray) -> list[tuple[float, float]]:
    """(start, width) of the angle intervals in contact; a step counts as its end state (as the mode dwell)."""
    step_active = np.concatenate(([0], active[1:].astype(int), [0]))   # step i runs from row i to row i + 1
    edges = np.diff(step_active)
    starts = np.flatnonzero(edges == 1)                 # first step in contact: starts at row `start`
    ends = np.flatnonzero(edges == -1)                  # first step out of contact: the contact ended at row `end`
    return [(angle[a], angle[b] - angle[a]) for a, b in zip(starts, ends)]


def plot_contact_modes(runs: list[Run], rpm: float, path: Path) -> None:
    fig, axes = plt.subplots(len(runs), 1, figsize=(10, 1.0 + 2.2 * len(runs)), sharex=True, squeeze=False)
    for ax, run in zip(axes[:, 0], runs):
        angle = angle_in_revolution(run)
        for row, k in enumerate(REGIONS):
            bars = contact_intervals(angle, run.window[f"penetration_{k}"] > 0.0)
            ax.broken_barh(bars, (row - 0.4, 0.8), color=f"C{row}")
        ax.set_yticks(range(REGION_COUNT), REGION_LABELS)
        ax.set_ylim(REGION_COUNT - 0.4, -0.6)
        ax.set_ylabel("region")
        ax.set_title(f"c = {run.clearance_mm:g} mm: {len(run.summary.distinct_modes)} distinct modes "
                     f"(dwell ≥ {run.params.mode_dwell_time * 1e6:g} µs)", fontsize=10)
    fig.suptitle(f"Regions in contact (penetration > 0) over the last full revolution, {rpm:g} rpm")
    finish_axes(axes)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# main ---------------------------------------------------------------------------------------------------
def main(argv=None) -> int:
    parser, args = parse_arguments(argv)
    params = []
    for clearance in args.clearances:           # validate every run's parameters before running any of them
        try:
            params.append(make_parameters(clearance, args.lobes, args.integrator))
        except ValueError as error:
            parser.error(f"clearance {clearance:g} mm: {error}")    # prints usage and the message, exit code 2
    args.out.mkdir(parents=True, exist_ok=True)

    print(f"z = {args.lobes}, {args.rpm:g} rpm, {args.revolutions} revolutions "
          f"({args.revolutions * 60.0 / args.rpm:.4f} s), integrator {args.integrator}; "
          f"reporting the last full revolution")
    runs = []
    for clearance, p in zip(args.clearances, params):
        try:
            run = run_one(clearance, p, args.rpm, args.revolutions)
        except ValueError as error:
            parser.error(f"clearance {clearance:g} mm: {error}")
        except IntegrationError as error:
            print(f"error: c = {clearance:g} mm: {error.reason} at t = {error.time:.6g} s", file=sys.stderr)
            return 1
        print(f"  c = {clearance:g} mm: {run.steps} accepted steps, wall time {run.wall_time:.2f} s")
        runs.append(run)
    print("  (the first run's wall time includes loading or compiling the numba kernels)\n")

    print_table(runs)
    write_csv(runs, args.out / "summary.csv")

    print("\nLevel 0.5 (ideal-gas pressure table) and Level 1 (real-gas chambers coupled to the vane), "
          f"{params[0].fluid}:")
    pairs = []
    for clearance, table_run in zip(args.clearances, runs):
        gas_params = table_run.params.replace(pressure_model="real_gas")
        try:
            gas_run = run_one(clearance, gas_params, args.rpm, args.revolutions)
        except IntegrationError as error:
            print(f"error: c = {clearance:g} mm, real gas: {error.reason} at t = {error.time:.6g} s", file=sys.stderr)
            return 1
        pairs.append((table_run, gas_run))
    print_gas_comparison(pairs)
    plot_pv_diagram([gas_run for _, gas_run in pairs], args.out / "pv_diagram.png")
    plot_kinematics(runs, args.rpm, args.out / "kinematics.png")
    plot_contact_forces(runs, args.rpm, args.out / "contact_forces.png")
    plot_torques(runs, args.rpm, args.out / "torques.png")
    plot_contact_modes(runs, args.rpm, args.out / "contact_modes.png")
    print(f"\nwrote {', '.join(sorted(f.name for f in args.out.iterdir()))} to {args.out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
