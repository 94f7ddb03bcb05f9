"""Leading-chamber pressure tables p_L(phase) over one lobe (docs/model.md §6.1, §7.5).

Both builders are generic: the caller passes the chamber volume V(phase)
[m^3] (and dV/dphase [m^3/rad]) on a phase grid [rad]; for the reference
model this is the thin-vane volume of docs/model.md §6.5. All quantities are SI.
"""

import numpy as np

from .checks import checked_number, fail
from ..kernels.kernel import kernel
from .nozzle import isentropic_nozzle_mass_flow


def _check_array(name, values, length, allowed, condition):
    """Require a finite 1-D float array of ``length`` with ``condition`` true element-wise."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1 or array.size != length:
        fail(f"{name}.shape", array.shape, f"({length},), same length as phase")
    bad = np.flatnonzero(~(np.isfinite(array) & condition(array)))
    if bad.size:
        fail(f"{name}[{bad[0]}]", float(array[bad[0]]), allowed)
    return array


def _check_grid(phase, volume, suction_close_phase):
    """Validate an increasing uniform phase grid and a positive volume on it."""
    phase = np.asarray(phase, dtype=np.float64)
    if phase.ndim != 1 or phase.size < 2:
        fail("phase.shape", phase.shape, "1-D with at least 2 points")
    phase = _check_array("phase", phase, phase.size, "finite", lambda a: a == a)
    steps = np.diff(phase)
    mean_step = (phase[-1] - phase[0]) / (phase.size - 1)
    if not mean_step > 0.0:
        fail("phase", f"[{phase[0]!r}, ..., {phase[-1]!r}]", "strictly increasing")
    worst = int(np.argmax(np.abs(steps - mean_step)))
    if abs(steps[worst] - mean_step) > 1e-6 * mean_step:
        fail(f"phase[{worst + 1}]-phase[{worst}]", float(steps[worst]),
              f"uniform step {mean_step!r} (relative tolerance 1e-6)")
    volume = _check_array("volume", volume, phase.size, "> 0 m^3", lambda a: a > 0.0)
    close = checked_number("suction_close_phase", suction_close_phase,
                          f"[{float(phase[0])!r}, {float(phase[-1])!r}] rad (inside the phase grid)",
                          lambda x: phase[0] <= x <= phase[-1])
    return phase, volume, close


def _check_pressures(suction_pressure, discharge_pressure):
    suction_pressure = checked_number("suction_pressure", suction_pressure, "> 0 Pa",
                                     lambda x: x > 0.0)
    discharge_pressure = checked_number(
        "discharge_pressure", discharge_pressure,
        f"> suction_pressure = {suction_pressure!r} Pa", lambda x: x > suction_pressure)
    return suction_pressure, discharge_pressure


def polytropic_pressure_table(phase, volume, suction_pressure, discharge_pressure,
                              suction_close_phase, polytropic_exponent):
    """Level-0 leading-chamber pressure p_L(phase) [Pa] (docs/model.md §6.1).

        p = p_s                                 for phase <  phase_sc
        p = min(p_s (V_sc / V)^n_p, p_d)        for phase >= phase_sc

    with V_sc = V(phase_sc) linearly interpolated on the grid. No leakage,
    no port throttling (the chamber is clipped at p_d).
    """
    phase, volume, suction_close_phase = _check_grid(phase, volume, suction_close_phase)
    suction_pressure, discharge_pressure = _check_pressures(suction_pressure,
                                                            discharge_pressure)
    polytropic_exponent = checked_number("polytropic_exponent", polytropic_exponent,
                                        "> 0", lambda x: x > 0.0)
    close_volume = np.interp(suction_close_phase, phase, volume)
    compressed = np.minimum(
        suction_pressure * (close_volume / volume) ** polytropic_exponent,
        discharge_pressure)
    return np.where(phase < suction_close_phase, suction_pressure,
                    compressed).astype(np.float64)


@kernel(allocates=True)
def _ideal_gas_kernel(phase, volume, volume_derivative, time_step, angular_speed,
                      suction_pressure, suction_temperature, discharge_pressure,
                      suction_close_phase, leak_area, leak_coefficient,
                      port_area, port_coefficient, heat_capacity_ratio, gas_constant):
    """Explicit-Euler single-chamber ideal-gas CV march of docs/model.md §7.5."""
    specific_heat_volume = gas_constant / (heat_capacity_ratio - 1.0)
    specific_heat_pressure = heat_capacity_ratio * specific_heat_volume
    pressure = np.empty(phase.size)
    temperature = suction_temperature
    mass = suction_pressure * volume[0] / (gas_constant * suction_temperature)
    for i in range(phase.size):
        if phase[i] < suction_close_phase:  # open to suction: reset the state
            temperature = suction_temperature
            mass = suction_pressure * volume[i] / (gas_constant * suction_temperature)
            pressure[i] = suction_pressure
            continue
        chamber_pressure = mass * gas_constant * temperature / volume[i]
        pressure[i] = chamber_pressure
        leak_flow = isentropic_nozzle_mass_flow(
            leak_coefficient, leak_area, chamber_pressure, temperature,
            suction_pressure, heat_capacity_ratio, gas_constant)
        port_flow = isentropic_nozzle_mass_flow(  # check valve: 0 unless above p_d
            port_coefficient, port_area, chamber_pressure, temperature,
            discharge_pressure, heat_capacity_ratio, gas_constant)
        mass_rate = -(leak_flow + port_flow)
        volume_rate = volume_derivative[i] * angular_speed
        energy_rate = (-chamber_pressure * volume_rate
                       + mass_rate * specific_heat_pressure * temperature)
        temperature_rate = ((energy_rate - specific_heat_volume * temperature * mass_rate)
                            / (mass * specific_heat_volume))
        mass += time_step * mass_rate
        temperature += time_step * temperature_rate
    return pressure


def ideal_gas_pressure_table(phase, volume, volume_derivative, angular_speed,
                             suction_pressure, suction_temperature, discharge_pressure,
                             suction_close_phase, leak_area, leak_discharge_coefficient,
                             discharge_port_area, discharge_port_coefficient,
                             heat_capacity_ratio, gas_constant):
    """Level-0.5 leading-chamber pressure p_L(phase) [Pa] (docs/model.md §6.1, §7.5).

    One chamber of ideal gas (c_v = R/(k-1), c_p = k c_v), adiabatic, marched by
    explicit Euler over the uniform phase grid with dt = dphase/omega and
    dV/dt = (dV/dphase) omega. For phase < phase_sc the chamber is open to
    suction: p = p_s, T = T_s, m = p_s V/(R T_s). Otherwise p = m R T / V and

        m_leak = nozzle(C_leak, A_leak, p -> p_s)        (valley-seal leak, A_leak = cS L)
        m_dis  = nozzle(C_d, A_d, p -> p_d)              (0 if p <= p_d)
        dm/dt  = -m_leak - m_dis
        dU/dt  = -p dV/dt - (m_leak + m_dis) c_p T
        dT/dt  = (dU/dt - c_v T dm/dt) / (m c_v)

    with the nozzle of docs/model.md §7.4. Returns p at every grid point (float64).
    """
    phase, volume, suction_close_phase = _check_grid(phase, volume, suction_close_phase)
    volume_derivative = _check_array("volume_derivative", volume_derivative,
                                     phase.size, "finite m^3/rad", lambda a: a == a)
    suction_pressure, discharge_pressure = _check_pressures(suction_pressure,
                                                            discharge_pressure)
    positive, non_negative = (lambda x: x > 0.0), (lambda x: x >= 0.0)
    unit_interval = lambda x: 0.0 <= x <= 1.0
    angular_speed = checked_number("angular_speed", angular_speed, "> 0 rad/s", positive)
    suction_temperature = checked_number("suction_temperature", suction_temperature,
                                        "> 0 K", positive)
    leak_area = checked_number("leak_area", leak_area, ">= 0 m^2", non_negative)
    leak_discharge_coefficient = checked_number(
        "leak_discharge_coefficient", leak_discharge_coefficient, "[0, 1]", unit_interval)
    discharge_port_area = checked_number("discharge_port_area", discharge_port_area,
                                        ">= 0 m^2", non_negative)
    discharge_port_coefficient = checked_number(
        "discharge_port_coefficient", discharge_port_coefficient, "[0, 1]", unit_interval)
    heat_capacity_ratio = checked_number("heat_capacity_ratio", heat_capacity_ratio,
                                        "> 1", lambda x: x > 1.0)
    gas_constant = checked_number("gas_constant", gas_constant, "> 0 J/(kg K)", positive)
    time_step = (phase[-1] - phase[0]) / (phase.size - 1) / angular_speed
    return _ideal_gas_kernel(
        phase, volume, volume_derivative, time_step, angular_speed, suction_pressure,
        suction_temperature, discharge_pressure, suction_close_phase, leak_area,
        leak_discharge_coefficient, discharge_port_area, discharge_port_coefficient,
        heat_capacity_ratio, gas_constant)
