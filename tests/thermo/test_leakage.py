"""thermo.leakage: the leakage laws of the clearance gaps and the gap geometry (docs/model.md §7.4).

References, independent of the code under test:
- PDSim's `FrictionCorrectedIsentropicNozzle` (ibell/pdsim, PDSim/flow/flow_models.pyx, type TYPE_RADIAL): PDSim
  itself cannot be imported here (a Cython extension built against CoolProp's old `State` class), so its formula
  is transcribed below in PDSim's own form (coefficient list, Lstar = t/0.005, delta_star = delta/10e-6) and the
  module must reproduce it wherever it is >= 1 (the module clamps it at 1, a documented decision).
- closed forms: the valley curvature from the offset stator curve of docs/model.md §2.4-§2.5, evaluated numerically
  with the independent harmonic pitch curve of reference_formulas.py; the friction integral by quadrature; the Fanno
  reference against the incompressible limit and a direct ODE integration.
"""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from reference_formulas import HarmonicPitch, pdsim_mdot_ratio

from rotary_vane.thermo.control_volume import LINEAR_FLOW_BAND, signed_nozzle_flow
from rotary_vane.thermo.fluid import Fluid, coolprop
from rotary_vane.thermo.leakage import (LAW_FRICTION_CORRECTED, LAW_NOZZLE, LAW_SEALED, LEAKAGE_LAWS,
                                        darcy_friction_factor, equivalent_discharge_coefficient, equivalent_gap_radius,
                                        fanno_channel_mass_flux, fanno_equivalent_discharge_coefficient,
                                        friction_flow_ratio, friction_length, gap_region_length, gap_reynolds_number,
                                        harmonic_valley_seal_radius, leakage_flux,
                                        pdsim_friction_ratio, signed_leakage_flow, signed_real_gas_leakage_flow,
                                        valley_seal_radius)
from rotary_vane.thermo.nozzle import isentropic_nozzle_mass_flow
from rotary_vane.thermo.property_table import STATUS_OK, envelope_for
from rotary_vane.thermo.real_gas_nozzle import nozzle_table_for, real_gas_mass_flux, signed_real_gas_nozzle_flow

# docs/model.md §7.1, §9: R134a duty and the default machine
SUCTION_PRESSURE, SUCTION_TEMPERATURE, DISCHARGE_PRESSURE = 0.2928e6, 283.15, 1.3179e6
ROTOR_RADIUS, TIP_RADIUS, STROKE, LOBES, AXIAL_LENGTH = 0.030, 0.002, 0.005, 3, 0.055

def r134a_viscosity(pressure, temperature):
    state = coolprop().AbstractState("HEOS", "R134a")
    state.update(coolprop().PT_INPUTS, pressure, temperature)
    return state.viscosity()


@pytest.fixture(scope="module")
def ideal_r134a():
    """(k, R) of R134a at the suction temperature, as Level 1 uses them, and the discharge-side upstream state."""
    fluid = Fluid("R134a")
    entropy = fluid.properties(SUCTION_TEMPERATURE, fluid.density(SUCTION_TEMPERATURE, SUCTION_PRESSURE)).entropy
    discharge_temperature = fluid.state_at_pressure_entropy(DISCHARGE_PRESSURE, entropy).temperature
    return dict(k=fluid.ideal_gas_exponent(SUCTION_TEMPERATURE), R=fluid.gas_constant,
                temperature=discharge_temperature, viscosity=r134a_viscosity(DISCHARGE_PRESSURE, discharge_temperature))


@pytest.fixture(scope="module")
def nozzle_table(tmp_path_factory):
    fluid = Fluid("R134a")
    envelope = envelope_for(fluid, SUCTION_PRESSURE, SUCTION_TEMPERATURE, DISCHARGE_PRESSURE)
    return fluid, nozzle_table_for(fluid, envelope, cache_dir=tmp_path_factory.mktemp("nozzle"))


def test_friction_ratio_reproduces_pdsim():
    checked = clamped = 0
    for delta in (2e-6, 5e-6, 10e-6, 20e-6, 50e-6, 200e-6):
        for length in (0.0, 2e-4, 1.5e-3, 3e-3, 5e-3, 1e-2):
            for reynolds in (0.0, 1e-13, 10.0, 300.0, 2000.0, 5000.0, 5243.58, 5500.0, 8000.0, 2e4, 1e5, 1e6):
                expected = pdsim_mdot_ratio(delta, length, reynolds)
                value = friction_flow_ratio(delta, length, reynolds)
                assert pdsim_friction_ratio(delta, length, reynolds) == pytest.approx(expected, rel=1e-13, abs=0.0)
                if expected >= 1.0:
                    assert value == pytest.approx(expected, rel=1e-13, abs=0.0), (delta, length, reynolds)
                    checked += 1
                else:                             # PDSim would pass more than the isentropic nozzle: clamped
                    assert value == 1.0
                    clamped += 1
    assert checked > 300 and clamped > 10


def test_friction_law_uses_pdsims_reynolds_number(ideal_r134a):
    """Re = (m_dot_nozzle / A) D_h / mu_up with D_h = 2 delta, the ideal-gas nozzle flux and the upstream viscosity."""
    gas = ideal_r134a
    for delta, length, downstream in ((10e-6, 3e-3, SUCTION_PRESSURE), (5e-6, 2e-3, 1.25e6), (20e-6, 1e-3, 1.3e6)):
        flux = isentropic_nozzle_mass_flow(1.0, 1.0, DISCHARGE_PRESSURE, gas["temperature"], downstream, gas["k"],
                                           gas["R"])
        reynolds = flux * 2.0 * delta / gas["viscosity"]
        assert gap_reynolds_number(flux, delta, gas["viscosity"]) == pytest.approx(reynolds, rel=1e-15)
        expected = flux / max(1.0, pdsim_mdot_ratio(delta, length, reynolds))
        assert leakage_flux(LAW_FRICTION_CORRECTED, 0.3, delta, length, flux, gas["viscosity"]) == pytest.approx(
            expected, rel=1e-13)
        assert equivalent_discharge_coefficient(delta, length, DISCHARGE_PRESSURE, gas["temperature"], downstream,
                                                gas["k"], gas["R"], gas["viscosity"]) == pytest.approx(
            expected / flux, rel=1e-13)
        assert equivalent_discharge_coefficient(delta, length, DISCHARGE_PRESSURE, gas["temperature"], downstream,
                                                gas["k"], gas["R"], gas["viscosity"], law="nozzle",
                                                discharge_coefficient=0.65) == pytest.approx(0.65, rel=1e-15)


def test_nozzle_law_is_todays_path(nozzle_table):
    """"nozzle" through delta W is exactly control_volume.signed_nozzle_flow (ideal gas) and
    signed_real_gas_nozzle_flow (real gas) through A = delta W."""
    fluid, table = nozzle_table
    rng = np.random.default_rng(3)
    for _ in range(50):
        delta, width = rng.uniform(0.0, 2e-4), rng.uniform(0.01, 0.1)
        pa, pb = rng.uniform(0.3e6, 1.3e6, 2)
        ta, tb = (fluid.saturation_temperature(p) + rng.uniform(5.0, 40.0) for p in (pa, pb))
        ideal = signed_leakage_flow(LAW_NOZZLE, 0.65, delta, 2e-3, width, pa, ta, pb, tb, 1.11, 81.5, 1e-5, 1e-5)
        assert ideal == signed_nozzle_flow(0.65, delta * width, pa, ta, pb, tb, 1.11, 81.5)
        ra, rb = fluid.density(ta, pa), fluid.density(tb, pb)
        real = signed_real_gas_leakage_flow(LAW_NOZZLE, 0.65, delta, 2e-3, width, ta, ra, pa, tb, rb, pb, table)
        assert real[1] == STATUS_OK
        assert real == signed_real_gas_nozzle_flow(0.65, delta * width, ta, ra, pa, tb, rb, pb, table)


def test_short_gap_is_the_nozzle(ideal_r134a):
    gas = ideal_r134a
    for downstream in (SUCTION_PRESSURE, 0.9 * DISCHARGE_PRESSURE, 0.999 * DISCHARGE_PRESSURE):
        for delta in (5e-6, 50e-6, 200e-6):
            assert equivalent_discharge_coefficient(delta, 0.0, DISCHARGE_PRESSURE, gas["temperature"], downstream,
                                                    gas["k"], gas["R"], gas["viscosity"]) == 1.0
            assert fanno_equivalent_discharge_coefficient(delta, 0.0, DISCHARGE_PRESSURE, gas["temperature"],
                                                          downstream, gas["k"], gas["R"],
                                                          gas["viscosity"]) == pytest.approx(1.0, rel=1e-9)
        # and C_d,eq falls as the gap gets longer, to 1 as it gets shorter
        lengths = np.linspace(0.0, 1e-2, 41)
        values = [equivalent_discharge_coefficient(10e-6, length, DISCHARGE_PRESSURE, gas["temperature"], downstream,
                                                   gas["k"], gas["R"], gas["viscosity"]) for length in lengths]
        assert np.all(np.diff(values) <= 0.0) and values[0] == 1.0 and values[-1] < 0.5


def test_monotone_in_gap_height_and_pressure_ratio(ideal_r134a, nozzle_table):
    gas = ideal_r134a
    fluid, table = nozzle_table
    seal_radius = harmonic_valley_seal_radius(ROTOR_RADIUS, TIP_RADIUS, STROKE, LOBES)
    temperature, pressure = gas["temperature"], DISCHARGE_PRESSURE
    density = fluid.density(temperature, pressure)
    suction_density = fluid.density(SUCTION_TEMPERATURE, SUCTION_PRESSURE)
    gaps = np.linspace(1e-6, 3e-4, 300)
    for length_of in (lambda delta: friction_length(delta, seal_radius), lambda delta: 3e-3):
        ideal = [signed_leakage_flow(LAW_FRICTION_CORRECTED, 1.0, d, length_of(d), AXIAL_LENGTH, pressure,
                                     temperature, SUCTION_PRESSURE, SUCTION_TEMPERATURE, gas["k"], gas["R"],
                                     gas["viscosity"], 1e-5) for d in gaps]
        real = [signed_real_gas_leakage_flow(LAW_FRICTION_CORRECTED, 1.0, d, length_of(d), AXIAL_LENGTH, temperature,
                                             density, pressure, SUCTION_TEMPERATURE, suction_density,
                                             SUCTION_PRESSURE, table)[0] for d in gaps]
        assert np.all(np.diff(ideal) > 0.0) and np.all(np.diff(real) > 0.0)
    ratios = np.linspace(0.02, 1.0, 2000)
    for delta in (2e-6, 10e-6, 50e-6, 200e-6):
        length = friction_length(delta, seal_radius)
        ideal = [signed_leakage_flow(LAW_FRICTION_CORRECTED, 1.0, delta, length, AXIAL_LENGTH, pressure, temperature,
                                     r * pressure, temperature, gas["k"], gas["R"], gas["viscosity"], 1e-5)
                 for r in ratios]
        real = [signed_real_gas_leakage_flow(LAW_FRICTION_CORRECTED, 1.0, delta, length, AXIAL_LENGTH, temperature,
                                             density, pressure, temperature, density, r * pressure, table)[0]
                for r in ratios]
        assert np.all(np.diff(ideal) <= 0.0) and np.all(np.diff(real) <= 0.0), delta
        assert ideal[-1] == 0.0 and real[-1] == 0.0


def test_signed_friction_flow_symmetry_band_and_closed_gap(nozzle_table):
    fluid, table = nozzle_table
    arguments = (LAW_FRICTION_CORRECTED, 1.0, 20e-6, 1.45e-3, AXIAL_LENGTH)
    forward = signed_leakage_flow(*arguments, 1.0e6, 330.0, 0.5e6, 300.0, 1.11, 81.5, 1.3e-5, 1.2e-5)
    backward = signed_leakage_flow(*arguments, 0.5e6, 300.0, 1.0e6, 330.0, 1.11, 81.5, 1.2e-5, 1.3e-5)
    assert forward > 0.0 and backward == -forward
    assert signed_leakage_flow(LAW_FRICTION_CORRECTED, 1.0, 0.0, 1e-3, AXIAL_LENGTH, 1e6, 330.0, 0.5e6, 300.0, 1.11,
                               81.5, 1e-5, 1e-5) == 0.0
    band = LINEAR_FLOW_BAND * 1.0e6
    edge = signed_leakage_flow(*arguments, 1.0e6, 330.0, 1.0e6 - band, 300.0, 1.11, 81.5, 1.3e-5, 1.2e-5)
    for fraction in (0.0, 0.25, 0.999999):
        inside = signed_leakage_flow(*arguments, 1.0e6, 330.0, 1.0e6 - fraction * band, 300.0, 1.11, 81.5, 1.3e-5,
                                     1.2e-5)
        assert inside == pytest.approx(fraction * edge, rel=1e-12, abs=0.0)
    density_a, density_b = fluid.density(330.0, 1.0e6), fluid.density(300.0, 0.5e6)
    real_forward, status = signed_real_gas_leakage_flow(*arguments, 330.0, density_a, 1.0e6, 300.0, density_b, 0.5e6,
                                                        table)
    real_backward, _ = signed_real_gas_leakage_flow(*arguments, 300.0, density_b, 0.5e6, 330.0, density_a, 1.0e6,
                                                    table)
    assert status == STATUS_OK and real_forward > 0.0 and real_backward == -real_forward
    flux = real_gas_mass_flux(330.0, density_a, 1.0e6, 0.5e6, table)[0]
    reynolds = flux * 2.0 * 20e-6 / r134a_viscosity(1.0e6, 330.0)
    expected = 20e-6 * AXIAL_LENGTH * flux / max(1.0, pdsim_mdot_ratio(20e-6, 1.45e-3, reynolds))
    assert real_forward == pytest.approx(expected, rel=1e-3)          # the table's viscosity: bilinear
    assert signed_real_gas_leakage_flow(*arguments, 330.0, density_a, 1.0e6, 300.0, density_b, 1.0e6,
                                        table)[0] == 0.0


def test_sealed_law_passes_nothing_whatever_the_states(ideal_r134a, nozzle_table):
    """"sealed" (an oil-sealed path) gives 0 at any gap and pressure difference, and status 0 even for an upstream
    state the table refuses (T = 1 K): it costs no look-up; C_d,eq = 0."""
    gas = ideal_r134a
    fluid, table = nozzle_table
    assert signed_leakage_flow(LAW_SEALED, 0.65, 50e-6, 1e-3, AXIAL_LENGTH, 1.0e6, 330.0, 0.3e6, 300.0, gas["k"],
                               gas["R"], 1.3e-5, 1.2e-5) == 0.0
    density = fluid.density(330.0, 1.0e6)
    assert signed_real_gas_leakage_flow(LAW_SEALED, 0.65, 50e-6, 1e-3, AXIAL_LENGTH, 330.0, density, 1.0e6, 1.0,
                                        1.0, 0.3e6, table) == (0.0, STATUS_OK)
    assert signed_real_gas_leakage_flow(LAW_NOZZLE, 0.65, 50e-6, 1e-3, AXIAL_LENGTH, 1.0, 1.0, 1.0e6, 1.0,
                                        1.0, 0.3e6, table)[1] != STATUS_OK
    assert equivalent_discharge_coefficient(50e-6, 1e-3, 1e6, 330.0, 0.3e6, gas["k"], gas["R"], gas["viscosity"],
                                            law="sealed") == 0.0


# --- the Fanno-channel reference --------------------------------------------------------------------------

def test_fanno_reference_incompressible_limit(ideal_r134a):
    """Small pressure difference: G = sqrt(2 rho0 dp / (1 + f_D L / D_h)) (Bernoulli with the friction loss)."""
    gas = ideal_r134a
    density = DISCHARGE_PRESSURE / (gas["R"] * gas["temperature"])
    for delta, length in ((20e-6, 1.45e-3), (100e-6, 3.2e-3), (5e-6, 3e-3)):
        drop = 1e-5 * DISCHARGE_PRESSURE
        flux = fanno_channel_mass_flux(delta, length, DISCHARGE_PRESSURE, gas["temperature"],
                                       DISCHARGE_PRESSURE - drop, gas["k"], gas["R"], gas["viscosity"])
        friction = darcy_friction_factor(flux * 2 * delta / gas["viscosity"]) * length / (2 * delta)
        assert flux == pytest.approx(math.sqrt(2 * density * drop / (1 + friction)), rel=1e-4)


def test_fanno_reference_against_the_ode(ideal_r134a):
    """The closed-form Fanno solution agrees with integrating dM^2/dx and dp/dx of adiabatic flow with friction
    (Shapiro): dM^2/M^2 = k M^2 (1 + (k-1)/2 M^2)/(1 - M^2) f dx/D,  dp/p = -k M^2 (1 + (k-1) M^2)/(2 (1 - M^2)) f dx/D."""
    gas = ideal_r134a
    k, gas_constant = gas["k"], gas["R"]
    delta, length, downstream = 20e-6, 1.45e-3, 0.9e6
    flux = fanno_channel_mass_flux(delta, length, DISCHARGE_PRESSURE, gas["temperature"], downstream, k,
                                   gas_constant, gas["viscosity"])
    friction = darcy_friction_factor(flux * 2 * delta / gas["viscosity"]) / (2 * delta)
    # inlet Mach number from the isentropic entrance
    from scipy.optimize import brentq
    mach = brentq(lambda m: DISCHARGE_PRESSURE * math.sqrt(k / (gas_constant * gas["temperature"])) * m
                  * (1 + 0.5 * (k - 1) * m * m) ** (-(k + 1) / (2 * (k - 1))) - flux, 1e-6, 1.0)
    inlet_pressure = DISCHARGE_PRESSURE * (1 + 0.5 * (k - 1) * mach * mach) ** (-k / (k - 1))

    def rates(x, y):
        m2, log_p = y
        common = k * m2 / (1 - m2) * friction
        return [m2 * common * (1 + 0.5 * (k - 1) * m2), -0.5 * common * (1 + (k - 1) * m2)]
    solution = solve_ivp(rates, (0.0, length), [mach * mach, math.log(inlet_pressure)], rtol=1e-11, atol=1e-14)
    assert math.exp(solution.y[1, -1]) == pytest.approx(downstream, rel=1e-7)


def test_correlation_and_fanno_reference_agree_where_pdsim_fitted_it(ideal_r134a):
    """Choked R134a leak through scroll-like radial gaps (10-20 um, 2-5 mm, turbulent): the hybrid model and the
    Fanno channel give the same friction ratio within 15 %; outside that range they part (docs/model.md §7.4)."""
    gas = ideal_r134a
    for delta in (10e-6, 20e-6):
        for length in (2e-3, 3e-3, 5e-3):
            hybrid = 1.0 / equivalent_discharge_coefficient(delta, length, DISCHARGE_PRESSURE, gas["temperature"],
                                                            SUCTION_PRESSURE, gas["k"], gas["R"], gas["viscosity"])
            fanno = 1.0 / fanno_equivalent_discharge_coefficient(delta, length, DISCHARGE_PRESSURE,
                                                                 gas["temperature"], SUCTION_PRESSURE, gas["k"],
                                                                 gas["R"], gas["viscosity"])
            assert hybrid == pytest.approx(fanno, rel=0.15), (delta, length)


# --- geometry --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("clearance", [0.0, 0.2e-3])
@pytest.mark.parametrize("lobes", [3, 5])
def test_valley_seal_radius_from_the_stator_contour(clearance, lobes):
    """Radial gap |S(u)| - R_r of the offset stator S = C + d n (docs/model.md §2.5, reference_formulas' harmonic pitch
    curve) near the valley, fitted as c + b phi^2 over the polar angle phi: R = R_r^2 / (2 b)."""
    pitch = HarmonicPitch(ROTOR_RADIUS - TIP_RADIUS, STROKE, lobes)
    offset = TIP_RADIUS + clearance
    u = np.linspace(-0.01, 0.01, 401)
    stator = pitch.point(u) + offset * pitch.normal(u)
    angle = np.arctan2(stator[1], stator[0])
    gap = np.hypot(stator[0], stator[1]) - ROTOR_RADIUS
    coefficients = np.polyfit(angle, gap, 4)
    assert coefficients[-1] == pytest.approx(clearance, abs=1e-12)
    numeric = ROTOR_RADIUS ** 2 / (2 * coefficients[-3])
    expected = harmonic_valley_seal_radius(ROTOR_RADIUS, TIP_RADIUS, STROKE, lobes, clearance)
    assert expected == pytest.approx(numeric, rel=2e-3 + 2 * clearance / ROTOR_RADIUS)
    if lobes == 3 and clearance == 0.0:
        assert expected == pytest.approx(37.86e-3, abs=0.01e-3)          # "about 38 mm" (issue 14)


def test_friction_length_is_the_friction_integral():
    for delta, radius_a, radius_b, flat in ((20e-6, 0.038, 0.038, 0.0), (0.1e-3, 0.038, 0.002, 0.0),
                                            (50e-6, 0.03, 0.02, 1.5e-3)):
        def integrand(x, radius):
            return delta ** 3 / (delta + x * x / (2 * radius)) ** 3
        flanks = quad(integrand, 0.0, np.inf, args=(radius_a,), epsabs=0, epsrel=1e-12)[0] + quad(
            integrand, 0.0, np.inf, args=(radius_b,), epsabs=0, epsrel=1e-12)[0]
        assert friction_length(delta, radius_a, radius_b, flat) == pytest.approx(flat + flanks, rel=1e-9)
    # the symmetric line seal: (3 pi / 8) sqrt(2 R delta), and 1.70 of it is where h <= 2 delta
    assert friction_length(20e-6, 0.038) == pytest.approx(3 * math.pi / 8 * math.sqrt(2 * 0.038 * 20e-6), rel=1e-14)
    assert gap_region_length(20e-6, 0.038, 2.0) == pytest.approx(2 * math.sqrt(2 * 0.038 * 20e-6), rel=1e-14)


def test_equivalent_gap_radius():
    assert equivalent_gap_radius(0.03) == 0.03
    assert equivalent_gap_radius(0.03, 0.1445) == pytest.approx(0.03 * 0.1445 / (0.1445 - 0.03), rel=1e-14)
    # the valley: rotor against the stator's own radius of curvature 1/kappa_C + d (docs/model.md §2.5)
    base = ROTOR_RADIUS - TIP_RADIUS
    kappa = (base - 0.5 * STROKE * LOBES ** 2) / base ** 2
    assert equivalent_gap_radius(ROTOR_RADIUS, 1 / kappa + TIP_RADIUS) == pytest.approx(
        harmonic_valley_seal_radius(ROTOR_RADIUS, TIP_RADIUS, STROKE, LOBES), rel=1e-12)


def test_bad_arguments_name_the_variable(ideal_r134a):
    gas = ideal_r134a
    codes = [LEAKAGE_LAWS.code(name, "tip_leak_law") for name in LEAKAGE_LAWS]
    assert codes == [LAW_NOZZLE, LAW_FRICTION_CORRECTED, LAW_SEALED]
    with pytest.raises(ValueError, match="'tip_leak_law' = 'fanno'.*nozzle, friction_corrected, sealed"):
        LEAKAGE_LAWS.code("fanno", "tip_leak_law")
    with pytest.raises(ValueError, match="gap_height=-1e-05"):
        friction_length(-1e-5, 0.038)
    with pytest.raises(ValueError, match="concave_radius=0.02"):
        equivalent_gap_radius(0.03, 0.02)
    with pytest.raises(ValueError, match="tip_radius=0.04"):
        valley_seal_radius(0.03, 0.04, 0.0, 0.0)
    with pytest.raises(ValueError, match="lobes=0"):
        harmonic_valley_seal_radius(0.03, 0.002, 0.005, 0)
    with pytest.raises(ValueError, match="downstream_pressure=2000000.0"):
        equivalent_discharge_coefficient(20e-6, 1e-3, 1e6, 330.0, 2e6, gas["k"], gas["R"], gas["viscosity"])
    with pytest.raises(ValueError, match="viscosity=0.0"):
        fanno_channel_mass_flux(20e-6, 1e-3, 1e6, 330.0, 0.5e6, gas["k"], gas["R"], 0.0)
    with pytest.raises(ValueError, match="discharge_coefficient=1.5"):
        equivalent_discharge_coefficient(20e-6, 1e-3, 1e6, 330.0, 0.5e6, gas["k"], gas["R"], gas["viscosity"],
                                         law="nozzle", discharge_coefficient=1.5)
