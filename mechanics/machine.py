"""The constants the compiled time loop reads: geometry, mass properties, contact and numerics (docs/model.md §2, §5, §8).

`Machine` is a flat named tuple of floats (numba passes it by value, with named fields); choices are stored as
their integer codes. It is derived from validated `CompressorParameters` and never edited by hand.
"""
import math
from typing import NamedTuple

from .chambers import stator_lobe_integral
from .displacement import LAW_CODES
from .parameters import FRICTION_MODELS, INTEGRATORS, PRESSURE_MODELS, STIFFNESS_MODELS, CompressorParameters


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


class Machine(NamedTuple):
    lobes: float
    law: float
    stroke: float
    bottom_dwell: float
    top_dwell: float
    rotor_radius: float
    base_radius: float            # R0
    tip_radius: float             # rho
    half_thickness: float         # t/2
    half_slot_width: float        # w/2
    mouth_radius: float           # R_m
    slot_bottom_radius: float
    stator_clearance: float       # c_S
    envelope_offset: float        # d
    axial_length: float           # L
    tip_centre: float             # xi_T, vane frame (origin at G)
    bottom_face: float            # xi_B, vane frame
    vane_mass: float
    vane_inertia: float
    rotor_inertia: float
    edge_radius: float
    effective_modulus: float      # E*
    compliance: float             # (1 - nu^2)/E of one body, for the line-contact law
    stiffness_model: float
    restitution: float
    onset_velocity_floor: float
    friction_model: float
    friction_coefficient: float
    friction_velocity: float
    friction_velocity_full: float
    suction_pressure: float
    discharge_pressure: float
    relative_tolerance: float
    atol_position: float
    atol_angle: float
    atol_velocity: float
    atol_angular_velocity: float
    atol_work: float
    min_step: float
    max_step: float
    max_onset_penetration: float
    # chamber gas (docs/model.md §7; Level 1 uses the fluid's values, the tables the ideal-gas parameters)
    pressure_model: float
    suction_temperature: float
    suction_density: float
    suction_enthalpy: float
    dead_volume: float
    suction_close_angle: float
    suction_port_area: float
    suction_port_coefficient: float
    discharge_port_area: float
    discharge_port_coefficient: float
    leak_coefficient: float
    nozzle_heat_capacity_ratio: float
    nozzle_gas_constant: float
    atol_temperature: float
    atol_density: float
    atol_mass: float
    stator_lobe_integral: float   # int (1/2 r^2 + d N) du over a lobe (mechanics.chambers), m^2


class SuctionGas(NamedTuple):
    """What the kernels need of the working fluid: suction density and enthalpy (consistent with the property
    table under Level 1), and the ideal-gas k and R of the nozzle law (docs/model.md §7.4)."""
    density: float
    enthalpy: float
    heat_capacity_ratio: float
    gas_constant: float


def ideal_suction_gas(p: CompressorParameters) -> SuctionGas:
    """The Level 0.5 ideal gas (k, R parameters) at the suction state; enthalpy c_p T_s."""
    return SuctionGas(p.suction_pressure / (p.gas_constant * p.suction_temperature),
                      p.heat_capacity_ratio * p.gas_constant / (p.heat_capacity_ratio - 1.0) * p.suction_temperature,
                      p.heat_capacity_ratio, p.gas_constant)


def machine_from_parameters(p: CompressorParameters, gas: SuctionGas | None = None) -> Machine:
    """Derive the kernel constants from validated parameters (docs/model.md §2.1, §2.2, §5.2, §7, §8.2); `gas` defaults to
    the ideal gas of the parameters."""
    gas = gas or ideal_suction_gas(p)
    vane = vane_mass_properties(p.vane_thickness, p.vane_length, p.axial_length, p.vane_density)
    tip_centre = -vane.centre_of_mass
    scale = p.tolerance_scale
    machine = Machine(
        lobes=float(p.lobes), law=float(LAW_CODES[p.displacement_law]), stroke=p.stroke,
        bottom_dwell=p.bottom_dwell, top_dwell=p.top_dwell, rotor_radius=p.rotor_radius,
        base_radius=p.base_radius, tip_radius=p.tip_radius, half_thickness=0.5 * p.vane_thickness,
        half_slot_width=0.5 * p.slot_width, mouth_radius=p.mouth_radius, slot_bottom_radius=p.slot_bottom_radius,
        stator_clearance=p.stator_clearance, envelope_offset=p.envelope_offset, axial_length=p.axial_length,
        tip_centre=tip_centre, bottom_face=tip_centre - (p.vane_length - p.tip_radius),
        vane_mass=vane.mass, vane_inertia=vane.inertia, rotor_inertia=p.rotor_inertia,
        edge_radius=p.edge_radius, effective_modulus=effective_modulus(p.youngs_modulus, p.poisson_ratio),
        compliance=(1.0 - p.poisson_ratio ** 2) / p.youngs_modulus,
        stiffness_model=float(STIFFNESS_MODELS.index(p.stiffness_model)), restitution=p.restitution,
        onset_velocity_floor=p.onset_velocity_floor,
        friction_model=float(FRICTION_MODELS.index(p.friction_model)),
        friction_coefficient=p.friction_coefficient, friction_velocity=p.friction_velocity,
        friction_velocity_full=p.friction_velocity_full,
        suction_pressure=p.suction_pressure, discharge_pressure=p.discharge_pressure,
        relative_tolerance=p.relative_tolerance, atol_position=1e-9 * scale, atol_angle=1e-8 * scale,
        atol_velocity=1e-6 * scale, atol_angular_velocity=1e-4 * scale, atol_work=1e-6 * scale,
        min_step=p.min_step, max_step=p.max_step, max_onset_penetration=p.max_onset_penetration,
        pressure_model=float(PRESSURE_MODELS.index(p.pressure_model)), suction_temperature=p.suction_temperature,
        suction_density=gas.density, suction_enthalpy=gas.enthalpy, dead_volume=p.dead_volume,
        suction_close_angle=p.suction_close_angle, suction_port_area=p.suction_port_area,
        suction_port_coefficient=p.suction_port_coefficient, discharge_port_area=p.discharge_port_area,
        discharge_port_coefficient=p.discharge_port_coefficient, leak_coefficient=p.leak_coefficient,
        nozzle_heat_capacity_ratio=gas.heat_capacity_ratio, nozzle_gas_constant=gas.gas_constant,
        atol_temperature=1e-4 * scale, atol_density=1e-6 * scale, atol_mass=1e-12 * scale,
        stator_lobe_integral=math.nan)
    return machine._replace(stator_lobe_integral=stator_lobe_integral(machine))


INTEGRATOR_CODES = {name: i for i, name in enumerate(INTEGRATORS)}
PRESSURE_MODEL_CODES = {name: i for i, name in enumerate(PRESSURE_MODELS)}
REAL_GAS_MODEL = float(PRESSURE_MODEL_CODES["real_gas"])
