"""The constants the compiled time loop reads: geometry, mass properties, contact and numerics (docs/model.md §2, §5, §8).

They form one numpy record (`MACHINE_DTYPE`, all float64, choices as their integer codes), derived from validated
`CompressorParameters` and never edited by hand. A record crosses into numba as cheaply as any array (a named
tuple of 45 floats costs about 6 us per call to unbox), and numba reads its fields by name.
"""
import math
from typing import NamedTuple

import numpy as np

from ..geometry.chamber_geometry import sector_integral, sector_table
from ..contact.contact_laws import HERTZ_POINT, hertz_stiffness, line_contact_constants
from ..geometry.displacement import DISPLACEMENT_LAWS
from ..parameters import FRICTION_MODELS, INTEGRATORS, PRESSURE_MODELS, STIFFNESS_MODELS, CompressorParameters
from ...kernels.kernel import kernel_record


class VaneMassProperties(NamedTuple):
    mass: float                    # m3 [kg]
    inertia: float                 # J3 about the centre of mass [kg m2]
    centre_of_mass: float          # xi_G: CG position along the axis from the tip centre T (negative) [m]


def vane_mass_properties(vane_thickness, vane_length, axial_length, density) -> VaneMassProperties:
    """Stadium-ended vane: rectangle t x l_r plus half disc of radius rho = t/2 (docs/model.md §2.1).

    A_r = t l_r, xi_r = -l_r/2;  A_s = pi rho^2/2, xi_s = 4 rho/(3 pi);  xi_G = (A_r xi_r + A_s xi_s)/(A_r + A_s)
    m3 = rho_s L (A_r + A_s)
    J3 = rho_s L [A_r (t^2 + l_r^2)/12 + A_r (xi_r - xi_G)^2 + (pi rho^4/4 - A_s xi_s^2) + A_s (xi_s - xi_G)^2]
    """
    tip_radius = 0.5 * vane_thickness
    straight_length = vane_length - tip_radius
    area_rect = vane_thickness * straight_length
    xi_rect = -0.5 * straight_length
    area_half_disc = 0.5 * math.pi * tip_radius ** 2
    xi_half_disc = 4.0 * tip_radius / (3.0 * math.pi)
    xi_g = (area_rect * xi_rect + area_half_disc * xi_half_disc) / (area_rect + area_half_disc)
    mass = density * axial_length * (area_rect + area_half_disc)
    second_moment = (area_rect * (vane_thickness ** 2 + straight_length ** 2) / 12.0
                     + area_rect * (xi_rect - xi_g) ** 2
                     + (math.pi * tip_radius ** 4 / 4.0 - area_half_disc * xi_half_disc ** 2)
                     + area_half_disc * (xi_half_disc - xi_g) ** 2)
    return VaneMassProperties(mass, density * axial_length * second_moment, xi_g)


def effective_modulus(youngs_modulus, poisson_ratio) -> float:
    """E* with 1/E* = (1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j, same material on both sides (docs/model.md §5.2)."""
    return youngs_modulus / (2.0 * (1.0 - poisson_ratio ** 2))


def contact_period(m) -> float:
    """T_c = 2 pi sqrt(m3 / k) of the vane on a slot edge (R* = r_e) at the representative load F = (p_d - p_s) h L,
    the gas force on the vane's exposed face, with k = dF/d delta of the machine's stiffness law (docs/model.md
    §8.3). `m`: the machine record."""
    load = (m.discharge_pressure - m.suction_pressure) * m.stroke * m.axial_length
    if m.stiffness_model == HERTZ_POINT:              # F = K delta^1.5: k = 1.5 K^(2/3) F^(1/3)
        stiffness = 1.5 * hertz_stiffness(1.0 / m.edge_radius, 0.0, m.effective_modulus) ** (2.0 / 3.0) \
            * load ** (1.0 / 3.0)
    else:                                             # delta = F (A - B ln F): 1/k = A - B ln F - B (>= B)
        a, b = line_contact_constants(1.0 / m.edge_radius, 0.0, m)
        stiffness = 1.0 / max(a - b * math.log(load) - b, b)
    return 2.0 * math.pi * math.sqrt(m.vane_mass / stiffness)


# (field, meaning): every constant the mechanics kernels read, all float64; choices as integer codes
MACHINE_FIELDS = (
    ("lobes", "z"), ("law", "displacement law code"), ("stroke", "h [m]"), ("bottom_dwell", "beta0 [rad]"),
    ("top_dwell", "beta1 [rad]"), ("rotor_radius", "R_r [m]"), ("base_radius", "R0 [m]"),
    ("tip_radius", "rho [m]"), ("half_thickness", "t/2 [m]"), ("half_slot_width", "w/2 [m]"),
    ("mouth_radius", "R_m [m]"), ("slot_bottom_radius", "r_sb [m]"), ("stator_clearance", "c_S [m]"),
    ("envelope_offset", "d = rho + c_S [m]"), ("axial_length", "L [m]"),
    ("tip_centre", "xi_T, vane frame with origin at G [m]"), ("bottom_face", "xi_B, vane frame [m]"),
    ("vane_mass", "m3 [kg]"), ("vane_inertia", "J3 [kg m2]"), ("rotor_inertia", "J2 [kg m2]"),
    ("edge_radius", "[m]"), ("effective_modulus", "E* [Pa]"),
    ("compliance", "(1 - nu^2)/E of one body, line-contact law [1/Pa]"), ("stiffness_model", "code"),
    ("restitution", "c_e"), ("onset_velocity_floor", "[m/s]"), ("friction_model", "code"),
    ("friction_coefficient", "mu"), ("friction_velocity", "v_0 [m/s]"), ("friction_velocity_full", "v_1 [m/s]"),
    ("suction_pressure", "p_s [Pa]"), ("discharge_pressure", "p_d, also the back chamber [Pa]"),
    ("dead_volume", "V_dead, added to both chamber volumes [m3]"),
    ("pressure_model", "code"), ("integrator", "code"), ("relative_tolerance", "rtol"),
    ("atol_position", "[m]"), ("atol_angle", "[rad]"), ("atol_velocity", "[m/s]"),
    ("atol_angular_velocity", "[rad/s]"), ("atol_work", "[J]"), ("max_step", "[s]"),
    ("contact_period", "T_c of docs/model.md §8.3, the time scale of the smallest step [s]"),
    ("stator_lobe_integral", "int (1/2 r^2 + d N) du over a lobe (mechanics.geometry.chamber_geometry) [m2]"),
)
MACHINE_DTYPE = np.dtype([(name, np.float64) for name, _ in MACHINE_FIELDS])


def machine_array(p: CompressorParameters) -> np.ndarray:
    """The kernel constants of validated parameters as a one-row structured array (docs/model.md §2.1, §2.2, §5.2,
    §8.2): numba reads its fields by name (`m = machine[0]; m.stroke`) and passes it at the cost of an array (a
    numpy recarray costs five times more to pass, so the kernels get the plain array)."""
    vane = vane_mass_properties(p.vane_thickness, p.vane_length, p.axial_length, p.vane_density)
    tip_centre = -vane.centre_of_mass
    scale = p.tolerance_scale
    values = dict(
        lobes=float(p.lobes), law=float(DISPLACEMENT_LAWS.code(p.displacement_law, "displacement_law")),
        stroke=p.stroke,
        bottom_dwell=p.bottom_dwell, top_dwell=p.top_dwell, rotor_radius=p.rotor_radius,
        base_radius=p.base_radius, tip_radius=p.tip_radius, half_thickness=0.5 * p.vane_thickness,
        half_slot_width=0.5 * p.slot_width, mouth_radius=p.mouth_radius, slot_bottom_radius=p.slot_bottom_radius,
        stator_clearance=p.stator_clearance, envelope_offset=p.envelope_offset, axial_length=p.axial_length,
        tip_centre=tip_centre, bottom_face=tip_centre - (p.vane_length - p.tip_radius),
        vane_mass=vane.mass, vane_inertia=vane.inertia, rotor_inertia=p.rotor_inertia,
        edge_radius=p.edge_radius, effective_modulus=effective_modulus(p.youngs_modulus, p.poisson_ratio),
        compliance=(1.0 - p.poisson_ratio ** 2) / p.youngs_modulus,
        stiffness_model=float(STIFFNESS_MODELS.code(p.stiffness_model, "stiffness_model")),
        restitution=p.restitution,
        onset_velocity_floor=p.onset_velocity_floor,
        friction_model=float(FRICTION_MODELS.code(p.friction_model, "friction_model")),
        friction_coefficient=p.friction_coefficient, friction_velocity=p.friction_velocity,
        friction_velocity_full=p.friction_velocity_full,
        suction_pressure=p.suction_pressure, discharge_pressure=p.discharge_pressure, dead_volume=p.dead_volume,
        pressure_model=float(PRESSURE_MODELS.code(p.pressure_model, "pressure_model")),
        integrator=float(INTEGRATORS.code(p.integrator, "integrator")), relative_tolerance=p.relative_tolerance,
        atol_position=1e-9 * scale, atol_angle=1e-8 * scale, atol_velocity=1e-6 * scale,
        atol_angular_velocity=1e-4 * scale, atol_work=1e-6 * scale,
        max_step=p.max_step, contact_period=math.nan,
        stator_lobe_integral=math.nan)
    machine = np.zeros(1, dtype=MACHINE_DTYPE)
    for name, value in values.items():
        machine[name] = value
    machine["stator_lobe_integral"] = 2.0 * sector_integral(math.pi / p.lobes, sector_table(record_of(machine)))
    machine["contact_period"] = contact_period(record_of(machine))
    return kernel_record(machine)


def record_of(array: np.ndarray):
    """Row 0 of a one-row structured array as a record whose fields read as attributes in Python (`m.stroke`) as in
    numba; a view, not a copy."""
    return array.view(np.recarray)[0]


def machine_from_parameters(p: CompressorParameters):
    """The kernel constants as one record (fields by name, in Python and in numba), e.g. for calling a kernel
    function directly; the time loop takes `machine_array`."""
    return record_of(machine_array(p))


REAL_GAS_MODEL = float(PRESSURE_MODELS.codes("real_gas")[0])
DOPRI5, ABM4, ARK548 = (float(code) for code in INTEGRATORS.codes("dopri5", "abm4", "ark548"))
