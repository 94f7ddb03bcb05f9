"""Lobe study (thesis ch. 5, Figs 5.56-5.67; docs/model.md §2.5, §3.4, §6.4): z = 3, 5, 7, 9 stator lobes at c_R = c_S =
0.05 mm and 1500 rpm, Level 0.5 pressure table, default geometry (stroke 5 mm, harmonic law).

Per z, two runs of the library's `Simulation` from the nominal pose (docs/model.md §3.3), both settling 3 revolutions
(`--quick`: 2): one keeps every accepted step and gives the power/efficiency summary of the last full revolution
(as the clearance study); the other advances to equally spaced times over the next revolution and records the vane
pose (x_G, y_G, phi3) there, where the integrator lands exactly (examples/animate.py `simulate_frames`).

From the poses: the vane centre of mass G in the fixed frame and in the rotor frame as its offset from the nominal
position (docs/model.md §3.3: untilted, centred in the slot, tip centre at radius R0 + s(theta) + c_S, i.e. on the stator),
radial (along e_r(theta)) and tangential (along e_theta(theta)); the tip centre T = G + xi_T e_xi and the tip
semicircle against the stator contour S(u) (docs/model.md §2.5), enlarged at a valley.

Written to `<out>/lobes/` (and printed): lobes.md (per z: stator regularity margin min(1 + d kappa_C), the powers,
efficiency and modes of the clearance study's table, the largest offsets), vane_centre_z<z>.png,
tip_stator_z<z>.png, powers_vs_lobes.png, trajectory_z<z>.csv (the sampled poses and offsets), manifest.json;
then `<out>/report.md` is rebuilt (examples/study_report.py).

    python examples/study_lobes.py                  # z = 3, 5, 7, 9 into out/studies/lobes/
    python examples/study_lobes.py --quick          # z = 3, 5, 9, fewer samples and revolutions
"""
from __future__ import annotations

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

from rotary_vane.mechanics import CompressorParameters  # noqa: E402
from rotary_vane.mechanics.geometry.stator import closest_pitch_frame, stator_regularity  # noqa: E402
from rotary_vane.mechanics.loop.machine import machine_from_parameters  # noqa: E402
from rotary_vane.mechanics.performance import WindowSummary  # noqa: E402
from rotary_vane.examples.animate import Frames, reference_centre, simulate_frames, stator_curve  # noqa: E402
from rotary_vane.examples.mechanics_demo import run_one  # noqa: E402
from rotary_vane.examples.study_clearance import (POWER_HEADERS, QUICK_REVOLUTIONS, REVOLUTIONS, PointFailed, power_cells,  # noqa: E402
                             run_points, span, study_arguments, study_parameters, trend, write_tables)
from rotary_vane.examples.study_report import markdown_table, write_manifest, write_report  # noqa: E402

LOBE_COUNTS = (3, 5, 7, 9)
QUICK_LOBE_COUNTS = (3, 5, 9)
CLEARANCE_MM = 0.05
RPM = 1500.0
SAMPLES = 1440                             # poses over the reported revolution (0.25 deg apart)
QUICK_SAMPLES = 360
MM, UM = 1e3, 1e6
ZOOM_HALF_WIDTH = 1.0e-3                   # m, tangential half-width of the enlargement at a valley
ZOOM_CIRCLES = 11                          # tip semicircles drawn in the enlargement


@dataclass
class LobeRun:
    lobes: int
    params: CompressorParameters
    regularity: float             # min over a lobe of 1 + d kappa_C (docs/model.md §2.5), > 0 for a regular stator
    summary: WindowSummary        # the last full revolution of the run that keeps its history
    frames: Frames                # sampled poses and output rows over the following revolution
    wall_time: float


def simulate_lobes(lobes: int, revolutions: int, samples: int) -> LobeRun:
    """The summary run (mechanics_demo.run_one) and the sampled-pose run for z = `lobes`."""
    start = time.perf_counter()
    params = study_parameters(CLEARANCE_MM, lobes)
    summary = run_one(CLEARANCE_MM, params, RPM, revolutions).summary
    frames = simulate_frames(params, RPM, samples, revolutions=1.0, settle_revolutions=revolutions - 1)
    return LobeRun(lobes, params, float(stator_regularity(params)[0]), summary, frames,
                   time.perf_counter() - start)


def describe_lobes(task: tuple, run: LobeRun) -> str:
    return (f"z = {run.lobes}: eta_m = {100 * run.summary.mechanical_efficiency:.2f} %, "
            f"min(1 + d kappa_C) = {run.regularity:.3f}, {run.wall_time:.2f} s")


# trajectories -------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Trajectory:
    """Sampled vane motion over one revolution (SI units)."""
    angle: np.ndarray             # rotor angle from the start of the revolution [rad]
    centre: np.ndarray            # (n, 2) G in the fixed frame [m]
    radial_offset: np.ndarray     # (G - G_nominal).e_r(theta) [m]
    tangential_offset: np.ndarray  # (G - G_nominal).e_theta(theta) = G.e_theta(theta) [m]
    tip_centre: np.ndarray        # (n, 2) T = G + xi_T e_xi(phi3) [m]
    tip_reach: np.ndarray         # (n, 2) point of the tip circle nearest the stator, T + rho n(u*) [m]
    vane_angle: np.ndarray        # phi3 [rad]
    tip_penetration: np.ndarray   # delta_S of the tip on the stator (c5 or c6), > 0 in contact [m]
    tip_region: np.ndarray        # 5 (leading quarter) or 6 (trailing quarter)
    slot_penetration: np.ndarray  # max of delta_1..delta_4 (slot regions) [m]


def law_of(m: np.record) -> tuple:
    """The pitch-curve arguments (law, h, z, beta0, beta1, R0) of mechanics.geometry.stator."""
    return m.law, m.stroke, m.lobes, m.bottom_dwell, m.top_dwell, m.base_radius


def trajectory(m: np.record, frames: Frames) -> Trajectory:
    """Rotor-frame offsets of G from the nominal pose of docs/model.md §3.3: G_nominal = (R0 + s(theta) + c_S - xi_T) e_r;
    the tip circle's point nearest the stator, T + rho n(u*), with u* the closest pitch-curve point (docs/model.md §2.6)."""
    theta = frames.column("rotor_angle")
    centre = frames.pose[:, :2]
    phi = frames.pose[:, 2]
    e_r = np.column_stack([np.cos(theta), np.sin(theta)])
    e_t = np.column_stack([-e_r[:, 1], e_r[:, 0]])
    nominal = np.array([reference_centre(m, t) for t in theta]) + m.stator_clearance * e_r
    offset = centre - nominal
    tip = centre + m.tip_centre * np.column_stack([np.cos(phi), np.sin(phi)])
    normals = np.array([closest_pitch_frame(x, y, math.atan2(y, x), *law_of(m))[3:5] for x, y in tip])
    leading, trailing = frames.column("penetration_5"), frames.column("penetration_6")
    slot = np.column_stack([frames.column(f"penetration_{k}") for k in range(1, 5)])
    revolution_start = 2.0 * math.pi * math.floor(theta[0] / (2.0 * math.pi))
    return Trajectory(angle=theta - revolution_start, centre=centre,
                      radial_offset=np.sum(offset * e_r, axis=1), tangential_offset=np.sum(offset * e_t, axis=1),
                      tip_centre=tip, tip_reach=tip + m.tip_radius * normals, vane_angle=phi,
                      tip_penetration=np.where(np.isnan(leading), trailing, leading),
                      tip_region=np.where(np.isnan(leading), 6, 5), slot_penetration=np.nanmax(slot, axis=1))


def write_trajectory_csv(path: Path, frames: Frames, path_data: Trajectory) -> None:
    columns = {
        "time [s]": frames.time, "rotor angle in revolution [deg]": np.degrees(path_data.angle),
        "x_G [mm]": MM * path_data.centre[:, 0], "y_G [mm]": MM * path_data.centre[:, 1],
        "phi3 [rad]": path_data.vane_angle,
        "radial offset of G [um]": UM * path_data.radial_offset,
        "tangential offset of G [um]": UM * path_data.tangential_offset,
        "x_T [mm]": MM * path_data.tip_centre[:, 0], "y_T [mm]": MM * path_data.tip_centre[:, 1],
        "tip penetration [um]": UM * path_data.tip_penetration, "tip region": path_data.tip_region,
        "max slot penetration [um]": UM * path_data.slot_penetration,
    }
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        for row in zip(*columns.values()):
            writer.writerow([f"{value:.9g}" for value in row])


# plots --------------------------------------------------------------------------------------------------------
def circle(radius: float, points: int = 721) -> np.ndarray:
    angle = np.linspace(0.0, 2.0 * math.pi, points)
    return radius * np.column_stack([np.cos(angle), np.sin(angle)])


def mark_valleys(ax, lobes: int) -> None:
    for k in range(lobes + 1):
        ax.axvline(360.0 * k / lobes, color="0.5", lw=0.8, ls=":")


def angle_axis(ax, lobes: int) -> None:
    mark_valleys(ax, lobes)
    ax.set_xlim(0.0, 360.0)
    ax.set_xticks(range(0, 361, 60))
    ax.set_xlabel("rotor angle in the revolution [deg] (dotted: valleys)")
    ax.grid(True, alpha=0.4)


def title_of(run: LobeRun) -> str:
    p = run.params
    return (f"z = {run.lobes}, c_R = c_S = {CLEARANCE_MM:g} mm, {RPM:g} rpm, stroke {MM * p.stroke:g} mm "
            f"(default geometry)")


def plot_vane_centre(run: LobeRun, m: np.record, path_data: Trajectory, path: Path) -> None:
    fig = plt.figure(figsize=(12, 10))
    grid = fig.add_gridspec(2, 2, height_ratios=(1.25, 1.0))
    fixed, rotor, offsets = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, :])

    bore = MM * stator_curve(m, np.linspace(0.0, 2.0 * math.pi, 1441))
    fixed.plot(bore[:, 0], bore[:, 1], color="0.3", lw=1.0, label="stator contour S(u)")
    fixed.plot(*(MM * circle(m.rotor_radius)).T, color="0.6", lw=0.8, ls="--", label="rotor circle")
    fixed.plot(*(MM * path_data.tip_centre).T, color="C1", lw=1.2, label="tip centre T")
    fixed.plot(*(MM * path_data.centre).T, color="C0", lw=1.6, label="centre of mass G")
    fixed.set_aspect("equal")
    fixed.set_xlabel("x [mm]")
    fixed.set_ylabel("y [mm]")
    fixed.set_title("fixed frame (stator)")
    fixed.legend(fontsize=8, loc="center")
    fixed.grid(True, alpha=0.3)

    degrees = np.degrees(path_data.angle)
    lobe_degrees = 360.0 / run.lobes
    points = rotor.scatter(UM * path_data.tangential_offset, UM * path_data.radial_offset,
                           c=np.mod(degrees, lobe_degrees), s=4, cmap="viridis", vmin=0.0, vmax=lobe_degrees)
    rotor.plot(UM * path_data.tangential_offset, UM * path_data.radial_offset, color="0.7", lw=0.4, zorder=0)
    half_gap = 0.5 * UM * run.params.slot_clearance
    for side in (-1.0, 1.0):
        rotor.axvline(side * half_gap, color="C3", ls="--", lw=1.0,
                      label="±c_R/2: beyond it a slot contact penetrates" if side > 0 else None)
    fig.colorbar(points, ax=rotor, label="rotor angle after the last valley [deg]")
    rotor.set_xlabel("tangential offset of G along e_θ [µm] (+ = leading side)")
    rotor.set_ylabel("radial offset of G along e_r [µm]")
    rotor.set_title("rotor frame: offset of G from its nominal position")
    rotor.legend(fontsize=8, loc="lower right")
    rotor.grid(True, alpha=0.3)

    offsets.plot(degrees, UM * path_data.radial_offset, lw=1.0, label="radial offset of G")
    offsets.plot(degrees, UM * path_data.tangential_offset, lw=1.0, label="tangential offset of G")
    offsets.axhline(half_gap, color="C3", ls="--", lw=0.8, label="±c_R/2 (band of the tangential offset)")
    offsets.axhline(-half_gap, color="C3", ls="--", lw=0.8)
    offsets.set_ylabel("offset from nominal [µm]")
    offsets.legend(fontsize=8, loc="upper right", ncol=3)
    angle_axis(offsets, run.lobes)
    fig.suptitle(f"Vane centre of mass over one revolution: {title_of(run)}\n"
                 f"nominal position: untilted, centred in the slot, tip centre at R0 + s(θ) + c_S (docs/model.md §3.3)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def tip_arc(m: np.record, tip: np.ndarray, vane_angle: float, points: int = 91) -> np.ndarray:
    """The vane's tip semicircle T + rho e(phi3 + psi), |psi| <= pi/2 (docs/model.md §2.1), in the fixed frame."""
    psi = vane_angle + np.linspace(-0.5 * math.pi, 0.5 * math.pi, points)
    return tip + m.tip_radius * np.column_stack([np.cos(psi), np.sin(psi)])


def rotate(points: np.ndarray, angle: float) -> np.ndarray:
    """Points (n, 2) rotated by `angle` about O."""
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def to_valley_frame(points: np.ndarray, valley: float, radius: float) -> np.ndarray:
    """Rotate so that the valley direction e_r(valley) points up (+y) and shift the valley point to the origin."""
    return rotate(points, 0.5 * math.pi - valley) - np.array([0.0, radius])


def from_valley_frame(points: np.ndarray, valley: float, radius: float) -> np.ndarray:
    """The inverse of `to_valley_frame`."""
    return rotate(points + np.array([0.0, radius]), valley - 0.5 * math.pi)


def plot_tip_and_stator(run: LobeRun, m: np.record, path_data: Trajectory, path: Path) -> None:
    fig = plt.figure(figsize=(14, 9.5))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.3))
    full, zoom, gap = fig.add_subplot(grid[:, 0]), fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, 1])
    lobe = 2.0 * math.pi / run.lobes
    valley = lobe                                   # the first valley after the start of the revolution
    valley_radius = m.rotor_radius + m.stator_clearance
    u = np.linspace(0.0, 2.0 * math.pi, 2881)
    bore = stator_curve(m, u)

    full.plot(*(MM * bore).T, color="0.2", lw=1.0, label="stator contour S(u)")
    full.plot(*(MM * circle(m.rotor_radius)).T, color="0.6", lw=0.8, ls="--", label="rotor circle")
    full.plot(*(MM * path_data.tip_centre).T, color="C1", lw=1.0, label="tip centre T")
    every = max(1, len(path_data.angle) // (8 * run.lobes))
    for i in range(0, len(path_data.angle), every):
        full.plot(*(MM * tip_arc(m, path_data.tip_centre[i], path_data.vane_angle[i])).T, color="C0", lw=0.6)
    full.plot([], [], color="C0", lw=0.6, label="tip semicircle (sampled)")
    valley_point = MM * valley_radius * np.array([math.cos(valley), math.sin(valley)])
    full.plot(*valley_point, "o", ms=16, mfc="none", mec="C3", mew=1.5, label="enlarged valley")
    full.set_aspect("equal")
    full.set_xlabel("x [mm]")
    full.set_ylabel("y [mm]")
    full.set_title("tip semicircle against the stator (fixed frame)")
    full.legend(fontsize=8, loc="lower left")
    full.grid(True, alpha=0.3)

    # enlargement: valley frame (valley direction up, valley point at the origin), micrometres vertically
    half_width = ZOOM_HALF_WIDTH
    local_bore = to_valley_frame(bore[np.abs(u - valley) < 0.3 * lobe], valley, valley_radius)
    local_rotor = to_valley_frame(circle(m.rotor_radius, 40001), valley, valley_radius)
    reach = to_valley_frame(path_data.tip_reach, valley, valley_radius)
    local_bore, local_rotor = (curve[(np.abs(curve[:, 0]) <= half_width) & (curve[:, 1] > -0.5e-3)]
                               for curve in (local_bore, local_rotor))     # the near side, inside the window
    zoom.plot(MM * local_bore[:, 0], UM * local_bore[:, 1], color="0.1", lw=2.0, label="stator contour")
    zoom.plot(MM * local_rotor[:, 0], UM * local_rotor[:, 1], color="0.5", lw=1.2, ls="--", label="rotor circle")
    near = np.flatnonzero((np.abs(reach[:, 0]) <= half_width) & (np.abs(path_data.angle - valley) < 0.5 * lobe))
    picked = near[np.linspace(0, near.size - 1, min(ZOOM_CIRCLES, near.size)).round().astype(int)]
    colours = plt.get_cmap("plasma")(np.linspace(0.0, 0.85, picked.size))
    for colour, i in zip(colours, picked):
        arc = to_valley_frame(tip_arc(m, path_data.tip_centre[i], path_data.vane_angle[i], 2001), valley,
                              valley_radius)
        arc = arc[np.abs(arc[:, 0]) <= half_width]
        zoom.plot(MM * arc[:, 0], UM * arc[:, 1], color=colour, lw=0.9)
    for colour, i in ((colours[0], picked[0]), (colours[-1], picked[-1])):
        zoom.plot([], [], color=colour, lw=0.9,
                  label=f"tip semicircle at θ − θ_valley = {math.degrees(path_data.angle[i] - valley):+.2f}°")
    zoom.plot(MM * reach[near, 0], UM * reach[near, 1], "k.", ms=4,
              label="tip point nearest the stator, every sample")
    lowest = min(local_bore[:, 1].min(), local_rotor[:, 1].min())
    zoom.set_xlim(-MM * half_width, MM * half_width)
    zoom.set_ylim(UM * lowest - 15.0, max(UM * np.max(reach[near, 1]), 0.0) + 15.0)
    zoom.set_xlabel("along the valley tangent [mm] (the rotor turns towards -x)")
    zoom.set_ylabel("radial, from the valley point [µm]")
    zoom.set_title(f"enlargement at the valley θ = {math.degrees(valley):g}° (vertical axis in µm): points "
                   f"above the stator line are penetration", fontsize=10)
    zoom.legend(fontsize=7.5, loc="lower center", ncol=2)
    zoom.grid(True, alpha=0.3)

    degrees = np.degrees(path_data.angle)
    for region, colour in ((5, "C2"), (6, "C4")):
        on = np.where(path_data.tip_region == region, UM * path_data.tip_penetration, np.nan)
        gap.plot(degrees, on, color=colour, lw=1.2,
                 label=f"c{region} ({'leading' if region == 5 else 'trailing'} quarter of the tip)")
    gap.axhline(0.0, color="k", lw=0.6)
    gap.set_ylabel("tip penetration into the stator δ_S [µm]\n(< 0: gap)")
    gap.set_title("tip-stator penetration at the sampled instants", fontsize=10)
    gap.legend(fontsize=8, loc="lower right")
    angle_axis(gap, run.lobes)
    fig.suptitle(f"Vane tip against the stator contour over one revolution: {title_of(run)}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_powers_vs_lobes(runs: list[LobeRun], path: Path) -> None:
    lobes = [run.lobes for run in runs]
    fig, (powers, efficiency) = plt.subplots(1, 2, figsize=(12, 4.6))
    for field, label, style in (("input_power", "input power P_in", "o-"), ("output_power", "output power P_out", "s-"),
                                ("friction_power", "friction power P_fric", "^-")):
        powers.plot(lobes, [getattr(run.summary, field) for run in runs], style, label=label)
    powers.set_ylabel("mean power over one revolution [W]")
    powers.legend(fontsize=9)
    efficiency.plot(lobes, [100 * run.summary.mechanical_efficiency for run in runs], "o-", color="C3")
    efficiency.set_ylabel("mechanical efficiency eta_m [%]")
    for ax in (powers, efficiency):
        ax.set_xlabel("number of stator lobes z")
        ax.set_xticks(lobes)
        ax.grid(True, alpha=0.4)
    fig.suptitle(f"Powers and efficiency vs lobes, c_R = c_S = {CLEARANCE_MM:g} mm, {RPM:g} rpm, stroke "
                 f"{MM * runs[0].params.stroke:g} mm")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# tables and captions ------------------------------------------------------------------------------------------
def lobes_table(runs: list[LobeRun], paths: list[Trajectory]) -> str:
    rows = [[f"{run.lobes}", f"{run.regularity:.3f}", *power_cells(run.summary),
             f"{UM * np.max(np.abs(p.tangential_offset)):.1f}", f"{UM * np.max(np.abs(p.radial_offset)):.1f}",
             f"{UM * np.nanmax(p.tip_penetration):.1f}"] for run, p in zip(runs, paths)]
    return markdown_table(["z", "min(1 + d kappa_C)", *POWER_HEADERS, "max abs tangential offset of G [um]",
                           "max abs radial offset of G [um]", "max tip penetration [um]"], rows,
                          f"Lobes at c_R = c_S = {CLEARANCE_MM:g} mm, {RPM:g} rpm: powers over the last revolution; "
                          f"offsets of G from the nominal pose at the sampled instants")


def captions(runs: list[LobeRun], paths: list[Trajectory]) -> dict[str, str]:
    lobes = [run.lobes for run in runs]
    eta = [100 * run.summary.mechanical_efficiency for run in runs]
    friction = [run.summary.friction_power for run in runs]
    regularity = ", ".join(f"{run.regularity:.3f}" for run in runs)
    z_text = "/".join(map(str, lobes))
    result = {
        "powers_vs_lobes.png":
            f"Mean powers and mechanical efficiency vs z: efficiency {trend(eta)} with z ({span(eta, '{:.2f}')} %, "
            f"z = {lobes[0]} -> {lobes[-1]}), friction power {trend(friction)} ({span(friction)} W).",
        "lobes.md":
            f"Every z runs with the default geometry (stroke 5 mm): the stator regularity margin min(1 + d kappa_C) "
            f"= {regularity} for z = {z_text} stays > 0 (docs/model.md §2.5), so nothing was changed. Same power columns "
            f"as the clearance study, plus the largest offsets of G and tip penetration.",
    }
    for run, p in zip(runs, paths):
        result[f"vane_centre_z{run.lobes}.png"] = (
            f"z = {run.lobes}: path of the vane centre of mass G in the fixed frame and its offset from the nominal "
            f"position in the rotor frame (cf. thesis Figs 5.56-5.67): tangential offset "
            f"{UM * p.tangential_offset.min():+.1f} to {UM * p.tangential_offset.max():+.1f} µm "
            f"(slot band ±{0.5 * UM * run.params.slot_clearance:g} µm), radial {UM * p.radial_offset.min():+.1f} to "
            f"{UM * p.radial_offset.max():+.1f} µm.")
        result[f"tip_stator_z{run.lobes}.png"] = (
            f"z = {run.lobes}: tip semicircle against the stator contour, enlarged at the first valley (radial "
            f"axis in µm), and the tip penetration over the revolution: {UM * np.nanmin(p.tip_penetration):.1f} to "
            f"{UM * np.nanmax(p.tip_penetration):.1f} µm "
            f"({'always in contact' if np.nanmin(p.tip_penetration) > 0 else 'the tip lifts off at times'}).")
        result[f"trajectory_z{run.lobes}.csv"] = (
            f"z = {run.lobes}: the sampled poses behind the two figures ({len(p.angle)} instants over the "
            f"revolution).")
    return result


def main(argv=None) -> int:
    args = study_arguments(f"Lobe study: vane centre trajectory, tip against the stator, and powers for z = "
                           f"3, 5, 7, 9 at c = {CLEARANCE_MM:g} mm, {RPM:g} rpm.", argv)
    lobe_counts = QUICK_LOBE_COUNTS if args.quick else LOBE_COUNTS
    revolutions = QUICK_REVOLUTIONS if args.quick else REVOLUTIONS
    samples = QUICK_SAMPLES if args.quick else SAMPLES
    for lobes in lobe_counts:                  # every parameter set is valid before any run starts
        try:
            study_parameters(CLEARANCE_MM, lobes)
        except ValueError as error:
            print(f"error: z = {lobes}: {error}", file=sys.stderr)
            return 2
    folder = args.out / "lobes"
    folder.mkdir(parents=True, exist_ok=True)
    tasks = [(lobes, revolutions, samples) for lobes in lobe_counts]
    workers = min(args.workers, len(tasks))
    print(f"lobe study: z = {', '.join(map(str, lobe_counts))} ({revolutions} revolutions, {samples} sampled poses "
          f"over the last) on {workers} worker(s)")
    start = time.perf_counter()
    try:
        runs = run_points(simulate_lobes, tasks, workers, describe_lobes)
    except PointFailed as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    simulated = time.perf_counter() - start

    machines = [machine_from_parameters(run.params) for run in runs]
    paths = [trajectory(m, run.frames) for m, run in zip(machines, runs)]
    write_tables(folder, {"lobes.md": [lobes_table(runs, paths)]})
    plot_powers_vs_lobes(runs, folder / "powers_vs_lobes.png")
    for run, m, p in zip(runs, machines, paths):
        write_trajectory_csv(folder / f"trajectory_z{run.lobes}.csv", run.frames, p)
        plot_vane_centre(run, m, p, folder / f"vane_centre_z{run.lobes}.png")
        plot_tip_and_stator(run, m, p, folder / f"tip_stator_z{run.lobes}.png")
    total = time.perf_counter() - start

    text = captions(runs, paths)
    order = ["powers_vs_lobes.png", "lobes.md",
             *(f"{kind}_z{run.lobes}.{ext}" for run in runs
               for kind, ext in (("vane_centre", "png"), ("tip_stator", "png"), ("trajectory", "csv")))]
    settings = (f"z = {', '.join(map(str, lobe_counts))}, c_R = c_S = {CLEARANCE_MM:g} mm, {RPM:g} rpm, default "
                f"geometry (stroke 5 mm, harmonic law), Level 0.5 pressure table; {revolutions} revolutions from "
                f"theta0 = 0.02 rad, powers over the last full one; {samples} poses sampled over the revolution after "
                f"{revolutions - 1} settling ones; {workers} worker(s)" + (" (--quick)." if args.quick else "."))
    write_manifest(folder, "lobes", "Lobe study", "python examples/study_lobes.py" + (" --quick" if args.quick else ""),
                   settings, [{"file": name, "caption": text[name]} for name in order],
                   {"simulation (all z)": simulated, "total": total})
    report = write_report(args.out)
    print(f"\nwrote {len(order)} figures, tables and trajectories to {folder}/ in {total:.1f} s; report: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
