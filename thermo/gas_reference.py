"""The ideal references of a real-gas compressor and the figures they define per revolution (docs/model.md §6.4):
volumetric and isentropic efficiency, discharge temperature. Everything comes from the run's
thermo.operating_point.OperatingPoint, or from the property table for a boundary moved during the run
(thermo.boundary_states), so nothing here imports CoolProp.
"""
from __future__ import annotations

import math

from .operating_point import OperatingPoint


class GasReference:
    """The suction state h_1, rho_s and the isentropic discharge enthalpy h_2s = h(p_d, s_1) of a real-gas run (its
    OperatingPoint) and its displacement per revolution (z L A_lobe, given by the caller)."""

    def __init__(self, point: OperatingPoint, displacement: float, boundary=None):
        """`boundary`: the moved boundary (suction density [kg/m^3], h_1 [J/kg], h_2s [J/kg], T(p_d, h) as a
        function) that replaces the point's (mechanics.simulation.Simulation.set_boundary); None: the point's."""
        self.point = point
        self.displacement = displacement
        self.suction_density, self.suction_enthalpy, self.isentropic_discharge_enthalpy, self.discharge_temperature = (
            (point.suction_density, point.suction_enthalpy, point.isentropic_discharge_enthalpy,
             point.discharge_temperature) if boundary is None else boundary)

    def figures(self, discharge_mass_flow: float, discharge_enthalpy: float, duration: float,
                input_power: float) -> dict[str, float]:
        """Per-revolution compressor figures (docs/model.md §6.4):

        volumetric efficiency  eta_v = m_d / (rho_s z L A_lobe)        (delivered mass per revolution)
        isentropic efficiency  eta_is = m_dot_d (h_2s - h_1) / <P_in>
        discharge temperature  T(p_d, h_d), h_d the mass-weighted enthalpy of the discharged gas (NaN if none;
                               OperatingPoint.discharge_temperature)
        """
        delivered = discharge_mass_flow * duration
        return dict(
            discharge_temperature=self.discharge_temperature(discharge_enthalpy) if delivered > 0.0 else math.nan,
            volumetric_efficiency=delivered / (self.suction_density * self.displacement),
            isentropic_efficiency=discharge_mass_flow * (self.isentropic_discharge_enthalpy - self.suction_enthalpy)
            / input_power)
