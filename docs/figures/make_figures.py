"""Figures of docs/model.md, made from the library (about a minute on one core once the kernels are compiled).

    python docs/figures/make_figures.py            # writes docs/figures/*.png next to this file

geometry.png          stator S(u), pitch curve C(u), rotor and the vane at one pose, z = 3 and z = 5 (§1.1, §2)
contact_regions.png   the vane in its slot with an exaggerated clearance and the six contact regions (§1.3, §4)
pressure_tables.png   p_L over a lobe for Level 0 and Level 0.5 (c_S = 0 and 0.2 mm) and Level 1 (§6.1, §7)
waveforms.png         driving torque, stator moment and contact forces over one revolution, c = 0 and 0.05 mm (§5, §6)
clearance_study.png   mean powers and efficiency against clearance at 1500 rpm, Level 0.5 (§10)
startup.png           radial acceleration of the vane during the thesis start-up, against the nominal law (§3.2, §10)
"""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed, cycloidal_ramp  # noqa: E402
from rotary_vane.mechanics.geometry.displacement import displacement  # noqa: E402
from rotary_vane.mechanics.geometry.stator import law_arguments, pitch_frame  # noqa: E402
from rotary_vane.mechanics.performance import revolutions  # noqa: E402
from rotary_vane.mechanics.gas.pressure_source import leading_pressure_table  # noqa: E402

HERE = Path(__file__).resolve().parent
DPI = 100
RPM = 1500.0
MM = 1e3


def _save(figure, name):
    figure.savefig(HERE / name, dpi=DPI)
    plt.close(figure)
    print("wrote", HERE / name)


def _curves(params, samples=1500):
    u = np.linspace(0.0, 2.0 * math.pi, samples)
    frames = np.array([pitch_frame(x, *law_arguments(params)) for x in u])
    pitch = frames[:, :2]
    stator = pitch + params.envelope_offset * frames[:, 2:4]
    return pitch, stator


def _vane_outline(params, theta, lift=None):
    """Outline of the vane on its nominal pose at rotor angle theta (tip centre on the pitch curve)."""
    s = (params.stroke / 2) * (1 - math.cos(params.lobes * theta)) if lift is None else lift
    rho = params.tip_radius
    radius = params.base_radius + s
    er = np.array([math.cos(theta), math.sin(theta)])
    et = np.array([-er[1], er[0]])
    straight = params.vane_length - rho
    psi = np.linspace(-math.pi / 2, math.pi / 2, 60)
    arc = [(radius + rho * math.cos(a)) * er + rho * math.sin(a) * et for a in psi]
    bottom = radius - straight
    corners = [bottom * er + rho * et, bottom * er - rho * et]
    points = np.array([radius * er - rho * et, *arc, radius * er + rho * et, corners[0], corners[1],
                       radius * er - rho * et])
    return points, radius * er


def geometry_figure():
    figure, axes = plt.subplots(1, 2, figsize=(10, 5))
    for ax, lobes in zip(axes, (3, 5)):
        p = CompressorParameters(lobes=lobes)
        pitch, stator = _curves(p)
        circle = np.linspace(0, 2 * math.pi, 400)
        ax.fill(stator[:, 0] * MM, stator[:, 1] * MM, color="#dde7f3", zorder=0)
        ax.plot(stator[:, 0] * MM, stator[:, 1] * MM, color="navy", lw=1.6, label="stator S(u)")
        ax.plot(pitch[:, 0] * MM, pitch[:, 1] * MM, "--", color="tab:orange", lw=1, label="pitch curve C(u)")
        ax.fill(p.rotor_radius * np.cos(circle) * MM, p.rotor_radius * np.sin(circle) * MM, color="#cccccc",
                zorder=1, label="rotor")
        theta = 0.55 * 2 * math.pi / lobes
        half = 0.5 * p.slot_width
        er = np.array([math.cos(theta), math.sin(theta)])
        et = np.array([-er[1], er[0]])
        slot = np.array([p.mouth_radius * er + half * et, p.slot_bottom_radius * er + half * et,
                         p.slot_bottom_radius * er - half * et, p.mouth_radius * er - half * et])
        ax.fill(slot[:, 0] * MM, slot[:, 1] * MM, color="white", zorder=2)
        outline, tip = _vane_outline(p, theta)
        ax.fill(outline[:, 0] * MM, outline[:, 1] * MM, color="tab:red", alpha=0.8, zorder=3, label="vane")
        ax.plot([0], [0], "k+", zorder=4)
        for j in range(lobes):
            u = 2 * math.pi * j / lobes
            ax.plot([p.rotor_radius * math.cos(u) * MM], [p.rotor_radius * math.sin(u) * MM], "k.", zorder=4)
        lead = er * (p.rotor_radius + 0.6 * p.stroke) + 4e-3 * et
        trail = er * (p.rotor_radius + 0.6 * p.stroke) - 4e-3 * et
        ax.annotate("L", lead * MM, fontsize=12, ha="center", va="center", zorder=5)
        ax.annotate("T", trail * MM, fontsize=12, ha="center", va="center", zorder=5)
        ax.annotate("ω", (0.5 * p.rotor_radius * MM, -0.15 * p.rotor_radius * MM), fontsize=12)
        ax.set_aspect("equal")
        ax.set_title(f"z = {lobes}, h = {p.stroke * MM:g} mm, R_r = {p.rotor_radius * MM:g} mm "
                     f"(dots: valleys)")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.legend(loc="lower left", fontsize=8)
    figure.tight_layout()
    _save(figure, "geometry.png")


def contact_regions_figure():
    """Schematic in the rotor frame (slot vertical), clearance and tilt exaggerated."""
    t, rho = 4.0, 2.0
    clearance = 1.2                                   # drawn, not to scale
    half_w = (t + clearance) / 2
    tilt = math.radians(-6.0)
    figure, ax = plt.subplots(figsize=(6.4, 6.4))
    mouth = 30.0
    bottom = 9.5
    # rotor body (two blocks beside the slot) and the stator arc above
    ax.fill([-9, -half_w, -half_w, -9], [bottom - 2, bottom - 2, mouth, mouth], color="#cccccc")
    ax.fill([half_w, 9, 9, half_w], [bottom - 2, bottom - 2, mouth, mouth], color="#cccccc")
    ax.fill([-half_w, half_w, half_w, -half_w], [bottom - 2, bottom - 2, bottom, bottom], color="#cccccc")
    x = np.linspace(-9, 9, 100)
    ax.fill_between(x, 34.5 + 0.02 * x ** 2 - 0.12 * x, 38, color="#dde7f3")
    ax.plot(x, 34.5 + 0.02 * x ** 2 - 0.12 * x, color="navy")
    # the vane: tip centre T, axis tilted
    tip = np.array([0.35, 32.5])
    axis = np.array([math.sin(-tilt), math.cos(-tilt)])
    normal = np.array([-axis[1], axis[0]])            # e_eta (leading side to the left: rotation towards -x)
    straight = 16.0
    psi = np.linspace(-math.pi / 2, math.pi / 2, 50)
    arc = [tip + rho * (math.cos(a) * axis + math.sin(a) * normal) for a in psi]
    base = tip - straight * axis
    outline = np.array([tip - rho * normal, *arc, tip + rho * normal, base + rho * normal, base - rho * normal,
                        tip - rho * normal])
    ax.fill(outline[:, 0], outline[:, 1], color="tab:red", alpha=0.75)
    ax.plot(*tip, "k.", ms=4)
    ax.annotate("T", tip + np.array([0.3, -0.9]), fontsize=9)
    labels = {
        "c1": (np.array([-half_w, mouth]), (-8.0, 33.0)),
        "c2": (np.array([half_w, mouth]), (6.0, 33.0)),
        "c3": (base + rho * normal, (-8.0, 12.5)),
        "c4": (base - rho * normal, (6.0, 12.5)),
        "c5": (tip + rho * (math.cos(0.6) * axis + math.sin(0.6) * normal), (-7.0, 37.0)),
        "c6": (tip + rho * (math.cos(-0.6) * axis + math.sin(-0.6) * normal), (5.5, 37.0)),
    }
    for name, (point, where) in labels.items():
        ax.plot(*point, "o", color="black", ms=5)
        ax.annotate(name, point, xytext=where, fontsize=12, arrowprops=dict(arrowstyle="->", lw=0.8))
    ax.annotate("", (-8.5, 22.0), xytext=(-4.5, 22.0), arrowprops=dict(arrowstyle="->", lw=1.0))
    ax.text(-8.5, 22.6, "rotor moves", fontsize=8)
    ax.text(-8.7, 9.0, "rotor", fontsize=9)
    ax.text(-1.2, 37.0, "stator", fontsize=9)
    ax.text(-3.6, 10.4, "back chamber p_b", fontsize=8)
    ax.text(-8.7, 30.6, "leading (L)", fontsize=8)
    ax.text(4.2, 30.6, "trailing (T)", fontsize=8)
    ax.set_xlim(-9, 9)
    ax.set_ylim(bottom - 2, 38)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title("Contact regions (rotor frame; clearance and tilt exaggerated)", fontsize=10)
    figure.tight_layout()
    _save(figure, "contact_regions.png")


def _last_revolution(params, revolutions_settle=3):
    sim = Simulation(params, constant_speed(RPM))
    period = 2 * math.pi / (RPM * math.pi / 30)
    sim.advance((revolutions_settle + 1.05) * period)
    history = sim.history
    last = revolutions(sim)[-1]
    rows = np.flatnonzero((history["time"] >= last.start_time) & (history["time"] <= last.end_time))
    return sim, history, slice(rows[0], rows[-1] + 1)


def pressure_figure():
    figure, ax = plt.subplots(figsize=(7, 4.2))
    omega = RPM * math.pi / 30
    for label, changes in (("Level 0 polytropic", dict(pressure_model="polytropic")),
                           ("Level 0.5, c_S = 0", dict()),
                           ("Level 0.5, c_S = 0.05 mm", dict(stator_clearance=5e-5, slot_clearance=5e-5)),
                           ("Level 0.5, c_S = 0.2 mm", dict(stator_clearance=2e-4, slot_clearance=2e-4))):
        p = CompressorParameters(**changes)
        table = leading_pressure_table(p, omega)
        phase = np.linspace(0.0, 360.0 / p.lobes, table.size)
        ax.plot(phase, table / 1e6, label=label)
    p = CompressorParameters(pressure_model="real_gas", slot_clearance=5e-5, stator_clearance=5e-5)
    sim, history, window = _last_revolution(p, revolutions_settle=2)
    angle = history["rotor_angle"][window]
    lobe = 2 * math.pi / p.lobes
    phase = np.degrees(np.mod(angle, lobe))
    order = np.argsort(phase)
    ax.plot(phase[order], history["leading_pressure"][window][order] / 1e6, ".", ms=1.5, color="black",
            label="Level 1 real gas (R134a), c = 0.05 mm, one revolution")
    ax.axhline(p.discharge_pressure / 1e6, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("lobe phase φ [deg] (rotor angle from the valley that opened the lobe)")
    ax.set_ylabel("leading-chamber pressure p_L [MPa]")
    ax.set_title(f"Leading-chamber pressure, z = 3, {RPM:g} rpm (dotted: p_d)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    figure.tight_layout()
    _save(figure, "pressure_tables.png")


def waveform_figure():
    figure, axes = plt.subplots(2, 2, figsize=(11, 6.5), sharex=True)
    for column, clearance in enumerate((0.0, 5e-5)):
        p = CompressorParameters(slot_clearance=clearance, stator_clearance=clearance)
        _, history, window = _last_revolution(p)
        angle = np.degrees(history["rotor_angle"][window] - history["rotor_angle"][window][0])
        ax = axes[0, column]
        ax.plot(angle, history["driving_torque"][window], label="driving torque T_d = −λ6")
        ax.plot(angle, history["stator_contact_moment"][window] + history["stator_gas_moment"][window],
                label="stator moment λ3 + M_gas,stator")
        ax.set_ylabel("[N m]")
        ax.set_title(f"c_R = c_S = {clearance * MM:g} mm, {RPM:g} rpm, z = 3")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        ax = axes[1, column]
        for k in range(1, 7):
            force = history[f"normal_force_{k}"][window]
            if np.max(force) > 0.0:
                ax.plot(angle, force, lw=0.9, label=f"c{k}")
        ax.set_ylabel("normal force [N]")
        ax.set_xlabel("rotor angle over the revolution [deg]")
        ax.legend(fontsize=8, ncol=3)
        ax.grid(alpha=0.3)
    figure.tight_layout()
    _save(figure, "waveforms.png")


def clearance_figure():
    clearances = (0.0, 2e-5, 5e-5, 1e-4, 2e-4)
    rows = []
    for c in clearances:
        p = CompressorParameters(slot_clearance=c, stator_clearance=c)
        sim = Simulation(p, constant_speed(RPM))
        sim.advance(4.02 * 2 * math.pi / (RPM * math.pi / 30))
        last = revolutions(sim)[-1]
        rows.append((c * MM, last.input_power, last.output_power, last.friction_power,
                     100 * last.mechanical_efficiency, len(last.distinct_modes)))
    data = np.array(rows)
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    left.plot(data[:, 0], data[:, 1], "o-", label="⟨P_in⟩")
    left.plot(data[:, 0], data[:, 2], "s-", label="⟨P_out⟩")
    left.plot(data[:, 0], data[:, 3], "^-", label="⟨P_fric⟩")
    left.set_xlabel("clearance c_R = c_S [mm]")
    left.set_ylabel("power [W]")
    left.legend()
    left.grid(alpha=0.3)
    right.plot(data[:, 0], data[:, 4], "o-", color="tab:purple")
    right.set_xlabel("clearance c_R = c_S [mm]")
    right.set_ylabel("mechanical efficiency η_m [%]")
    for x, eta, modes in zip(data[:, 0], data[:, 4], data[:, 5]):
        right.annotate(f"{int(modes)} modes", (x, eta), textcoords="offset points", xytext=(4, 4), fontsize=8)
    right.grid(alpha=0.3)
    figure.suptitle(f"4th revolution at {RPM:g} rpm, z = 3, Level 0.5 table")
    figure.tight_layout()
    _save(figure, "clearance_study.png")
    for row in rows:
        print("c = %.3f mm  P_in %.2f  P_out %.2f  P_fric %.2f  eta %.2f %%  modes %d" % row)


def startup_figure():
    p = CompressorParameters(slot_clearance=5e-5, stator_clearance=5e-5)
    sim = Simulation(p, cycloidal_ramp(RPM, 0.4), initial_angle=0.0)
    sim.advance(0.5)
    h = sim.history
    time, angle = h["time"], h["rotor_angle"]
    omega, theta_ddot = h["rotor_speed"], h["rotor_acceleration"]
    law = law_arguments(p)[:5]
    derivatives = np.array([displacement(a, *law)[1:3] for a in angle])
    nominal = derivatives[:, 1] * omega ** 2 + derivatives[:, 0] * theta_ddot
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    top.plot(time, omega * 30 / math.pi, color="black")
    top.set_ylabel("rotor speed [rpm]")
    top.set_title("Start-up: cycloidal ramp 0 → 1500 rpm over 0.4 s, c_R = c_S = 0.05 mm")
    top.grid(alpha=0.3)
    bottom.plot(time, h["vane_radial_acceleration"], lw=0.5, label="a_r (model)")
    bottom.plot(time, nominal, lw=1.0, color="tab:orange", label="s''ω² + s'θ̈ (nominal law)")
    bottom.set_ylim(-1500, 1500)
    bottom.set_ylabel("radial acceleration [m/s²]")
    bottom.set_xlabel("time [s]")
    bottom.legend(fontsize=8, loc="lower left")
    bottom.grid(alpha=0.3)
    figure.tight_layout()
    _save(figure, "startup.png")


def main():
    geometry_figure()
    contact_regions_figure()
    pressure_figure()
    waveform_figure()
    clearance_figure()
    startup_figure()


if __name__ == "__main__":
    main()
