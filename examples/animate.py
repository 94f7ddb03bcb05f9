"""Animations of the single-vane compressor: a 2D section (GIF, and MP4 when an ffmpeg is found) and a 3D page.

The compressor is simulated at constant speed (library `Simulation`); after `settle` revolutions that let the
start transient die out, the vane pose (x, y, phi of its centre of mass G, docs/model.md §1.2) and the output row are
taken at equally spaced frame times.

2D frame (docs/model.md §1-§2): stator bore S(u) (docs/model.md §2.5), rotor disc with its slot (§2.2), the vane at its simulated
pose (rectangle + semicircular tip, §2.1), the leading and trailing chambers of the active lobe filled with a
colour for their pressure (idle lobes at suction pressure, §1.1), the normal contact forces on the vane as arrows
at their contact points (§4), and a time / rotor-angle readout.

Clearances of 0.05 mm are invisible at the scale of the machine, so the drawing exaggerates them by a factor k:
the stator and slot are drawn with clearances k c_S and k c_R, and the vane at the zero-clearance reference pose
(tip centre on the pitch curve C(theta), axis radial, centred in the slot) plus k times its simulated offset
from that pose (position of G and tilt phi - theta). Gaps, tilts and the penetrations that give the contact
forces are thereby all scaled by k to first order; the factor is written on every frame.

3D page: the stator, rotor and vane extruded over the axial length L, moving, in one HTML file that works
offline (plotly with its library inlined): play / pause buttons, a frame slider, mouse orbit and zoom.

Usage (from the project folder):

    python examples/animate.py                                   # 2D GIF (+ MP4) and 3D HTML in out/animate/
    python examples/animate.py --kind 2d --frames 36 --fps 9 --size 640x576
    python examples/animate.py --clearance 0.1 --exaggeration 8 --rpm 2000 --revolutions 2
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")                                            # files only, no window
import numpy as np                                               # noqa: E402
from matplotlib import colormaps                                 # noqa: E402
from matplotlib.cm import ScalarMappable                         # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg      # noqa: E402
from matplotlib.colors import Normalize                          # noqa: E402
from matplotlib.figure import Figure                             # noqa: E402
from matplotlib.patches import PathPatch, Polygon                # noqa: E402
from matplotlib.path import Path as MplPath                      # noqa: E402
from PIL import Image                                            # noqa: E402


from rotary_vane.examples.cli_types import number_parser, whole_number_parser  # noqa: E402
from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed  # noqa: E402
from rotary_vane.mechanics.contact.detection import slot_contacts, tip_contact  # noqa: E402
from rotary_vane.mechanics.geometry.displacement import displacement  # noqa: E402
from rotary_vane.mechanics.geometry.stator import closest_pitch_parameter, stator_point  # noqa: E402
from rotary_vane.mechanics.geometry.kinematics import pose_of  # noqa: E402
from rotary_vane.mechanics.loop.layout import ANGLE, X, Y  # noqa: E402
from rotary_vane.mechanics.loop.machine import machine_from_parameters  # noqa: E402
from rotary_vane.mechanics.loop.outputs import OUTPUT_INDEX  # noqa: E402
from rotary_vane.mechanics.contact.modes import REGION_LABELS  # noqa: E402

MM = 1e3                          # drawings are in mm
TWO_PI = 2.0 * math.pi
PRESSURE_MAP = "YlOrRd"
VANE_PROUD = 0.3                  # mm the 3D vane stands out of the rotor faces (no coplanar flicker)


def _require(name: str, value, valid: bool, allowed: str) -> None:
    """Raise the project's ValueError for a bad input: variable, value, allowed range."""
    if not valid:
        raise ValueError(f"'{name}' = {value!r} is invalid: allowed {allowed}")


def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) \
        and math.isfinite(value)


# frames from the simulation ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Frames:
    """Equally spaced samples of one run: the vane pose and the output row at each frame time."""
    params: CompressorParameters
    rpm: float
    time: np.ndarray              # (n,) [s]
    pose: np.ndarray              # (n, 3): x_G, y_G [m], phi3 [rad] (docs/model.md §1.2)
    outputs: np.ndarray           # (n, number of outputs), columns named in mechanics.loop.layout.OUTPUT_NAMES

    def column(self, name: str) -> np.ndarray:
        return self.outputs[:, OUTPUT_INDEX[name]]

    def __len__(self) -> int:
        return self.time.size


def simulate_frames(params: CompressorParameters, rpm: float, frames: int, revolutions: float = 1.0,
                    settle_revolutions: float = 1.0) -> Frames:
    """Run at constant `rpm`, skip `settle_revolutions`, then sample `frames` poses over `revolutions`.

    Frame i (1..n) is at t = t_settle + i T_rev revolutions / n, so a looped animation steps evenly.
    Each frame time is an end point of `Simulation.advance`, where the integrator lands exactly.
    """
    _require("rpm", rpm, _is_number(rpm) and rpm > 0.0, "a finite speed > 0 rpm")
    _require("frames", frames, isinstance(frames, (int, np.integer)) and frames >= 2, "a whole number >= 2")
    _require("revolutions", revolutions, _is_number(revolutions) and revolutions > 0.0, "a finite number > 0")
    _require("settle_revolutions", settle_revolutions, _is_number(settle_revolutions) and settle_revolutions >= 0.0,
             "a finite number >= 0")
    period = 60.0 / rpm
    simulation = Simulation(params, constant_speed(rpm), keep_history=False)
    start = settle_revolutions * period
    simulation.advance(start)
    times = start + revolutions * period * np.arange(1, frames + 1) / frames
    poses = np.empty((frames, 3))
    rows = np.empty((frames, simulation.last_output.size))
    for i, t in enumerate(times):
        simulation.advance(float(t))
        poses[i] = simulation.state[[X, Y, ANGLE]]
        rows[i] = simulation.last_output
    return Frames(params, float(rpm), times, poses, rows)


# drawn geometry ------------------------------------------------------------------------------------------
def drawn_machine(params: CompressorParameters, exaggeration: float) -> np.record:
    """The machine as drawn: clearances c_R, c_S multiplied by the exaggeration factor k >= 1.

    Built through CompressorParameters, so the drawn slot width w = t + k c_R, mouth radius, envelope offset
    d = rho + k c_S and the regularity of the drawn stator (docs/model.md §2.2, §2.5) are checked as for a real machine.
    """
    _require("exaggeration", exaggeration, _is_number(exaggeration) and exaggeration >= 1.0, "a finite factor >= 1")
    try:
        drawn = replace(params, slot_clearance=exaggeration * params.slot_clearance,
                        stator_clearance=exaggeration * params.stator_clearance)
    except ValueError as error:
        raise ValueError(f"'exaggeration' = {exaggeration!r} is invalid for c_R = {params.slot_clearance!r} m, "
                         f"c_S = {params.stator_clearance!r} m: the drawn clearances must themselves be valid "
                         f"({error})") from None
    return machine_from_parameters(drawn)


def _law(m: np.record) -> tuple:
    return m.law, m.stroke, m.lobes, m.bottom_dwell, m.top_dwell


def reference_centre(m: np.record, theta: float) -> np.ndarray:
    """Vane CG G at zero clearance: tip centre on the pitch curve, axis radial: G = (R0 + s(theta) - xi_T) e_r."""
    radius = m.base_radius + displacement(theta, *_law(m))[0] - m.tip_centre
    return radius * np.array([math.cos(theta), math.sin(theta)])


def drawn_pose(m: np.record, theta: float, pose: np.ndarray, exaggeration: float) -> np.ndarray:
    """(x, y, phi) of the drawn vane: reference pose + k (simulated pose - reference pose)."""
    reference = reference_centre(m, theta)
    centre = reference + exaggeration * (pose[:2] - reference)
    return np.array([centre[0], centre[1], theta + exaggeration * (pose[2] - theta)])


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def vane_outline(m: np.record, pose: np.ndarray, arc_points: int = 25) -> np.ndarray:
    """Stadium-ended vane (docs/model.md §2.1) in the global frame: bottom corners B-, J-, tip arc, J+, B+ (closed shape).

    Body frame: flat faces eta = +-t/2 for xi_B <= xi <= xi_T, tip arc T + rho (cos psi, sin psi), |psi| <= pi/2.
    """
    psi = np.linspace(-0.5 * math.pi, 0.5 * math.pi, arc_points)
    body = np.vstack([[m.bottom_face, -m.half_thickness],
                      np.column_stack([m.tip_centre + m.tip_radius * np.cos(psi), m.tip_radius * np.sin(psi)]),
                      [m.bottom_face, m.half_thickness]])
    return _rotate(body, pose[2]) + pose[:2]


def rotor_outline(m: np.record, theta: float, arc_points: int = 180) -> np.ndarray:
    """Rotor disc minus its slot (docs/model.md §2.2): rim arc from E+ round to E-, then the slot walls and bottom.

    Rotor frame: E+- = (R_m, +-w/2), slot bottom at xi = r_sb; the outline is star-shaped about O.
    """
    mouth = math.atan2(m.half_slot_width, m.mouth_radius)
    rim = np.linspace(mouth, TWO_PI - mouth, arc_points)
    body = np.vstack([m.rotor_radius * np.column_stack([np.cos(rim), np.sin(rim)]),
                      [[m.slot_bottom_radius, -m.half_slot_width], [m.slot_bottom_radius, m.half_slot_width]]])
    return _rotate(body, theta)


def slot_outline(m: np.record, theta: float) -> np.ndarray:
    """The slot as a rectangle r_sb <= xi <= R_m, |eta| <= w/2 in the rotor frame (docs/model.md §2.2), rotated by theta."""
    corners = np.array([[m.slot_bottom_radius, -m.half_slot_width], [m.mouth_radius, -m.half_slot_width],
                        [m.mouth_radius, m.half_slot_width], [m.slot_bottom_radius, m.half_slot_width]])
    return _rotate(corners, theta)


def stator_curve(m: np.record, parameters: np.ndarray) -> np.ndarray:
    """Stator bore points S(u) = C(u) + d n(u) (docs/model.md §2.5) at the given curve parameters u."""
    law = _law(m)
    return np.array([stator_point(u, *law, m.base_radius, m.envelope_offset)[:2] for u in parameters])


def chamber_polygons(m: np.record, theta: float, tip_centre: np.ndarray, arc_points: int = 60):
    """Leading and trailing chambers of the active lobe as polygons (docs/model.md §1.1), for the vane tip centre T.

    Lobe j spans the valleys u_j = 2 pi j/z <= theta < u_j+1. The vane meets the stator at u*, the closest
    stator point to T (docs/model.md §2.6). Leading: T, stator u* -> u_j+1, rotor rim u_j+1 -> theta. Trailing: T, rotor
    rim theta -> u_j, stator u_j -> u*. Both share the edge from T to the slot mouth, which the vane covers;
    together they fill the lobe between rotor and stator.
    """
    lobe = TWO_PI / m.lobes
    valley = math.floor(theta / lobe) * lobe
    polar = math.atan2(tip_centre[1], tip_centre[0])
    polar = theta + (polar - theta + math.pi) % TWO_PI - math.pi             # unwrapped next to theta
    contact = closest_pitch_parameter(tip_centre[0], tip_centre[1], polar, *_law(m), m.base_radius)[0]

    def rim(a, b):
        angle = np.linspace(a, b, arc_points)
        return m.rotor_radius * np.column_stack([np.cos(angle), np.sin(angle)])

    leading = np.vstack([tip_centre, stator_curve(m, np.linspace(contact, valley + lobe, arc_points)),
                         rim(valley + lobe, theta)])
    trailing = np.vstack([tip_centre, rim(theta, valley), stator_curve(m, np.linspace(valley, contact, arc_points))])
    return leading, trailing


@dataclass(frozen=True)
class ContactForce:
    region: int                   # 1..6 (docs/model.md §1.3)
    point: np.ndarray             # application point on the vane (global frame) [m]
    normal: np.ndarray            # unit normal from the other body into the vane
    force: float                  # normal force magnitude [N]


def contact_forces(m: np.record, pose: np.ndarray, row: np.ndarray) -> list[ContactForce]:
    """The active contacts of one output row with their points and normals from the detection functions (docs/model.md §4).

    Regions c1/c2 slot mouth, c3/c4 vane bottom corners on the walls, c5/c6 tip on stator (one of them at a time),
    c7/c8 vane bottom corners on the slot bottom.
    """
    gx, gy, phi = pose
    vane = pose_of(gx, gy, phi, row[OUTPUT_INDEX["rotor_angle"]], m)
    tip = tip_contact(vane, row[OUTPUT_INDEX["closest_parameter_offset"]], m).candidate
    detected = dict(zip((1, 2, 3, 4, 5, 6), (*slot_contacts(vane, m), tip, tip)))
    contacts = []
    for region, candidate in detected.items():
        force = row[OUTPUT_INDEX[f"normal_force_{region}"]]
        if force > 0.0:
            contacts.append(ContactForce(region, np.array([candidate.point_x, candidate.point_y]),
                                         np.array([candidate.normal_x, candidate.normal_y]), float(force)))
    return contacts


def carried_with_vane(point: np.ndarray, pose: np.ndarray, new_pose: np.ndarray) -> np.ndarray:
    """A point fixed in the vane, moved from `pose` to `new_pose` (same body-frame coordinates)."""
    body = _rotate((point - pose[:2])[None, :], -pose[2])
    return (_rotate(body, new_pose[2]) + new_pose[:2])[0]


# 2D animation -------------------------------------------------------------------------------------------
def _nice_force(value: float) -> float:
    """A round force (1, 2 or 5 x 10^n N) not above `value`, for the arrow scale key."""
    power = 10.0 ** math.floor(math.log10(value))
    return max(step * power for step in (1.0, 2.0, 5.0) if step * power <= value)


class Section2D:
    """A matplotlib figure of the compressor section whose artists are moved to each frame by `show(i)`."""

    def __init__(self, frames: Frames, exaggeration: float, size: tuple[int, int] = (800, 720), dpi: int = 100):
        self.frames = frames
        self.exaggeration = exaggeration
        self.actual = machine_from_parameters(frames.params)
        self.drawn = drawn_machine(frames.params, exaggeration)
        params = frames.params
        leading, trailing = frames.column("leading_pressure"), frames.column("trailing_pressure")
        self.norm = Normalize(min(params.suction_pressure, trailing.min()) / 1e5,
                              max(params.discharge_pressure, leading.max()) / 1e5)
        self.cmap = colormaps[PRESSURE_MAP]

        self.figure = Figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
        FigureCanvasAgg(self.figure)
        ax = self.figure.add_axes((0.07, 0.1, 0.74, 0.78))
        m = self.drawn
        bore = MM * stator_curve(m, np.linspace(0.0, TWO_PI, 721))
        reach = float(np.max(np.hypot(bore[:, 0], bore[:, 1])))
        outer = (reach + 4.0) * np.column_stack([np.cos(np.linspace(0.0, TWO_PI, 361)),
                                                 np.sin(np.linspace(0.0, TWO_PI, 361))])
        ring = MplPath.make_compound_path(MplPath(outer, closed=True), MplPath(bore[::-1], closed=True))
        ax.add_patch(PathPatch(ring, facecolor="0.45", edgecolor="0.2", lw=0.8, zorder=1))
        ax.add_patch(Polygon(bore, facecolor=self.cmap(self.norm(params.suction_pressure / 1e5)),
                             edgecolor="none", zorder=0))
        self.leading = ax.add_patch(Polygon(np.zeros((3, 2)), edgecolor="0.3", lw=0.5, zorder=0.5))
        self.trailing = ax.add_patch(Polygon(np.zeros((3, 2)), edgecolor="0.3", lw=0.5, zorder=0.5))
        self.back_chamber = ax.add_patch(Polygon(np.zeros((3, 2)), edgecolor="none", zorder=1.5,
                                                 facecolor=self.cmap(self.norm(params.discharge_pressure / 1e5))))
        self.rotor = ax.add_patch(Polygon(np.zeros((3, 2)), facecolor="0.75", edgecolor="0.25", lw=0.8, zorder=2))
        self.vane = ax.add_patch(Polygon(np.zeros((3, 2)), facecolor="steelblue", edgecolor="navy", lw=0.8,
                                         zorder=3))
        ax.plot([0.0], [0.0], "k+", zorder=2.5)

        peak = max((c.force for i in range(len(frames))
                    for c in contact_forces(self.actual, frames.pose[i], frames.outputs[i])), default=100.0)
        self.newton_per_mm = peak / (0.25 * reach)         # the largest force is drawn 0.25 stator radii long
        self.arrows = ax.quiver(np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6), angles="xy", scale_units="xy",
                                scale=self.newton_per_mm, pivot="tip", color="black", width=0.006, zorder=4)
        key = _nice_force(0.6 * peak)
        ax.quiverkey(self.arrows, 0.855, 0.955, key, f"{key:g} N", labelpos="S", coordinates="figure",
                     fontproperties={"size": 9})
        self.labels = [ax.text(0.0, 0.0, label, fontsize=8, ha="center", va="center", zorder=5, visible=False,
                               bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
                       for label in REGION_LABELS]

        ax.set_aspect("equal")
        ax.set_xlim(-reach - 10.0, reach + 10.0)
        ax.set_ylim(-reach - 10.0, reach + 10.0)
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        colour_axes = self.figure.add_axes((0.84, 0.1, 0.03, 0.78))
        self.figure.colorbar(ScalarMappable(self.norm, self.cmap), cax=colour_axes,
                             label="chamber pressure [bar]")
        self.readout = self.figure.text(0.07, 0.985, "", fontsize=9, va="top", family="monospace")
        c_r, c_s = params.slot_clearance * MM, params.stator_clearance * MM
        self.figure.text(0.07, 0.005, f"clearances drawn x{exaggeration:g}: c_R = {c_r:g} mm, c_S = {c_s:g} mm "
                         f"shown as {exaggeration * c_r:.3g} mm, {exaggeration * c_s:.3g} mm; the vane's offset and "
                         f"tilt from its nominal slot\nposition also x{exaggeration:g}. Slot bottom (back chamber) "
                         f"at discharge pressure; idle lobes at suction pressure.", fontsize=8)

    def show(self, i: int) -> None:
        """Move every artist to frame i."""
        frames, m = self.frames, self.drawn
        row = frames.outputs[i]
        theta = row[OUTPUT_INDEX["rotor_angle"]]
        pose = drawn_pose(m, theta, frames.pose[i], self.exaggeration)
        tip_centre = pose[:2] + m.tip_centre * np.array([math.cos(pose[2]), math.sin(pose[2])])
        leading, trailing = chamber_polygons(m, theta, tip_centre)
        p_leading = row[OUTPUT_INDEX["leading_pressure"]] / 1e5
        p_trailing = row[OUTPUT_INDEX["trailing_pressure"]] / 1e5
        self.leading.set_xy(MM * leading)
        self.leading.set_facecolor(self.cmap(self.norm(p_leading)))
        self.trailing.set_xy(MM * trailing)
        self.trailing.set_facecolor(self.cmap(self.norm(p_trailing)))
        self.rotor.set_xy(MM * rotor_outline(m, theta))
        self.back_chamber.set_xy(MM * slot_outline(m, theta))
        self.vane.set_xy(MM * vane_outline(m, pose))

        contacts = contact_forces(self.actual, frames.pose[i], row)
        points = np.zeros((6, 2))
        vectors = np.zeros((6, 2))
        for label in self.labels:
            label.set_visible(False)
        for k, contact in enumerate(contacts):
            point = MM * carried_with_vane(contact.point, frames.pose[i], pose)
            points[k] = point
            vectors[k] = contact.force * contact.normal
            tail = point - vectors[k] / self.newton_per_mm
            label = self.labels[contact.region - 1]
            label.set_position(tail - 2.0 * contact.normal)
            label.set_visible(True)
        self.arrows.set_offsets(points)
        self.arrows.set_UVC(vectors[:, 0], vectors[:, 1])

        lobe = TWO_PI / m.lobes
        forces = ", ".join(f"{REGION_LABELS[c.region - 1]} {c.force:.3g} N" for c in contacts) or "none"
        self.readout.set_text(
            f"t = {1e3 * frames.time[i]:7.2f} ms   rotor angle {math.degrees(theta) % 360.0:6.1f} deg "
            f"(lobe phase {math.degrees(theta % lobe):5.1f} deg)   {frames.rpm:g} rpm, z = {m.lobes:.0f}\n"
            f"leading chamber {p_leading:5.2f} bar, trailing {p_trailing:5.2f} bar\n"
            f"normal contact forces on the vane (arrows): {forces}")

    def rgb(self, i: int) -> np.ndarray:
        """Frame i rendered, as an (height, width, 3) uint8 array."""
        self.show(i)
        self.figure.canvas.draw()
        return np.asarray(self.figure.canvas.buffer_rgba())[:, :, :3].copy()


def find_ffmpeg() -> str | None:
    """An ffmpeg executable: the one on PATH, else the binary bundled by the imageio-ffmpeg package, else None."""
    found = shutil.which("ffmpeg")
    if found:
        return found
    try:
        import imageio_ffmpeg
    except ImportError:
        return None
    return imageio_ffmpeg.get_ffmpeg_exe()


def _ffmpeg_pipe(ffmpeg: str, path: Path, width: int, height: int, fps: float) -> subprocess.Popen:
    """ffmpeg reading raw RGB frames on stdin and writing H.264 (yuv420p, padded to even sizes) to `path`."""
    command = [ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{width}x{height}",
               "-r", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264",
               "-pix_fmt", "yuv420p", str(path)]
    return subprocess.Popen(command, stdin=subprocess.PIPE, stderr=subprocess.PIPE)


def write_2d(frames: Frames, out: Path, exaggeration: float = 20.0, fps: float = 12.0,
             size: tuple[int, int] = (800, 720), ffmpeg: str | None = None) -> list[Path]:
    """Render every frame once; write compressor_2d.gif (Pillow) and, given an ffmpeg, compressor_2d.mp4 (H.264).

    Returns the paths written. GIF frames use a fast octree palette of 256 colours (slight banding of the colour
    bar); the MP4 keeps the full colours. The GIF frame time is 1/fps rounded to the format's 10 ms."""
    _require("fps", fps, _is_number(fps) and fps > 0.0, "a finite rate > 0 frames/s")
    _require("size", size, len(size) == 2 and all(isinstance(v, int) and 100 <= v <= 4000 for v in size),
             "(width, height) in whole pixels, each 100..4000")
    out.mkdir(parents=True, exist_ok=True)
    section = Section2D(frames, exaggeration, size)
    images = []
    video = None
    paths = [out / "compressor_2d.gif"]
    try:
        for i in range(len(frames)):
            rgb = section.rgb(i)
            if ffmpeg and video is None:
                paths.append(out / "compressor_2d.mp4")
                video = _ffmpeg_pipe(ffmpeg, paths[-1], rgb.shape[1], rgb.shape[0], fps)
            if video is not None:
                video.stdin.write(rgb.tobytes())
            images.append(Image.fromarray(rgb).quantize(colors=256, method=Image.Quantize.FASTOCTREE))
    finally:
        if video is not None:
            _, errors = video.communicate()
            if video.returncode != 0:
                raise RuntimeError(f"ffmpeg failed writing {paths[-1]}: {errors.decode(errors='replace')}")
    images[0].save(paths[0], save_all=True, append_images=images[1:], duration=round(1000.0 / fps), loop=0)
    return paths


# 3D page -------------------------------------------------------------------------------------------------
def _extruded_star(outline: np.ndarray, centre: np.ndarray, bottom: float, top: float):
    """Prism over a polygon star-shaped about `centre`, z in [bottom, top]: vertices and triangles (i, j, k).

    Vertex layout: bottom outline (n), top outline (n), bottom centre, top centre; fan caps and quad sides.
    """
    n = len(outline)
    points = np.vstack([outline, outline, centre, centre])
    z = np.concatenate([np.full(n, bottom), np.full(n, top), [bottom, top]])
    a = np.arange(n)
    b = (a + 1) % n
    triangles = np.vstack([np.column_stack([a, b, b + n]), np.column_stack([a, b + n, a + n]),
                           np.column_stack([np.full(n, 2 * n), b, a]), np.column_stack([np.full(n, 2 * n + 1),
                                                                                         a + n, b + n])])
    return points, z, triangles


def _extruded_ring(inner: np.ndarray, outer: np.ndarray, length: float):
    """Prism over the ring between two closed polylines of equal point count, z in [0, L]."""
    n = len(inner)
    points = np.vstack([inner, inner, outer, outer])                 # inner bottom, inner top, outer bottom, top
    z = np.concatenate([np.zeros(n), np.full(n, length), np.zeros(n), np.full(n, length)])
    a = np.arange(n)
    b = (a + 1) % n
    quads = [(a, b, b + n, a + n), (a + 2 * n, b + 2 * n, b + 3 * n, a + 3 * n),   # bore, outer wall
             (a, b, b + 2 * n, a + 2 * n), (a + n, b + n, b + 3 * n, a + 3 * n)]   # end faces
    triangles = np.vstack([np.vstack([np.column_stack([p, q, r]), np.column_stack([p, r, s])])
                           for p, q, r, s in quads])
    return points, z, triangles


def write_3d(frames: Frames, path: Path, exaggeration: float = 20.0, fps: float = 12.0) -> Path:
    """One self-contained HTML page (plotly.js inlined) with the extruded stator, rotor and vane moving.

    Drawn geometry as in 2D (clearances and vane offsets x exaggeration), extruded over the axial length L; the
    vane stands VANE_PROUD out of both rotor faces so that its end faces do not flicker against the rotor's.
    """
    import plotly.graph_objects as go

    _require("fps", fps, _is_number(fps) and fps > 0.0, "a finite rate > 0 frames/s")
    m = drawn_machine(frames.params, exaggeration)
    length = MM * m.axial_length
    bore = MM * stator_curve(m, np.linspace(0.0, TWO_PI, 360, endpoint=False))
    reach = float(np.max(np.hypot(bore[:, 0], bore[:, 1])))
    outer = (reach + 4.0) * bore / np.hypot(bore[:, 0], bore[:, 1])[:, None]
    stator, stator_z, stator_triangles = _extruded_ring(bore, outer, length)

    def mesh(points, z, triangles, colour, opacity, name):
        return go.Mesh3d(x=points[:, 0], y=points[:, 1], z=z, i=triangles[:, 0], j=triangles[:, 1],
                         k=triangles[:, 2], color=colour, opacity=opacity, name=name, flatshading=True,
                         hoverinfo="skip")

    def moving(i):
        theta = frames.outputs[i, OUTPUT_INDEX["rotor_angle"]]
        pose = drawn_pose(m, theta, frames.pose[i], exaggeration)
        rotor = _extruded_star(MM * rotor_outline(m, theta, 120), np.zeros(2), 0.0, length)
        vane_points = MM * vane_outline(m, pose, 17)
        vane = _extruded_star(vane_points, vane_points.mean(axis=0), -VANE_PROUD, length + VANE_PROUD)
        return theta, rotor, vane

    theta, rotor, vane = moving(0)
    edge = np.vstack([bore, bore[:1]])
    figure = go.Figure(data=[mesh(stator, stator_z, stator_triangles, "lightsteelblue", 1.0, "stator"),
                             mesh(*rotor, "gray", 1.0, "rotor"), mesh(*vane, "darkorange", 1.0, "vane"),
                             go.Scatter3d(x=edge[:, 0], y=edge[:, 1], z=np.full(len(edge), length), mode="lines",
                                          line=dict(color="black", width=3), hoverinfo="skip", name="bore")])
    steps = []
    frame_list = []
    for i in range(len(frames)):
        theta, rotor, vane = moving(i)
        name = str(i)
        frame_list.append(go.Frame(name=name, traces=[1, 2], data=[
            go.Mesh3d(x=rotor[0][:, 0], y=rotor[0][:, 1]), go.Mesh3d(x=vane[0][:, 0], y=vane[0][:, 1])]))
        steps.append(dict(method="animate", label=f"{math.degrees(theta) % 360.0:.0f}",
                          args=[[name], dict(mode="immediate", frame=dict(duration=0, redraw=True),
                                             transition=dict(duration=0))]))
    figure.frames = frame_list
    play = dict(frame=dict(duration=round(1000.0 / fps), redraw=True), fromcurrent=True,
                transition=dict(duration=0), mode="immediate")
    pause = dict(frame=dict(duration=0, redraw=False), transition=dict(duration=0), mode="immediate")
    c = frames.params.slot_clearance * MM
    figure.update_layout(
        title=dict(text=f"Single-vane compressor, z = {m.lobes:.0f}, {frames.rpm:g} rpm, "
                        f"clearance {c:g} mm drawn x{exaggeration:g} (dimensions in mm)", font=dict(size=14)),
        scene=dict(aspectmode="data", camera=dict(eye=dict(x=0.4, y=-0.9, z=1.7)), domain=dict(y=[0.08, 1.0]),
                   xaxis_title="x", yaxis_title="y", zaxis_title="z"),
        margin=dict(l=0, r=0, t=40, b=0), showlegend=False,
        updatemenus=[dict(type="buttons", direction="left", x=0.02, y=0.02, xanchor="left", yanchor="bottom",
                          buttons=[dict(label="Play", method="animate", args=[None, play]),
                                   dict(label="Pause", method="animate", args=[[None], pause])])],
        sliders=[dict(steps=steps, x=0.2, len=0.78, y=0.02, yanchor="bottom", ticklen=0,
                      font=dict(color="rgba(0,0,0,0)"),                        # no per-step tick labels
                      currentvalue=dict(prefix="rotor angle [deg]: ", font=dict(color="black")))])
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.write_html(path, include_plotlyjs=True, full_html=True, auto_play=False)
    return path


# command line --------------------------------------------------------------------------------------------
def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT in pixels, e.g. 800x720") from None
    if not (100 <= width <= 4000 and 100 <= height <= 4000):
        raise argparse.ArgumentTypeError(f"{text!r} is invalid: allowed a width and height of 100..4000 pixels")
    return width, height


def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="Simulate the compressor at constant speed and write a 2D animation (GIF, and MP4 if an "
                    "ffmpeg is found) and/or a self-contained 3D HTML page.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--kind", choices=("2d", "3d", "both"), default="both", help="which animations to write")
    parser.add_argument("--rpm", type=number_parser("rpm"), default=1500.0, help="constant rotor speed [rpm]")
    parser.add_argument("--clearance", type=float, default=0.05,
                        help="slot clearance c_R (total) = stator clearance c_S [mm]")
    parser.add_argument("--lobes", type=int, default=3, help="number of stator lobes z")
    parser.add_argument("--exaggeration", type=float, default=20.0,
                        help="factor on the clearances and the vane's offsets from its nominal pose in the drawing")
    parser.add_argument("--revolutions", type=number_parser("revolutions"), default=1.0, help="simulated revolutions shown")
    parser.add_argument("--settle", type=number_parser("revolutions", low_inclusive=True), default=1.0,
                        help="revolutions simulated first and not shown (start transient)")
    parser.add_argument("--frames", type=whole_number_parser(2), default=72, help="frames over the revolutions shown")
    parser.add_argument("--fps", type=number_parser("frames/s"), default=12.0, help="playback frames per second")
    parser.add_argument("--size", type=_size, default=(800, 720), help="2D frame size WIDTHxHEIGHT [pixels]")
    parser.add_argument("--out", type=Path, default=Path("out/animate"), help="output folder")
    args = parser.parse_args(argv)
    if args.kind != "2d" and importlib.util.find_spec("plotly") is None:
        parser.error("the 3D page needs plotly (pip install plotly), or use --kind 2d")
    try:
        args.params = CompressorParameters(slot_clearance=args.clearance * 1e-3,
                                           stator_clearance=args.clearance * 1e-3, lobes=args.lobes)
        drawn_machine(args.params, args.exaggeration)          # reject a bad factor before simulating
    except ValueError as error:
        parser.error(str(error))
    return args


def main(argv=None) -> int:
    args = parse_arguments(argv)
    start = time.perf_counter()
    frames = simulate_frames(args.params, args.rpm, args.frames, args.revolutions, args.settle)
    print(f"simulated {args.settle:g} + {args.revolutions:g} revolutions at {args.rpm:g} rpm, "
          f"{len(frames)} frames: {time.perf_counter() - start:.2f} s")
    written = []
    if args.kind in ("2d", "both"):
        start = time.perf_counter()
        ffmpeg = find_ffmpeg()
        written += write_2d(frames, args.out, args.exaggeration, args.fps, args.size, ffmpeg)
        print(f"2D: {len(frames)} frames rendered and written in {time.perf_counter() - start:.2f} s")
        if ffmpeg is None:
            print("note: no ffmpeg found (neither on PATH nor from the imageio-ffmpeg package): wrote the GIF only")
    if args.kind in ("3d", "both"):
        start = time.perf_counter()
        written.append(write_3d(frames, args.out / "compressor_3d.html", args.exaggeration, args.fps))
        print(f"3D: page written in {time.perf_counter() - start:.2f} s")
    for path in written:
        print(f"  {path}  {path.stat().st_size / 1e6:.2f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
