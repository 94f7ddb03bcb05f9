"""Isentropic-nozzle mass flow of an ideal gas (docs/model.md §7.4)."""

import math

from ..kernels.kernel import kernel


@kernel
def isentropic_nozzle_mass_flow(
    discharge_coefficient,
    area,
    upstream_pressure,
    upstream_temperature,
    downstream_pressure,
    heat_capacity_ratio,
    gas_constant,
):
    """Mass flow [kg/s] through an isentropic nozzle, upstream -> downstream (docs/model.md §7.4).

    With pr = p_down/p_up and the critical ratio pr* = (2/(k+1))^(k/(k-1)):

        pr >  pr*:  m_dot = C_d A p_up / sqrt(R T_up)
                            * sqrt( 2k/(k-1) * (pr^(2/k) - pr^((k+1)/k)) )
        pr <= pr*:  m_dot = C_d A p_up sqrt(k/(R T_up)) * (2/(k+1))^((k+1)/(2(k-1)))   (choked)

    Returns 0.0 if p_down >= p_up or A <= 0 (no reverse flow: the caller
    swaps the arguments for flow in the other direction).
    """
    if area <= 0.0 or downstream_pressure >= upstream_pressure:
        return 0.0
    gamma = heat_capacity_ratio
    pressure_ratio = downstream_pressure / upstream_pressure
    critical_ratio = (2.0 / (gamma + 1.0)) ** (gamma / (gamma - 1.0))
    if pressure_ratio > critical_ratio:
        flow_function = math.sqrt(2.0 * gamma / (gamma - 1.0) * (
            pressure_ratio ** (2.0 / gamma) - pressure_ratio ** ((gamma + 1.0) / gamma)))
        return (discharge_coefficient * area * upstream_pressure
                / math.sqrt(gas_constant * upstream_temperature) * flow_function)
    choked_factor = (2.0 / (gamma + 1.0)) ** ((gamma + 1.0) / (2.0 * (gamma - 1.0)))
    return (discharge_coefficient * area * upstream_pressure
            * math.sqrt(gamma / (gas_constant * upstream_temperature)) * choked_factor)
