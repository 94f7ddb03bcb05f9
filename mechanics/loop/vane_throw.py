"""A vane thrown off its profile and the impact that ends its flight, said before any work (docs/model.md §8.3).

Only the stator pushes the vane in; what pulls it out is the centrifugal force and the back-chamber pressure. Where
the profile asks for more outward acceleration than they give, the vane leaves the stator on its way in:

    lift ratio  Lambda = max over a lobe of  s'' omega^2 / (omega^2 (R0 + s) + (p_d - p_s) t L / m3)  > 1

(the net gas push on the vane taken at its largest, p_d behind and p_s at the tip). Such a vane is thrown onto the
slot bottom or back onto the stator at up to the profile's radial speed v_r = max |s'| omega. The impact is taken on
a bottom corner, the Hertz point contact of the slot-bottom regions (R* = r_e, §4.4b, §5.2: K = 4/3 E* sqrt(r_e)):
the vane's kinetic energy m3 v_r^2 / 2 stored at the largest penetration gives

    delta_i = (5 m3 v_r^2 / (4 K))^(2/5),   F_i = K delta_i^(3/2),   t_i = 2.94 delta_i / v_r  (its duration),

the classical Hertz impact of a mass on an elastic half-space (Johnson 1985, ch. 11).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .machine import effective_modulus, vane_mass_properties
from ..contact.contact_laws import hertz_stiffness
from ..geometry.stator import lobe_profile

HERTZ_IMPACT_DURATION = 2.94     # t_i v / delta_max for a Hertz impact without damping (Johnson 1985, ch. 11)


class VaneThrow(NamedTuple):
    lift_ratio: float       # Lambda of the module docstring; > 1: the vane leaves the stator
    radial_speed: float     # v_r = max |s'| omega [m/s]
    impact_force: float     # F_i [N]
    impact_time: float      # t_i [s]


def vane_throw(params, rpm: float) -> VaneThrow:
    """The lift ratio and the impact of a thrown vane at `rpm` (module docstring)."""
    if not rpm > 0.0:
        return VaneThrow(0.0, 0.0, 0.0, 0.0)
    omega = rpm * math.pi / 30.0
    mass = vane_mass_properties(params.vane_thickness, params.vane_length, params.axial_length,
                                params.vane_density).mass
    s, slope, curvature = lobe_profile(params)
    gas_push = (params.discharge_pressure - params.suction_pressure) * params.vane_thickness * params.axial_length
    lift_ratio = float(np.max(curvature * omega ** 2 / (omega ** 2 * (params.base_radius + s) + gas_push / mass)))
    speed = float(np.max(np.abs(slope))) * omega
    if speed == 0.0:
        return VaneThrow(lift_ratio, 0.0, 0.0, 0.0)
    stiffness = hertz_stiffness(1.0 / params.edge_radius, 0.0,
                                effective_modulus(params.youngs_modulus, params.poisson_ratio))
    penetration = (5.0 * mass * speed ** 2 / (4.0 * stiffness)) ** 0.4
    return VaneThrow(lift_ratio, speed, stiffness * penetration ** 1.5,
                     HERTZ_IMPACT_DURATION * penetration / speed)
