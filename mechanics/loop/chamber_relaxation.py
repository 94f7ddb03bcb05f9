"""The stiff mode of a small chamber open to the suction port, for the run-cost estimate (docs/model.md §8.3).

A chamber of volume V open to the suction plenum through the port (area A_port, discharge coefficient C_d) relaxes
on p_s with the rate lambda = (dp/dm)_V d(m_dot)/dp: for gas entering at the chamber's own state (dp/dm)_V = c^2/V
(c the speed of sound), and the port is the nozzle law of docs/model.md §7.4 with its linear band (relative
pressure difference eps = thermo.control_volume.LINEAR_FLOW_BAND). Its largest slope, inside the band, is

    d(m_dot)/dp = C_d A G_eps/(eps p) = C_d A sqrt(2 rho/(eps p))     (G_eps^2 = 2 rho eps p, Bernoulli),

so lambda_max = C_d A c sqrt(2 kappa/eps)/V with kappa = rho c^2/p (`suction_sound`). Outside the
band the slope of G ~ sqrt(2 rho dp) is (C_d A)^2 rho/m_dot; a chamber that grows at dV/dt draws m_dot = rho dV/dt
through the port, so its slope is (C_d A)^2/(dV/dt): a chamber that hardly grows (the new trailing chamber in a
bottom dwell, docs/model.md §2.3) settles inside the band, where the slope is largest, a growing one does not. The
slope used is the smaller of the two.

The trailing chamber holds the share phi/phi_sc of the port (thermo.control_volume.port_coverage: the port spans
the lobe phases [0, phi_sc]) and the leading chamber the rest; V is the chamber's geometric volume
(mechanics.geometry.chamber_geometry, the untilted vane on its nominal path at c_S off the stator, as
mechanics.simulation's valley check places it) plus the dead volume. An explicit method keeps h lambda within its
stability reach on the negative real axis (`STABILITY_REACH`), so over a lobe the chambers ask for
int lambda/reach dt steps, (z/2 pi) int_0^{2 pi/z} lambda(phi)/reach dphi per second at any speed. Only the real-gas
model integrates chamber states (Level 0 and 0.5 interpolate a pressure table), and ark548 integrates them
implicitly, so the rate is zero for those.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..geometry.chamber_geometry import sector_table
from ..geometry.displacement import displacement_on_grid
from ..geometry.stator import law_arguments
from ..parameters import CompressorParameters
from ...thermo.control_volume import LINEAR_FLOW_BAND
from ...thermo.operating_point import operating_point_for
from .dynamics import chamber_geometry_of
from .integrators import STABILITY_LIMIT
from .machine import machine_from_parameters

# h |lambda| an explicit method keeps on the negative real axis: DOPRI5 its stability cap (docs/model.md §8.2),
# ABM4 PECE its real-axis boundary (docs/model.md §8.3); ark548 treats the chambers implicitly (no bound)
STABILITY_REACH = {"dopri5": STABILITY_LIMIT, "abm4": 1.28}
LOBE_SAMPLES = 501            # phases over a lobe (1/500 lobe): within 1.3e-4 of 2001 on the 26 real-gas cases checked
GROWTH_STEP = 1e-4            # the central difference of dV/dphi, in lobes
# the least volume the real-gas model lets a chamber have at the valley (mechanics.simulation's valley check)
VALLEY_VOLUME_SHARE = 0.25


def suction_sound(params: CompressorParameters) -> tuple[float, float]:
    """(c [m/s], kappa = rho c^2/p) of the suction gas from its operating point (thermo.operating_point, cached on
    disk: no CoolProp import)."""
    point = operating_point_for(params.fluid, params.suction_pressure, params.suction_temperature,
                                params.discharge_pressure)
    sound = point.suction_sound_speed
    return sound, point.suction_density * sound ** 2 / params.suction_pressure


def nominal_chamber_volumes(params: CompressorParameters, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(V_L, V_T) geometric volumes [m^3] (no dead volume) of the lobe starting at angle 0 with the untilted vane at
    rotor angle `phase`, its tip centre on the nominal path R0 + s + c_S, centred in its slot."""
    machine = machine_from_parameters(params)
    table = sector_table(machine)
    stroke = displacement_on_grid(phase, *law_arguments(params)[:5])
    radius = params.base_radius + stroke + params.stator_clearance - machine.tip_centre
    volumes = np.array([chamber_geometry_of(r * math.cos(a), r * math.sin(a), a, 0.0, 0.0, 0.0, a, 1.0, 0.0,
                                            machine, table)[:2] for r, a in zip(radius, phase)])
    return volumes[:, 0], volumes[:, 1]


def relaxation_step_rates(params: CompressorParameters, rpm: float, phase: np.ndarray) -> np.ndarray:
    """Steps per second [1/s] the two chambers' relaxation through the suction port asks of the explicit method at
    each lobe phase (rotor angle from the start valley, increasing, [0, 2 pi/z]) at `rpm` (module docstring): the
    sum over both chambers of lambda/reach; zeros where no chamber state is integrated explicitly."""
    reach = STABILITY_REACH.get(params.integrator)
    if params.pressure_model != "real_gas" or reach is None or not rpm > 0.0:
        return np.zeros_like(phase)
    omega = rpm * math.pi / 30.0
    sound, kappa = suction_sound(params)
    trailing_share = np.clip(phase / params.suction_close_angle, 0.0, 1.0) if params.suction_close_angle > 0.0 \
        else np.ones_like(phase)
    lobe = 2.0 * math.pi / params.lobes
    before = np.clip(phase - GROWTH_STEP * lobe, 0.0, lobe)
    after = np.clip(phase + GROWTH_STEP * lobe, 0.0, lobe)
    rates = np.zeros_like(phase)
    for share, geometric, first, last in zip((1.0 - trailing_share, trailing_share),
                                             nominal_chamber_volumes(params, phase),
                                             nominal_chamber_volumes(params, before),
                                             nominal_chamber_volumes(params, after)):
        volume = np.maximum(geometric + params.dead_volume, VALLEY_VOLUME_SHARE * params.dead_volume)
        growth = np.abs(last - first) / (after - before) * omega                  # |dV/dt| [m^3/s]
        conductance = params.suction_port_coefficient * params.suction_port_area * share
        in_band = conductance * sound * math.sqrt(2.0 * kappa / LINEAR_FLOW_BAND) / volume
        filling = np.divide(conductance ** 2 * sound ** 2 / volume, growth, out=np.full_like(volume, np.inf),
                            where=growth > 0.0)
        rates += np.minimum(in_band, filling) / reach
    return rates


@functools.lru_cache(maxsize=64)
def chamber_relaxation_rate(params: CompressorParameters, rpm: float) -> float:
    """Steps per simulated second over whole lobes at `rpm` (module docstring): the lobe average of
    `relaxation_step_rates`. Kept for the last 64 (params, rpm): every Simulation asks for it at construction
    (mechanics.loop.run_cost.slow_run_notice), and its 1500 chamber volumes take about 0.03 s."""
    lobe = 2.0 * math.pi / params.lobes
    phase = np.linspace(0.0, lobe, LOBE_SAMPLES)
    rates = relaxation_step_rates(params, rpm, phase)
    return float(np.sum(0.5 * (rates[1:] + rates[:-1]) * np.diff(phase))) / lobe
