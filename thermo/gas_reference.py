"""The ideal references of a real-gas compressor and the figures they define per revolution (docs/model.md §6.4):
volumetric and isentropic efficiency, discharge temperature.
"""
from __future__ import annotations

import math

from .fluid import Fluid, coolprop


class GasReference:
    """The suction state h_1, s_1 and the isentropic discharge enthalpy h_2s = h(p_d, s_1) of a real-gas run, its
    suction density rho_s and its displacement per revolution (z L A_lobe, given by the caller)."""

    def __init__(self, fluid: Fluid, suction_temperature: float, suction_density: float, discharge_pressure: float,
                 displacement: float):
        self.fluid = fluid
        self.discharge_pressure = discharge_pressure
        suction = fluid.properties(suction_temperature, suction_density)
        self.suction_enthalpy = suction.enthalpy
        self.isentropic_discharge_enthalpy = fluid.isentropic_enthalpy(discharge_pressure, suction.entropy)
        self.suction_density = suction_density
        self.displacement = displacement
        self._state = coolprop().AbstractState("HEOS", fluid.name)

    def discharge_temperature(self, enthalpy: float) -> float:
        """T(p_d, h) [K] of gas discharged with mass-weighted enthalpy h."""
        self._state.update(coolprop().HmassP_INPUTS, enthalpy, self.discharge_pressure)
        return self._state.T()

    def figures(self, discharge_mass_flow: float, discharge_enthalpy: float, duration: float,
                input_power: float) -> dict[str, float]:
        """Per-revolution compressor figures (docs/model.md §6.4):

        volumetric efficiency  eta_v = m_d / (rho_s z L A_lobe)        (delivered mass per revolution)
        isentropic efficiency  eta_is = m_dot_d (h_2s - h_1) / <P_in>
        discharge temperature  T(p_d, h_d), h_d the mass-weighted enthalpy of the discharged gas (NaN if none)
        """
        delivered = discharge_mass_flow * duration
        return dict(
            discharge_temperature=self.discharge_temperature(discharge_enthalpy) if delivered > 0.0 else math.nan,
            volumetric_efficiency=delivered / (self.suction_density * self.displacement),
            isentropic_efficiency=discharge_mass_flow * (self.isentropic_discharge_enthalpy - self.suction_enthalpy)
            / input_power)
