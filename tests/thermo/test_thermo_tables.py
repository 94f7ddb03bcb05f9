"""Physics checks of thermo: nozzle (docs/model.md §7.4) and pressure tables (docs/model.md §6.1, §7.5)."""

import math

import numpy as np
import pytest

from rotary_vane.thermo import (
    ideal_gas_pressure_table,
    isentropic_nozzle_mass_flow,
    polytropic_pressure_table,
)

# docs/model.md §9 defaults
ROTOR_RADIUS = 30e-3
STROKE = 5e-3
LOBES = 3
DEAD_VOLUME = 0.05e-6
AXIAL_LENGTH = 55e-3
SUCTION_PRESSURE = 0.2928e6
SUCTION_TEMPERATURE = 283.15
DISCHARGE_PRESSURE = 1.3179e6
SUCTION_CLOSE_PHASE = math.radians(10.0)
ANGULAR_SPEED = 1500.0 * 2.0 * math.pi / 60.0
GAMMA = 1.10
GAS_CONSTANT = 81.5
PORT_AREA = 20e-6
PORT_COEFFICIENT = 0.7
LEAK_COEFFICIENT = 0.65
LOBE_PITCH = 2.0 * math.pi / LOBES
CLEARANCES = [0.0, 0.02e-3, 0.05e-3, 0.1e-3, 0.2e-3]


def thin_vane_volume(phase):
    """docs/model.md §6.5 with harmonic s = h/2 (1 - cos z phase), integrated in closed form."""
    amplitude = STROKE / 2.0

    def antiderivative(angle):  # of R_r s + s^2/2
        integral_s = amplitude * (angle - np.sin(LOBES * angle) / LOBES)
        integral_s2 = amplitude**2 * (1.5 * angle - 2.0 * np.sin(LOBES * angle) / LOBES
                                      + np.sin(2 * LOBES * angle) / (4 * LOBES))
        return ROTOR_RADIUS * integral_s + 0.5 * integral_s2

    stroke = amplitude * (1.0 - np.cos(LOBES * phase))
    volume = AXIAL_LENGTH * (antiderivative(LOBE_PITCH) - antiderivative(phase)) + DEAD_VOLUME
    derivative = -AXIAL_LENGTH * 0.5 * ((ROTOR_RADIUS + stroke)**2 - ROTOR_RADIUS**2)
    return volume, derivative


def grid(points):
    phase = np.linspace(0.0, LOBE_PITCH, points)
    return (phase, *thin_vane_volume(phase))


def level_half_table(points=20000, leak_area=0.0, discharge_pressure=DISCHARGE_PRESSURE):
    phase, volume, derivative = grid(points)
    pressure = ideal_gas_pressure_table(
        phase, volume, derivative, ANGULAR_SPEED, SUCTION_PRESSURE, SUCTION_TEMPERATURE,
        discharge_pressure, SUCTION_CLOSE_PHASE, leak_area, LEAK_COEFFICIENT,
        PORT_AREA, PORT_COEFFICIENT, GAMMA, GAS_CONSTANT)
    return phase, volume, pressure


# ---------------------------------------------------------------- nozzle (§7.4)
UPSTREAM_PRESSURE = 1.5e6
UPSTREAM_TEMPERATURE = 330.0
CRITICAL_RATIO = (2.0 / (GAMMA + 1.0)) ** (GAMMA / (GAMMA - 1.0))


def nozzle(downstream_pressure, area=1e-6, upstream_pressure=UPSTREAM_PRESSURE):
    return isentropic_nozzle_mass_flow(0.7, area, upstream_pressure, UPSTREAM_TEMPERATURE,
                                       downstream_pressure, GAMMA, GAS_CONSTANT)


def test_nozzle_zero_for_reversed_equal_pressure_or_no_area():
    assert nozzle(UPSTREAM_PRESSURE) == 0.0
    assert nozzle(2.0 * UPSTREAM_PRESSURE) == 0.0
    assert nozzle(0.5 * UPSTREAM_PRESSURE, area=0.0) == 0.0
    assert nozzle(0.5 * UPSTREAM_PRESSURE, area=-1e-6) == 0.0


def test_nozzle_continuous_at_critical_ratio():
    below = nozzle(UPSTREAM_PRESSURE * CRITICAL_RATIO * (1.0 - 1e-12))
    above = nozzle(UPSTREAM_PRESSURE * CRITICAL_RATIO * (1.0 + 1e-12))
    assert above > 0.0
    assert abs(above - below) / below < 1e-9


def test_nozzle_choked_flow_independent_of_downstream_pressure():
    flows = [nozzle(UPSTREAM_PRESSURE * ratio) for ratio in (0.0, 0.1, 0.3, 0.5,
                                                            CRITICAL_RATIO * 0.999)]
    # independent reference: C_d A p_up sqrt(k/(R T)) (2/(k+1))^((k+1)/(2(k-1)))
    expected = 0.7 * 1e-6 * UPSTREAM_PRESSURE * math.sqrt(
        GAMMA / (GAS_CONSTANT * UPSTREAM_TEMPERATURE)) * (2.0 / (GAMMA + 1.0)) ** (
        (GAMMA + 1.0) / (2.0 * (GAMMA - 1.0)))
    assert np.allclose(flows, expected, rtol=1e-12, atol=0.0)


def test_nozzle_flow_increases_as_pressure_ratio_falls_to_critical():
    ratios = np.linspace(1.0 - 1e-6, CRITICAL_RATIO * (1.0 + 1e-3), 500)
    flows = np.array([nozzle(UPSTREAM_PRESSURE * ratio) for ratio in ratios])
    assert flows[0] > 0.0
    assert np.all(np.diff(flows) > 0.0)


def test_nozzle_incompressible_limit():
    downstream = 0.999 * UPSTREAM_PRESSURE
    density = UPSTREAM_PRESSURE / (GAS_CONSTANT * UPSTREAM_TEMPERATURE)
    incompressible = 0.7 * 1e-6 * math.sqrt(2.0 * density * (UPSTREAM_PRESSURE - downstream))
    assert nozzle(downstream) == pytest.approx(incompressible, rel=1e-2)


# ------------------------------------------------------- Level 0.5 table (§7.5)
def adiabatic_invariant_error(points):
    """Max relative deviation of p V^k from p_s V(phase_sc)^k after suction close."""
    phase, volume, pressure = level_half_table(points, discharge_pressure=1e15)
    closed = phase >= SUCTION_CLOSE_PHASE
    close_volume, _ = thin_vane_volume(np.array(SUCTION_CLOSE_PHASE))
    expected = SUCTION_PRESSURE * close_volume**GAMMA
    return np.max(np.abs(pressure[closed] * volume[closed] ** GAMMA / expected - 1.0))


def test_sealed_chamber_is_adiabatic_and_euler_converges_first_order():
    coarse = adiabatic_invariant_error(20000)
    fine = adiabatic_invariant_error(40000)
    assert coarse < 1e-3
    assert coarse / fine > 1.6


def test_open_to_suction_before_close_and_float64():
    phase, _, pressure = level_half_table()
    assert pressure.dtype == np.float64 and pressure.shape == phase.shape
    assert np.all(pressure[phase < SUCTION_CLOSE_PHASE] == SUCTION_PRESSURE)


@pytest.fixture(scope="module")
def peak_pressures():
    return [level_half_table(leak_area=clearance * AXIAL_LENGTH)[2].max()
            for clearance in CLEARANCES]


def test_leakage_lowers_peak_pressure_monotonically(peak_pressures):
    assert all(leaky < peak_pressures[0] for leaky in peak_pressures[1:])
    assert np.all(np.diff(peak_pressures) < 0.0)


def test_port_throttling_over_compresses_without_leak(peak_pressures):
    # docs/model.md §7.5: ~1.463 MPa at cS = 0, 1500 rpm (~11 % over-compression)
    assert DISCHARGE_PRESSURE < peak_pressures[0] < 1.3 * DISCHARGE_PRESSURE


# --------------------------------------------------------- Level 0 table (§6.1)
def test_polytropic_table():
    phase, volume, _ = grid(5000)
    pressure = polytropic_pressure_table(phase, volume, SUCTION_PRESSURE, DISCHARGE_PRESSURE,
                                         SUCTION_CLOSE_PHASE, GAMMA)
    assert np.all(pressure[phase < SUCTION_CLOSE_PHASE] == SUCTION_PRESSURE)
    assert np.all(pressure <= DISCHARGE_PRESSURE)
    assert pressure.max() == DISCHARGE_PRESSURE  # the chamber does reach p_d
    close_volume, _ = thin_vane_volume(np.array(SUCTION_CLOSE_PHASE))
    compressing = (phase >= SUCTION_CLOSE_PHASE) & (pressure < DISCHARGE_PRESSURE)
    assert compressing.sum() > 100
    invariant = pressure[compressing] * volume[compressing] ** GAMMA
    assert np.allclose(invariant, SUCTION_PRESSURE * close_volume**GAMMA, rtol=1e-6, atol=0)


# -------------------------------------------------------------- input checks
def good_arguments():
    phase, volume, derivative = grid(200)
    return dict(
        phase=phase, volume=volume, volume_derivative=derivative,
        angular_speed=ANGULAR_SPEED, suction_pressure=SUCTION_PRESSURE,
        suction_temperature=SUCTION_TEMPERATURE, discharge_pressure=DISCHARGE_PRESSURE,
        suction_close_phase=SUCTION_CLOSE_PHASE, leak_area=1e-6,
        leak_discharge_coefficient=LEAK_COEFFICIENT, discharge_port_area=PORT_AREA,
        discharge_port_coefficient=PORT_COEFFICIENT, heat_capacity_ratio=GAMMA,
        gas_constant=GAS_CONSTANT)


@pytest.mark.parametrize("name, value, shown", [
    ("angular_speed", 0.0, "0.0"),
    ("suction_temperature", float("nan"), "nan"),
    ("suction_pressure", -1.0, "-1.0"),
    ("discharge_pressure", 0.2e6, "200000.0"),
    ("leak_area", -1e-6, "-1e-06"),
    ("heat_capacity_ratio", 1.0, "1.0"),
    ("gas_constant", float("inf"), "inf"),
    ("suction_close_phase", 3.0, "3.0"),
    ("discharge_port_coefficient", 1.5, "1.5"),
])
def test_bad_scalar_raises(name, value, shown):
    arguments = good_arguments()
    arguments[name] = value
    with pytest.raises(ValueError) as error:
        ideal_gas_pressure_table(**arguments)
    assert name in str(error.value) and shown in str(error.value)


def test_bad_arrays_raise():
    arguments = good_arguments()
    arguments["volume"] = arguments["volume"].copy()
    arguments["volume"][7] = -2.5e-6
    with pytest.raises(ValueError, match=r"volume\[7\]=-2\.5e-06"):
        ideal_gas_pressure_table(**arguments)

    arguments = good_arguments()
    arguments["phase"] = arguments["phase"] ** 1.01  # not uniform
    with pytest.raises(ValueError, match="phase"):
        ideal_gas_pressure_table(**arguments)

    arguments = good_arguments()
    arguments["volume_derivative"] = arguments["volume_derivative"][:-1]
    with pytest.raises(ValueError, match="volume_derivative"):
        ideal_gas_pressure_table(**arguments)

    phase, volume, _ = grid(200)
    with pytest.raises(ValueError, match=r"phase.*strictly increasing"):
        polytropic_pressure_table(phase[::-1], volume, SUCTION_PRESSURE,
                                  DISCHARGE_PRESSURE, SUCTION_CLOSE_PHASE, GAMMA)
    with pytest.raises(ValueError, match=r"polytropic_exponent.*-1\.1"):
        polytropic_pressure_table(phase, volume, SUCTION_PRESSURE, DISCHARGE_PRESSURE,
                                  SUCTION_CLOSE_PHASE, -1.1)


@pytest.mark.parametrize("clearance", [0.05e-3, 0.2e-3])
def test_outflow_keeps_remaining_gas_isentropic_and_mass_balanced(clearance):
    """Adiabatic outflow leaves the remaining gas isentropic: rho = rho_s (p/p_s)^(1/k),
    T = T_s (p/p_s)^((k-1)/k). The mass m = rho V inferred from the table must drop by
    the time integral of the nozzle outflows (leak to p_s, port to p_d) at that state."""
    phase, volume, pressure = level_half_table(leak_area=clearance * AXIAL_LENGTH)
    closed = phase >= SUCTION_CLOSE_PHASE
    phase, volume, pressure = phase[closed], volume[closed], pressure[closed]
    suction_density = SUCTION_PRESSURE / (GAS_CONSTANT * SUCTION_TEMPERATURE)
    mass = suction_density * (pressure / SUCTION_PRESSURE) ** (1.0 / GAMMA) * volume
    temperature = SUCTION_TEMPERATURE * (pressure / SUCTION_PRESSURE) ** ((GAMMA - 1) / GAMMA)
    outflow = np.array([
        isentropic_nozzle_mass_flow(LEAK_COEFFICIENT, clearance * AXIAL_LENGTH, p, t,
                                    SUCTION_PRESSURE, GAMMA, GAS_CONSTANT)
        + isentropic_nozzle_mass_flow(PORT_COEFFICIENT, PORT_AREA, p, t,
                                      DISCHARGE_PRESSURE, GAMMA, GAS_CONSTANT)
        for p, t in zip(pressure, temperature)])
    time_step = (phase[1] - phase[0]) / ANGULAR_SPEED
    expelled = np.concatenate(([0.0], np.cumsum(outflow[:-1]) * time_step))
    assert expelled[-1] > 0.5 * mass[0]  # most of the charge leaves the chamber
    assert np.max(np.abs(mass[0] - mass - expelled)) < 2e-4 * mass[0]
