"""What the time loop reads of the gas, per pressure model (docs/model.md §6.1, §7).

- Level 0 / 0.5 (`polytropic`, `ideal_gas_table`): the p_L(phase) table of mechanics.pressure_source; the chamber
  model gets placeholders it never reads.
- Level 1 (`real_gas`): the operating point (thermo.operating_point: suction state, envelope, ideal-gas k and R of
  the nozzle law, references of the per-revolution figures), the fluid's (T, ln rho) property table for its
  envelope (thermo.property_table) and the chamber model's constants (thermo.chamber_model) with the suction state
  consistent with that table. Both the point and the table are cached on disk; CoolProp is imported only to
  compute what is not cached (docs/model.md §7.1).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rotary_vane.thermo.chamber_model import chamber_constants
from rotary_vane.thermo.gas_reference import GasReference
from rotary_vane.thermo.operating_point import operating_point_for
from rotary_vane.thermo.property_table import PropertyTable, property_table_for, table_arrays, table_properties

from .geometry import lobe_area
from .parameters import CompressorParameters
from .pressure_source import leading_pressure_table


class GasCoupling(NamedTuple):
    """The gas arguments of the time loop and what the figures need."""
    pressure_table: np.ndarray            # p_L(phase) over a lobe (Level 0/0.5), else unused
    properties: tuple                     # thermo.property_table.table_arrays of the fluid (real gas) or a placeholder
    chambers: np.ndarray                  # thermo.chamber_model constants (one-row structured array)
    suction_density: float                # kg/m^3
    reference: object                     # thermo.gas_reference.GasReference (real gas) or None


def _placeholder_properties() -> PropertyTable:
    """A table that refuses every state (status != 0): the Level 0/0.5 runs never query it."""
    return PropertyTable(temperature_min=1.0, temperature_max=2.0, inverse_temperature_step=1.0,
                         log_density_min=0.0, log_density_max=1.0, inverse_log_density_step=1.0,
                         nodes=np.zeros((2, 2, 4, 4)), inverse_dome_step=1.0,
                         dome_log_density_limit=np.full(2, -np.inf), accurate_cell=np.zeros((1, 1), dtype=np.bool_),
                         ideal_gas_exponent=np.ones(2), superheat_margin=1.0, critical_temperature=1.0)


def _constants(p: CompressorParameters, suction_density, suction_enthalpy, heat_capacity_ratio, gas_constant):
    scale = p.tolerance_scale
    return chamber_constants(
        suction_pressure=p.suction_pressure, suction_temperature=p.suction_temperature,
        suction_density=suction_density, suction_enthalpy=suction_enthalpy, discharge_pressure=p.discharge_pressure,
        dead_volume=p.dead_volume, suction_close_angle=p.suction_close_angle, suction_port_area=p.suction_port_area,
        suction_port_coefficient=p.suction_port_coefficient, discharge_port_area=p.discharge_port_area,
        discharge_port_coefficient=p.discharge_port_coefficient, leak_coefficient=p.leak_coefficient,
        valley_leak_area=p.stator_clearance * p.axial_length, axial_length=p.axial_length,
        nozzle_heat_capacity_ratio=heat_capacity_ratio, nozzle_gas_constant=gas_constant,
        atol_temperature=1e-4 * scale, atol_mass=1e-12 * scale, atol_energy=1e-6 * scale)


def gas_coupling(params: CompressorParameters, operating_speed: float) -> GasCoupling:
    """The GasCoupling of the parameters' pressure model; `operating_speed` [rad/s] is the Level 0.5 table's speed."""
    p = params
    if p.pressure_model != "real_gas":
        density = p.suction_pressure / (p.gas_constant * p.suction_temperature)
        enthalpy = p.heat_capacity_ratio * p.gas_constant / (p.heat_capacity_ratio - 1.0) * p.suction_temperature
        return GasCoupling(leading_pressure_table(p, operating_speed), table_arrays(_placeholder_properties()),
                           _constants(p, density, enthalpy, p.heat_capacity_ratio, p.gas_constant), density, None)
    point = operating_point_for(p.fluid, p.suction_pressure, p.suction_temperature, p.discharge_pressure)
    table = property_table_for(point, point.envelope)
    enthalpy = table_properties(p.suction_temperature, point.suction_density, table)[1]
    reference = GasReference(point, p.lobes * p.axial_length * lobe_area(p))
    return GasCoupling(np.zeros(2), table_arrays(table),
                       _constants(p, point.suction_density, enthalpy, point.ideal_gas_exponent, point.gas_constant),
                       point.suction_density, reference)
