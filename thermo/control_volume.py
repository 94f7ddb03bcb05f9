"""Real-gas control-volume balance in (T, rho) and the flow paths between chambers (docs/model.md §7.3, §7.4).

Pure numba functions: a chamber is a volume, its rate of change and the mass and enthalpy flows through its
paths; the fluid properties (p, h, c_v, (dp/dT)_rho) are evaluated by the caller (thermo.property_table).
"""
import math


from ..kernels.kernel import kernel
from .nozzle import isentropic_nozzle_mass_flow
from .property_table import table_properties


@kernel
def chamber_derivatives(temperature, density, volume, volume_rate, mass_in, enthalpy_in, mass_out, enthalpy,
                        heat_capacity_v, pressure_temperature_derivative, heat_rate):
    """(dT/dt, drho/dt) of one chamber (docs/model.md §7.3, PDSim's form):

        dm/dt   = sum m_in - sum m_out
        drho/dt = (dm/dt - rho dV/dt) / V
        dT/dt   = [ -T (dp/dT)_rho (dV/dt - v dm/dt) - h dm/dt + Q + sum m_in h_up - sum m_out h ] / (m c_v)

    mass_in = sum m_in [kg/s], enthalpy_in = sum m_in h_up [W], mass_out = sum m_out [kg/s] leaving at the
    chamber's own enthalpy h [J/kg]; heat_rate Q [W] into the gas.
    """
    mass = density * volume
    mass_rate = mass_in - mass_out
    density_rate = (mass_rate - density * volume_rate) / volume
    temperature_rate = (-temperature * pressure_temperature_derivative * (volume_rate - mass_rate / density)
                        - enthalpy * mass_rate + heat_rate + enthalpy_in - mass_out * enthalpy) / (
        mass * heat_capacity_v)
    return temperature_rate, density_rate


LINEAR_FLOW_BAND = 2e-3      # relative pressure difference below which a path's flow is linear in it


@kernel
def signed_nozzle_flow(discharge_coefficient, area, pressure_a, temperature_a, pressure_b, temperature_b,
                       heat_capacity_ratio, gas_constant):
    """Mass flow [kg/s] from side a to side b through an isentropic nozzle (docs/model.md §7.4); negative when the gas
    flows from b to a (the upstream side's temperature is used).

    The nozzle law has an infinite derivative d m_dot / d p at equal pressures (m_dot ~ sqrt(p_up - p_down)),
    which makes an explicit integrator chatter around every pressure equalisation. Below a relative difference
    eps = LINEAR_FLOW_BAND the flow is taken linear in the difference through the nozzle value at eps
    (continuous, Lipschitz; a regularisation like that of the friction law):
        |p_up - p_down| < eps p_up:  m_dot = m_dot_nozzle(p_up, (1 - eps) p_up) (p_up - p_down) / (eps p_up)
    """
    forward = pressure_a >= pressure_b
    upstream = pressure_a if forward else pressure_b
    downstream = pressure_b if forward else pressure_a
    temperature = temperature_a if forward else temperature_b
    band = LINEAR_FLOW_BAND * upstream
    if upstream - downstream < band:
        flow = isentropic_nozzle_mass_flow(discharge_coefficient, area, upstream, temperature, upstream - band,
                                           heat_capacity_ratio, gas_constant) * (upstream - downstream) / band
    else:
        flow = isentropic_nozzle_mass_flow(discharge_coefficient, area, upstream, temperature, downstream,
                                           heat_capacity_ratio, gas_constant)
    return flow if forward else -flow


@kernel
def port_coverage(vane_phase, port_start, port_end):
    """Fraction of a port spanning lobe phases [port_start, port_end] that lies ahead of the vane (in the leading
    chamber) when the vane is at `vane_phase`; the rest lies behind it (trailing chamber). Linear in the phase."""
    if vane_phase <= port_start:
        return 1.0
    if vane_phase >= port_end:
        return 0.0
    return (port_end - vane_phase) / (port_end - port_start)


@kernel
def internal_energy_temperature(target_energy, density, temperature_guess, table):
    """Temperature at which the specific internal energy u = h - p/rho equals `target_energy` at `density`
    (Newton on (du/dT)_rho = c_v with the property table); NaN if the table refuses a state on the way."""
    temperature = temperature_guess
    for _ in range(30):
        p, h, cv, _, status = table_properties(temperature, density, table)
        if status != 0:
            return math.nan
        correction = (h - p / density - target_energy) / cv
        temperature -= correction
        if abs(correction) < 1e-10 * temperature:
            return temperature
    return math.nan
