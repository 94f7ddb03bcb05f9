"""The chamber pressure source of the Level 0 and Level 0.5 models (docs/model.md §6.1, §6.5, §7.5).

Both levels give the leading-chamber pressure as a table p_L(phi) over one lobe, built once per operating point
by `thermo` from the thin-vane chamber volume of docs/model.md §6.5; the time loop interpolates it.
"""
import math

import numpy as np

from ...thermo import ideal_gas_pressure_table, polytropic_pressure_table

from ..geometry.displacement import displacement_on_grid
from ..geometry.stator import law_arguments

TABLE_POINTS = 20001          # 20000 intervals over the lobe, docs/model.md §7.5


def thin_vane_volume(params, phase):
    """Leading-chamber volume and its derivative on a phase grid starting at the valley (docs/model.md §6.5):

    V(phi) = L int_phi^{2 pi/z} 1/2 ((R_r + s)^2 - R_r^2) dphi' + V_dead,   dV/dphi = -L 1/2 ((R_r + s)^2 - R_r^2)
    The integral is taken with the composite trapezoidal rule on the (fine, uniform) grid.
    """
    law, stroke, lobes, bottom_dwell, top_dwell, _ = law_arguments(params)
    stroke_values = displacement_on_grid(phase, law, stroke, lobes, bottom_dwell, top_dwell)
    derivative = -0.5 * params.axial_length * ((params.rotor_radius + stroke_values) ** 2
                                               - params.rotor_radius ** 2)
    steps = np.diff(phase)
    remaining = np.concatenate([np.cumsum((0.5 * steps * (derivative[1:] + derivative[:-1]))[::-1])[::-1], [0.0]])
    return -remaining + params.dead_volume, derivative


def leading_pressure_table(params, angular_speed):
    """p_L on TABLE_POINTS uniform phases over [0, 2 pi/z] for the chosen pressure model (docs/model.md §6.1).

    Level 0.5 depends on the speed; for a varying speed the table is built at `angular_speed` (the operating
    speed of the run) and held.
    """
    phase = np.linspace(0.0, 2.0 * math.pi / params.lobes, TABLE_POINTS)
    volume, volume_derivative = thin_vane_volume(params, phase)
    if params.pressure_model == "polytropic":
        return polytropic_pressure_table(phase, volume, params.suction_pressure, params.discharge_pressure,
                                         params.suction_close_angle, params.polytropic_exponent)
    return ideal_gas_pressure_table(
        phase, volume, volume_derivative, angular_speed, params.suction_pressure, params.suction_temperature,
        params.discharge_pressure, params.suction_close_angle, params.stator_clearance * params.axial_length,
        0.0 if params.end_valley_leak_law == "sealed" else params.end_valley_leak_coefficient,
        params.discharge_port_area, params.discharge_port_coefficient,
        params.heat_capacity_ratio, params.gas_constant)
