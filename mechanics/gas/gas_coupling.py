"""What the time loop reads of the gas, per pressure model (docs/model.md §6.1, §7).

- Level 0 / 0.5 (`polytropic`, `ideal_gas_table`): the p_L(phase) table of mechanics.gas.pressure_source; the chamber
  model gets placeholders it never reads.
- Level 1 (`real_gas`): the operating point (thermo.operating_point: suction state, h_2s, references of the
  per-revolution figures), the fluid's (T, ln rho) property table and its real-gas nozzle table, and the chamber
  model's constants (thermo.chamber_model): the suction state and the discharge plenum and back chamber at p_d on
  the suction isentrope, both solved on the property table (thermo.boundary_states), the valley seal's
  friction-equivalent length and each leakage path's law and coefficient (docs/model.md §7.4). The tables are the
  fluid's fluid-wide ones with the dome on (thermo.fluid_envelope) when the fluid has a declared input range that
  holds the operating point, so that the boundary can move within that range during the run; else those of the
  point's envelope. The point and the tables are cached on disk; CoolProp is imported only to compute what is not
  cached (docs/model.md §7.1).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...thermo.chamber_model import chamber_constants, chamber_flow_work
from ...thermo.gas_reference import GasReference
from ...thermo.flow_paths import FlowNode
from ...thermo.leakage import LEAKAGE_LAWS
from ...thermo.boundary_states import boundary_states, describe_boundary_status
from ...thermo.fluid_envelope import InputRange, fluid_range_for, fluid_tables_for
from ...thermo.operating_point import operating_point_for
from ...thermo.property_table import PropertyTable, property_table_for, table_arrays
from ...thermo.real_gas_nozzle import (STATUS_THROAT_NEAR_SATURATION, NozzleTable, describe_nozzle_status,
                                       nozzle_table_arrays, nozzle_table_for, real_gas_mass_flux)

from ..geometry.stator import lobe_area, valley_seal_length
from ..parameters import CompressorParameters
from .pressure_source import leading_pressure_table


class GasCoupling(NamedTuple):
    """The gas arguments of the time loop and what the figures need."""
    pressure_table: np.ndarray            # p_L(phase) over a lobe (Level 0/0.5), else unused
    properties: tuple                     # thermo.property_table.table_arrays of the fluid (real gas) or a placeholder
    nozzles: tuple                        # thermo.real_gas_nozzle.nozzle_table_arrays (real gas) or a placeholder
    chambers: np.ndarray                  # thermo.chamber_model constants (one-row structured array)
    flow_work: np.ndarray                 # the flow network's working values (thermo.chamber_model.chamber_flow_work)
    suction_density: float                # kg/m^3
    reference: object                     # thermo.gas_reference.GasReference (real gas) or None
    input_range: object = None            # thermo.fluid_envelope.InputRange the tables cover, None: a fixed point


def _placeholder_properties() -> PropertyTable:
    """A table that refuses every state (status != 0): the Level 0/0.5 runs never query it."""
    return PropertyTable(temperature_min=1.0, temperature_max=2.0, inverse_temperature_step=1.0,
                         log_density_min=0.0, log_density_max=1.0, inverse_log_density_step=1.0,
                         nodes=np.zeros((2, 2, 4, 4)), inverse_dome_step=1.0,
                         dome_log_density_limit=np.full(2, -np.inf), accurate_cell=np.zeros((1, 1), dtype=np.bool_),
                         ideal_gas_exponent=np.ones(2), superheat_margin=1.0, critical_temperature=1.0)


def _placeholder_nozzles() -> NozzleTable:
    """A nozzle table that refuses every state: the Level 0/0.5 runs never query it."""
    return NozzleTable(temperature_min=1.0, temperature_max=2.0, inverse_temperature_step=1.0, log_density_min=0.0,
                       log_density_max=1.0, inverse_log_density_step=1.0, inverse_sigma_step=1.0,
                       inverse_dome_step=1.0, superheat_margin=1.0, critical_ratio=np.zeros((2, 2)),
                       choked_flux_factor=np.zeros((2, 2)), shape_factor=np.zeros((2, 2, 2)),
                       throat_superheat=np.zeros((2, 2, 2)), viscosity=np.zeros((2, 2)),
                       dome_log_density_limit=np.full(2, -np.inf), accurate_cell=np.zeros((1, 1), dtype=np.bool_))


def _law(p: CompressorParameters, name: str) -> int:
    """The thermo.leakage code of the leakage law parameter `name`."""
    return LEAKAGE_LAWS.code(getattr(p, name), name)


def _constants(p: CompressorParameters, suction: FlowNode, discharge: FlowNode, valley_flow_length):
    """The chamber model's constants: the boundary states, and the values the flow paths' rows name
    (thermo.flow_paths.FLOW_PATHS)."""
    scale = p.tolerance_scale
    return chamber_constants(
        suction_pressure=suction.pressure, suction_temperature=suction.temperature, suction_density=suction.density,
        suction_enthalpy=suction.enthalpy, discharge_pressure=discharge.pressure,
        discharge_temperature=discharge.temperature, discharge_density=discharge.density,
        discharge_enthalpy=discharge.enthalpy, dead_volume=p.dead_volume, suction_close_angle=p.suction_close_angle,
        suction_port_area=p.suction_port_area, suction_port_coefficient=p.suction_port_coefficient,
        discharge_port_area=p.discharge_port_area, discharge_port_coefficient=p.discharge_port_coefficient,
        axial_length=p.axial_length, valley_gap=p.stator_clearance, valley_flow_length=valley_flow_length,
        end_valley_law=_law(p, "end_valley_leak_law"), end_valley_coefficient=p.end_valley_leak_coefficient,
        start_valley_law=_law(p, "start_valley_leak_law"), start_valley_coefficient=p.start_valley_leak_coefficient,
        tip_law=_law(p, "tip_leak_law"), tip_coefficient=p.tip_leak_coefficient,
        slot_law=_law(p, "slot_leak_law"), slot_coefficient=p.slot_leak_coefficient,
        atol_temperature=1e-4 * scale, atol_mass=1e-12 * scale, atol_energy=1e-6 * scale)


def _check_nozzle_inlet(name: str, value, state: FlowNode, table: NozzleTable, where: str):
    """Refuse, before any work, a boundary state that is upstream of a flow path but that the nozzle table refuses
    (status 1-7; 8, a metastable throat, is accepted as in the loop, docs/model.md §7.4)."""
    status = real_gas_mass_flux(state.temperature, state.density, state.pressure, 0.5 * state.pressure, table)[1]
    if status not in (0, STATUS_THROAT_NEAR_SATURATION):
        raise ValueError(f"parameter '{name}' = {value!r} is not valid here: "
                         + describe_nozzle_status(status, state.temperature, state.density, table, state=where))


def fluid_wide_range(p: CompressorParameters) -> InputRange | None:
    """The declared input range of the fluid-wide tables (thermo.fluid_envelope) if they serve this run: a fluid
    that has one, and the parameters' operating point inside it; else None (the run uses per-point tables)."""
    inputs = fluid_range_for(p.fluid).inputs
    if inputs is None:                                # no dome above 20 °C (air): per operating point
        return None
    inside = (inputs.suction_pressure_min <= p.suction_pressure <= inputs.suction_pressure_max
              and p.discharge_pressure <= inputs.discharge_pressure_max
              and p.suction_temperature <= inputs.suction_temperature_max)
    return inputs if inside else None


def boundary_nodes_of(suction_pressure, suction_value, by_enthalpy, discharge_pressure, guess: FlowNode,
                      properties) -> tuple[FlowNode, FlowNode, int, int]:
    """(suction node, back node, status, which node failed) on the property table (`properties`: its
    table_arrays) for p_s, T_s (or h_s if `by_enthalpy`) and p_d; thermo.boundary_states, from the suction state
    `guess`."""
    values = boundary_states(float(suction_pressure), float(suction_value), bool(by_enthalpy),
                             float(discharge_pressure), guess.temperature, guess.density, *properties)
    t_s, rho_s, h_s, t_d, rho_d, h_d, status, which = values
    if by_enthalpy and status == 0:
        h_s = float(suction_value)         # the input itself (the solve meets it to 1e-12): an unchanged input
                                           # is then recognised as such
    return (FlowNode(t_s, rho_s, float(suction_pressure), h_s), FlowNode(t_d, rho_d, float(discharge_pressure), h_d),
            int(status), int(which))


def _real_gas_coupling(p: CompressorParameters) -> GasCoupling:
    point = operating_point_for(p.fluid, p.suction_pressure, p.suction_temperature, p.discharge_pressure)
    inputs = fluid_wide_range(p)
    if inputs is not None:
        table, nozzles = fluid_tables_for(p.fluid)
    else:
        table, nozzles = property_table_for(point, point.envelope), nozzle_table_for(point, point.envelope)
    properties = table_arrays(table)
    guess = FlowNode(p.suction_temperature, point.suction_density, p.suction_pressure, point.suction_enthalpy)
    suction, discharge, status, which = boundary_nodes_of(p.suction_pressure, p.suction_temperature, False,
                                                          p.discharge_pressure, guess, properties)
    if status != 0:                # the table misses a state of a point CoolProp accepted: a table too small
        raise ValueError(f"parameter '{'suction_temperature' if which == 1 else 'discharge_pressure'}' is out of "
                         f"range for the {p.fluid} property table: {describe_boundary_status(status)}")
    _check_nozzle_inlet("fluid", p.fluid, suction, nozzles, "suction state")
    if p.slot_leak_law != "sealed":
        _check_nozzle_inlet("slot_leak_law", p.slot_leak_law, discharge, nozzles,
                            "back chamber (p_d on the suction isentrope)")
    reference = GasReference(point, p.lobes * p.axial_length * lobe_area(p))
    return GasCoupling(np.zeros(2), properties, nozzle_table_arrays(nozzles),
                       _constants(p, suction, discharge, valley_seal_length(p)), chamber_flow_work(),
                       point.suction_density, reference, inputs)


def gas_coupling(params: CompressorParameters, operating_speed: float) -> GasCoupling:
    """The GasCoupling of the parameters' pressure model; `operating_speed` [rad/s] is the Level 0.5 table's speed."""
    p = params
    if p.pressure_model == "real_gas":
        return _real_gas_coupling(p)
    density = p.suction_pressure / (p.gas_constant * p.suction_temperature)
    enthalpy = p.heat_capacity_ratio * p.gas_constant / (p.heat_capacity_ratio - 1.0) * p.suction_temperature
    suction = FlowNode(p.suction_temperature, density, p.suction_pressure, enthalpy)
    return GasCoupling(leading_pressure_table(p, operating_speed), table_arrays(_placeholder_properties()),
                       nozzle_table_arrays(_placeholder_nozzles()), _constants(p, suction, suction, 0.0),
                       chamber_flow_work(), density, None, None)
