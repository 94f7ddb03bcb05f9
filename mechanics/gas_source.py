"""What the time loop reads of the gas, per pressure model (docs/model.md §6.1, §7), and the compressor figures derived
from a revolution of Level 1 (docs/model.md §6.4): volumetric and isentropic efficiency, discharge temperature.

- Level 0 / 0.5: a p_L(phase) table (mechanics.pressure_source); the property table is a one-cell placeholder.
- Level 1: the fluid's (T, ln rho) property table for the operating envelope (thermo.property_table, cached on
  disk), the suction state consistent with that table, and the ideal-gas k and R of the nozzle law.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rotary_vane.thermo.fluid import Fluid, coolprop
from rotary_vane.thermo.property_table import PropertyTable, envelope_for, property_table_for, table_properties

from .geometry import lobe_area
from .machine import SuctionGas, ideal_suction_gas
from .parameters import CompressorParameters
from .pressure_source import leading_pressure_table


class GasSource(NamedTuple):
    """The gas arguments of the kernels: the Level 0/0.5 p_L table and the Level 1 property table."""
    pressure_table: np.ndarray
    properties: PropertyTable


def _placeholder_properties() -> PropertyTable:
    """A table that refuses every state (status != 0): the Level 0/0.5 runs never query it."""
    return PropertyTable(temperature_min=1.0, temperature_max=2.0, inverse_temperature_step=1.0,
                         log_density_min=0.0, log_density_max=1.0, inverse_log_density_step=1.0,
                         nodes=np.zeros((2, 2, 4, 4)), inverse_dome_step=1.0,
                         dome_log_density_limit=np.full(2, -np.inf), accurate_cell=np.zeros((1, 1), dtype=np.bool_),
                         ideal_gas_exponent=np.ones(2), superheat_margin=1.0, critical_temperature=1.0)


class GasReference:
    """The suction state and the ideal references of a Level 1 run: h_1, s_1, h_2s = h(p_d, s_1), rho_s, and the
    displacement z L A_lobe per revolution."""

    def __init__(self, params: CompressorParameters, fluid: Fluid, suction_density: float):
        self.fluid = fluid
        self.discharge_pressure = params.discharge_pressure
        suction = fluid.properties(params.suction_temperature, suction_density)
        self.suction_enthalpy = suction.enthalpy
        self.isentropic_discharge_enthalpy = fluid.isentropic_enthalpy(params.discharge_pressure, suction.entropy)
        self.suction_density = suction_density
        self.displacement = params.lobes * params.axial_length * lobe_area(params)
        self._state = coolprop().AbstractState("HEOS", params.fluid)

    def _temperature(self, pressure, enthalpy):
        self._state.update(coolprop().HmassP_INPUTS, enthalpy, pressure)
        return self._state.T()

    def figures(self, summary) -> dict[str, float]:
        """Per-revolution compressor figures from a Level 1 WindowSummary (one revolution):

        volumetric efficiency  eta_v = m_d / (rho_s z L A_lobe)        (delivered mass per revolution)
        isentropic efficiency  eta_is = m_dot_d (h_2s - h_1) / <P_in>  (docs/model.md §6.4)
        discharge temperature  T(p_d, h_d), h_d the mass-weighted enthalpy of the discharged gas
        """
        duration = summary.end_time - summary.start_time
        delivered = summary.discharge_mass_flow * duration
        temperature = (self._temperature(self.discharge_pressure, summary.discharge_enthalpy)
                       if delivered > 0.0 else math.nan)
        return dict(
            suction_mass_flow=summary.suction_mass_flow, discharge_mass_flow=summary.discharge_mass_flow,
            discharge_temperature=temperature, indicated_power=summary.indicated_power,
            volumetric_efficiency=delivered / (self.suction_density * self.displacement),
            isentropic_efficiency=summary.discharge_mass_flow * (self.isentropic_discharge_enthalpy
                                                                 - self.suction_enthalpy) / summary.input_power)


def gas_source(params: CompressorParameters, operating_speed: float):
    """(GasSource, SuctionGas, GasReference or None) for the parameters' pressure model; `operating_speed` [rad/s]
    is the Level 0.5 table's speed."""
    if params.pressure_model != "real_gas":
        return (GasSource(leading_pressure_table(params, operating_speed), _placeholder_properties()),
                ideal_suction_gas(params), None)
    fluid = Fluid(params.fluid)
    envelope = envelope_for(fluid, params.suction_pressure, params.suction_temperature, params.discharge_pressure)
    table = property_table_for(fluid, envelope)
    density = fluid.density(params.suction_temperature, params.suction_pressure)
    suction = table_properties(params.suction_temperature, density, table)
    suction_gas = SuctionGas(density, suction[1], fluid.ideal_gas_exponent(params.suction_temperature),
                             fluid.gas_constant)
    return (GasSource(np.zeros(2), table), suction_gas, GasReference(params, fluid, density))
