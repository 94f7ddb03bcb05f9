"""The tables through the two-phase dome (docs/model.md §7.3.1, §7.4.1) and over a fluid's whole input envelope
(§7.3.2), against CoolProp HEOS.

References: CoolProp's two-phase DmassT states (p, h, Q); c_v and (dp/dT)_rho of the mixture as central differences
of HEOS's u and p at fixed rho (CoolProp's own cvmass() in the dome is not the mixture's); nozzle fluxes from an
isentropic expansion computed here with CoolProp's (p, s) flash. Small grids; the full-size fluid-wide build is
marked slow.
"""
import math

import numpy as np
import pytest

import CoolProp.CoolProp as CP

from rotary_vane.thermo.fluid import Fluid, typical_operating_point
from rotary_vane.thermo.fluid_envelope import fluid_envelope, fluid_grid, input_range
from rotary_vane.thermo.property_table import (STATUS_LIQUID, STATUS_NEAR_SATURATION, STATUS_OK, Envelope,
                                                build_property_table, describe_status, envelope_for,
                                                property_table_for, table_arrays, table_from_arrays, table_quality,
                                                table_state, table_status, with_two_phase)
from rotary_vane.thermo.real_gas_nozzle import (STATUS_THROAT_NEAR_SATURATION, build_nozzle_table, real_gas_mass_flux,
                                                table_viscosity)
from rotary_vane.thermo import real_gas_nozzle
from rotary_vane.thermo.saturation import VAPOUR_VOLUME, saturation_quantity

FLUID = "R134a"
SMALL_ENVELOPE = Envelope(235.0, 380.0, 2.0, 500.0, 1.0)     # the suction side of R134a, through the dome
TEMPERATURES = (240.0, 263.0, 290.0, 320.0, 350.0)
QUALITIES = (0.999, 0.9, 0.7, 0.5, 0.3)


@pytest.fixture(scope="module")
def fluid():
    return Fluid(FLUID)


@pytest.fixture(scope="module")
def heos():
    return CP.AbstractState("HEOS", FLUID)


@pytest.fixture(scope="module")
def table(fluid):
    return with_two_phase(build_property_table(fluid, SMALL_ENVELOPE, 64, 64), True)


@pytest.fixture(scope="module")
def nozzles(fluid):
    return build_nozzle_table(fluid, SMALL_ENVELOPE, 16, 16, 9, two_phase=True)


def saturated_densities(heos, temperature):
    heos.update(CP.QT_INPUTS, 1.0, temperature)
    vapour = heos.rhomass()
    heos.update(CP.QT_INPUTS, 0.0, temperature)
    return vapour, heos.rhomass()


def mixture_density(heos, temperature, quality):
    vapour, liquid = saturated_densities(heos, temperature)
    return 1.0 / (1.0 / liquid + quality * (1.0 / vapour - 1.0 / liquid))


def heos_at(heos, temperature, density, step=1e-4):
    """p, h, Q and, by central differences at fixed rho, c_v = du/dT and dp/dT from HEOS."""
    heos.update(CP.DmassT_INPUTS, density, temperature + step)
    u_plus, p_plus = heos.umass(), heos.p()
    heos.update(CP.DmassT_INPUTS, density, temperature - step)
    u_minus, p_minus = heos.umass(), heos.p()
    heos.update(CP.DmassT_INPUTS, density, temperature)
    return (heos.p(), heos.hmass(), heos.Q(), (u_plus - u_minus) / (2.0 * step), (p_plus - p_minus) / (2.0 * step))


def test_dome_states_agree_with_heos(table, heos, check):
    """p and h within 1e-6, c_v and (dp/dT)_rho within 1e-4 of HEOS, quality within 1e-7, (dp/drho)_T = 0."""
    worst = np.zeros(5)
    for temperature in TEMPERATURES:
        for quality in QUALITIES:
            density = mixture_density(heos, temperature, quality)
            state = table_state(temperature, density, table)
            assert state.status == STATUS_OK
            assert state.pressure_density_derivative == 0.0
            p, h, q, heat_capacity, slope = heos_at(heos, temperature, density)
            assert 0.0 < q < 1.0
            errors = [state.pressure / p - 1.0, state.enthalpy / h - 1.0, state.heat_capacity_v / heat_capacity - 1.0,
                      state.pressure_temperature_derivative / slope - 1.0,
                      table_quality(temperature, density, table) - q]
            worst = np.maximum(worst, np.abs(errors))
    for label, error, limit in zip(("p", "h", "c_v", "(dp/dT)_rho", "quality"), worst,
                                   (1e-6, 1e-6, 1e-4, 1e-4, 1e-7)):
        check(f"dome vs HEOS {label}", error, limit)


def test_dome_heat_capacity_is_the_derivative_of_the_tables_energy(table, heos, check):
    """c_v = (du/dT)_rho of the table's own u = h - p/rho, and (dp/dT)_rho that of its p, inside the dome."""
    worst = np.zeros(2)
    step = 1e-3
    for temperature in TEMPERATURES[:-1]:
        density = mixture_density(heos, temperature, 0.6)
        plus, minus = table_state(temperature + step, density, table), table_state(temperature - step, density, table)
        state = table_state(temperature, density, table)
        energy = [(s.enthalpy - s.pressure / density) for s in (plus, minus)]
        worst = np.maximum(worst, [
            abs((energy[0] - energy[1]) / (2.0 * step) / state.heat_capacity_v - 1.0),
            abs((plus.pressure - minus.pressure) / (2.0 * step) / state.pressure_temperature_derivative - 1.0)])
    check("dome c_v vs du/dT of the table", worst[0], 1e-5)
    check("dome (dp/dT)_rho vs dp/dT of the table", worst[1], 1e-4)


@pytest.mark.parametrize("temperature", (245.0, 300.0, 345.0))
def test_dew_line_is_continuous_and_keeps_its_kink(table, heos, temperature, check):
    """Both sides of the dew line give the same p and h (1e-9), while (dp/drho)_T and c_v jump as HEOS's do."""
    vapour = 1.0 / saturation_quantity(VAPOUR_VOLUME, temperature, table.saturation_temperature_min,
                                       table.inverse_saturation_step, table.saturation_nodes)[0]
    check("dew density vs HEOS", abs(vapour / saturated_densities(heos, temperature)[0] - 1.0), 1e-8)
    offset = 1e-12
    gas = table_state(temperature, vapour * (1.0 - offset), table)
    wet = table_state(temperature, vapour * (1.0 + offset), table)
    assert table_quality(temperature, vapour * (1.0 - offset), table) == 1.0
    assert table_quality(temperature, vapour * (1.0 + offset), table) < 1.0
    check("dew line p continuity", abs(wet.pressure / gas.pressure - 1.0), 1e-9)
    check("dew line h continuity", abs(wet.enthalpy / gas.enthalpy - 1.0), 1e-9)
    # one-sided derivatives: HEOS single phase just outside, the mixture by differences just inside
    heos.update(CP.DmassT_INPUTS, vapour * (1.0 - 1e-6), temperature)
    gas_slope = heos.first_partial_deriv(CP.iP, CP.iDmass, CP.iT)
    gas_heat_capacity = heos.cvmass()
    wet_heat_capacity = heos_at(heos, temperature, vapour * (1.0 + 1e-5))[3]
    assert wet.pressure_density_derivative == 0.0 and gas.pressure_density_derivative > 0.0
    check("dew line gas-side (dp/drho)_T", abs(gas.pressure_density_derivative / gas_slope - 1.0), 1e-4)
    check("dew line gas-side c_v", abs(gas.heat_capacity_v / gas_heat_capacity - 1.0), 1e-5)
    check("dew line wet-side c_v", abs(wet.heat_capacity_v / wet_heat_capacity - 1.0), 1e-3)
    assert wet.heat_capacity_v / gas.heat_capacity_v - 1.0 > 0.1 * (wet_heat_capacity / gas_heat_capacity - 1.0) > 0


def test_statuses_with_and_without_the_dome(fluid, table, heos):
    """Off (the default): the dome is refused as before. On: a mixture is STATUS_OK, a liquid STATUS_LIQUID with NaN
    values and a sentence naming it, the last kelvins below T_crit still STATUS_NEAR_SATURATION."""
    temperature = 280.0
    density = mixture_density(heos, temperature, 0.5)
    assert table_status(temperature, density, with_two_phase(table, False)) == STATUS_NEAR_SATURATION
    assert table_status(temperature, density, table) == STATUS_OK
    liquid = saturated_densities(heos, temperature)[1]
    small = with_two_phase(table._replace(log_density_max=math.log(2.0 * liquid)), True)
    state = table_state(temperature, 1.01 * liquid, small)
    assert state.status == STATUS_LIQUID and math.isnan(state.pressure) and math.isnan(state.enthalpy)
    assert math.isnan(table_quality(temperature, 1.01 * liquid, small))
    text = describe_status(STATUS_LIQUID, temperature, 1.01 * liquid, small, fluid, "leading chamber")
    assert "leading chamber" in text and "liquid" in text
    hot = 0.5 * (table.saturation_temperature_max + fluid.critical_temperature)
    assert fluid.critical_temperature - 10.0 < table.saturation_temperature_max < fluid.critical_temperature
    assert table_status(hot, mixture_density(heos, hot, 0.9), table) == STATUS_NEAR_SATURATION


def test_two_phase_table_crosses_into_compiled_code(table, heos):
    """table_arrays / table_from_arrays (what the time loop takes) keep the saturation line and the flag."""
    rebuilt = table_from_arrays(*table_arrays(table))
    density = mixture_density(heos, 300.0, 0.8)
    assert table_state(300.0, density, rebuilt) == table_state(300.0, density, table)
    assert rebuilt.two_phase == 1.0


def test_cached_table_is_single_phase_unless_asked(fluid, tmp_path, heos):
    envelope = Envelope(240.0, 330.0, 2.0, 100.0, 1.0)
    density = mixture_density(heos, 280.0, 0.8)
    plain = property_table_for(fluid, envelope, 8, 8, cache_dir=tmp_path)
    wet = property_table_for(fluid, envelope, 8, 8, cache_dir=tmp_path, two_phase=True)
    assert len(list(tmp_path.iterdir())) == 1
    assert table_status(280.0, density, plain) == STATUS_NEAR_SATURATION
    assert wet.two_phase == 1.0 and plain.two_phase == 0.0
    assert table_status(280.0, density, wet) != STATUS_NEAR_SATURATION      # (a cell of this 8 x 8 grid may
                                                                             # miss its accuracy check)


def _heos_flux(heos, temperature, quality, ratio):
    """G of the equilibrium isentropic expansion from (T, x) to ratio p0 with p* found on a fine grid of ratios
    (CoolProp's (p, s) flash, h0 - h(p, s0)), and p0, rho0."""
    heos.update(CP.QT_INPUTS, quality, temperature)
    p0, h0, s0, rho0 = heos.p(), heos.hmass(), heos.smass(), heos.rhomass()

    def flux(r):
        heos.update(CP.PSmass_INPUTS, r * p0, s0)
        return heos.rhomass() * math.sqrt(2.0 * (h0 - heos.hmass()))
    ratios = np.linspace(0.3, 0.99, 691)
    fluxes = np.array([flux(r) for r in ratios])
    best = int(np.argmax(fluxes))
    critical = ratios[best]
    return (fluxes[best] if ratio <= critical else flux(ratio)), p0, rho0


@pytest.mark.parametrize("temperature,quality", [(250.0, 0.95), (285.0, 0.7), (320.0, 0.5)])
def test_nozzle_from_a_wet_upstream_state_agrees_with_heos(nozzles, heos, temperature, quality, check):
    """The HEM flux from the table within 1e-3 of the expansion computed here with CoolProp (subsonic and choked)."""
    for ratio in (0.97, 0.8, 0.2):
        expected, p0, rho0 = _heos_flux(heos, temperature, quality, ratio)
        flux, status = real_gas_mass_flux(temperature, rho0, p0, ratio * p0, nozzles)
        assert status == STATUS_OK
        check("HEM nozzle vs HEOS", abs(flux / expected - 1.0), 1e-3)


def test_nozzle_flux_across_the_dew_line(nozzles, heos, check):
    """Just outside the dew line the throat is metastable vapour (status 8), just inside the HEM expansion: the
    flux steps by less than 1 % (docs/model.md §7.4.1); off, a wet upstream state is refused."""
    temperature = 290.0
    vapour, _ = saturated_densities(heos, temperature)
    heos.update(CP.QT_INPUTS, 1.0, temperature)
    pressure = heos.p()
    gas, gas_status = real_gas_mass_flux(temperature, vapour * (1.0 - 1e-9), pressure, 0.3 * pressure, nozzles)
    wet, wet_status = real_gas_mass_flux(temperature, vapour * (1.0 + 1e-9), pressure, 0.3 * pressure, nozzles)
    assert gas_status == STATUS_THROAT_NEAR_SATURATION and wet_status == STATUS_OK
    check("dew line nozzle flux step", abs(wet / gas - 1.0), 1e-2)
    wet_viscosity, wet_status = table_viscosity(temperature, 1.5 * vapour, nozzles)   # the saturated vapour's
    dew_viscosity, dew_status = table_viscosity(temperature, vapour * (1.0 - 1e-9), nozzles)
    assert wet_status == dew_status == STATUS_OK and abs(wet_viscosity / dew_viscosity - 1.0) < 1e-9
    off = real_gas_nozzle.with_two_phase(nozzles, False)
    assert real_gas_mass_flux(temperature, 1.5 * vapour, pressure, 0.3 * pressure, off)[1] == STATUS_NEAR_SATURATION


@pytest.mark.parametrize("name", ("R134a", "R410A", "R1234yf", "R290", "CO2"))
def test_fluid_envelope_holds_the_typical_operating_point(name):
    """The fluid-wide rectangle contains the per-point envelope of the fluid's typical operating point, and the
    operating point lies in the declared input range."""
    fluid = Fluid(name)
    point = typical_operating_point(fluid)
    inputs = input_range(fluid)
    wide = fluid_envelope(fluid)
    own = envelope_for(fluid, *point)
    assert inputs.suction_pressure_min <= point[0] <= inputs.suction_pressure_max
    assert point[2] <= inputs.discharge_pressure_max
    assert wide.temperature_min <= own.temperature_min and wide.temperature_max >= own.temperature_max
    assert wide.density_min <= own.density_min and wide.density_max >= 0.99 * own.density_max
    nodes = fluid_grid(wide)
    assert all(n >= 160 for n in nodes)


def test_fluid_envelope_refuses_a_fluid_without_a_dome_in_range():
    with pytest.raises(ValueError, match="fluid='Air' is out of range"):
        fluid_envelope(Fluid("Air"))


@pytest.mark.slow
def test_fluid_wide_table_is_as_accurate_as_the_per_point_table(fluid, tmp_path, check):
    """Full size: every accepted state of the default operating point's table (random over its envelope) is
    accepted by the fluid-wide table and within the per-point table's bounds of HEOS."""
    own_envelope = envelope_for(fluid, *typical_operating_point(fluid))
    own = property_table_for(fluid, own_envelope, cache_dir=tmp_path)
    wide_envelope = fluid_envelope(fluid)
    wide = property_table_for(fluid, wide_envelope, *fluid_grid(wide_envelope), cache_dir=tmp_path,
                              two_phase=True)
    rng = np.random.default_rng(24)
    temperatures = rng.uniform(own_envelope.temperature_min, own_envelope.temperature_max, 3000)
    densities = np.exp(rng.uniform(math.log(own_envelope.density_min), math.log(own_envelope.density_max), 3000))
    worst = {"own": np.zeros(4), "wide": np.zeros(4)}
    for temperature, density in zip(temperatures, densities):
        if table_status(temperature, density, own) != STATUS_OK:
            continue
        exact = fluid.properties(temperature, density)
        reference = np.array([exact.pressure, exact.enthalpy, exact.isochoric_heat_capacity,
                              exact.pressure_temperature_derivative])
        for label, candidate in (("own", own), ("wide", wide)):
            state = table_state(temperature, density, candidate)
            assert state.status == STATUS_OK, (label, temperature, density)
            values = np.array(state[:4])
            worst[label] = np.maximum(worst[label], np.abs(values / reference - 1.0))
    for k, name in enumerate(("p", "h", "c_v", "(dp/dT)_rho")):
        check(f"fluid-wide table vs HEOS {name} (per point {worst['own'][k]:.1e})", worst["wide"][k],
              max(3.0 * worst["own"][k], 1e-8))


@pytest.mark.parametrize("name", ("R134a", "R290", "CO2"))
def test_fluid_envelope_holds_the_dew_line_and_the_wet_suction_states(name):
    """Every dew point from T_min to below T_crit lies inside the density range (so every mixture is anchored), and
    so do the mixtures of quality 0.5 between the lowest suction and the highest condensing saturation temperature;
    no vapour at p >= p_min is colder than T_min."""
    fluid = Fluid(name)
    wide = fluid_envelope(fluid)
    inputs = input_range(fluid)
    heos = CP.AbstractState("HEOS", fluid.coolprop_name)
    lowest_pressure = max(0.25 * inputs.suction_pressure_min, fluid.dew_pressure(fluid.triple_temperature))
    assert fluid.saturation_temperature(lowest_pressure) >= wide.temperature_min - 1e-9
    hottest = fluid.saturation_temperature(inputs.discharge_pressure_max) or 293.15
    for temperature in np.linspace(wide.temperature_min, fluid.critical_temperature - 1.0, 40):
        vapour, _ = saturated_densities(heos, temperature)
        assert wide.density_min <= vapour <= wide.density_max
        if fluid.saturation_temperature(inputs.suction_pressure_min) <= temperature <= hottest:
            assert mixture_density(heos, temperature, inputs.suction_quality_min) <= wide.density_max


def test_nozzle_table_builds_the_wet_part_only_when_asked(fluid, table, tmp_path, heos):
    """The default (per operating point) nozzle table has no HEM part, and refuses a wet upstream state even with
    the flag switched on; asked with two_phase, the table is another file and takes it."""
    envelope = Envelope(240.0, 330.0, 2.0, 100.0, 1.0)
    plain = real_gas_nozzle.nozzle_table_for(fluid, envelope, 6, 6, 5, cache_dir=tmp_path)
    wet = real_gas_nozzle.nozzle_table_for(fluid, envelope, 6, 6, 5, cache_dir=tmp_path, two_phase=True)
    assert len(list(tmp_path.iterdir())) == 2
    assert plain.two_phase == 0.0 and plain.dome_critical_ratio.shape == (2, 2)
    density = mixture_density(heos, 280.0, 0.9)
    pressure = table_state(280.0, density, table).pressure
    switched = real_gas_nozzle.with_two_phase(plain, True)
    assert real_gas_mass_flux(280.0, density, pressure, 0.5 * pressure, switched)[1] == STATUS_NEAR_SATURATION
    assert real_gas_mass_flux(280.0, density, pressure, 0.5 * pressure, wet)[1] != STATUS_NEAR_SATURATION
