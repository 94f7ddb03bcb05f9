"""thermo.fluid: the CoolProp HEOS fluid (docs/model.md §7.1, §7.3, §7.4, §11 T19) and the operating-point check.

References are independent of the code under test: textbook gas constants and heat-capacity ratios, docs/model.md's
CoolProp check values (computed there with PropsSI, another code path), thermodynamic identities (Maxwell-type
finite differences, ideal-gas limits, round trips between flashes).
"""
import math

import pytest

from rotary_vane.thermo.fluid import SUPERHEAT_MARGIN, Fluid, check_operating_point

REQUIRED_FLUIDS = ("R134a", "Air", "R410A", "R1234yf", "R290", "CO2")
MODEL_DOC_SUCTION = (0.2928e6, 283.15, 1.3179e6)           # docs/model.md §7.1: p_s, T_s, p_d for R134a


@pytest.fixture(scope="module")
def fluids():
    return {name: Fluid(name) for name in REQUIRED_FLUIDS}


def test_default_fluid_is_r134a():
    assert Fluid().coolprop_name == "R134a"


@pytest.mark.parametrize("name", ["R134b", "", "R32&R125", 42])
def test_unknown_or_mixed_fluid_names_are_refused_with_how_to_list_them(name):
    with pytest.raises(ValueError, match=r"fluid=.*FluidsList"):
        Fluid(name)


def test_gas_constant_is_universal_constant_over_molar_mass(fluids, check):
    # textbook specific gas constants: R134a 81.49 J/(kg K) (M = 102.03 g/mol), air 287.05, CO2 188.92
    for name, reference in (("R134a", 81.49), ("Air", 287.05), ("CO2", 188.92)):
        check(f"gas constant {name}", abs(fluids[name].gas_constant / reference - 1.0), 3e-4)


def test_spec_saturation_check_values(fluids, check):
    # docs/model.md §7.1: PropsSI('P','T',273.15,'Q',1,'R134a') = 292 803 Pa, ...323.15... = 1 317 905 Pa
    r134a = fluids["R134a"]
    check("T_sat(292803 Pa) - 273.15 K", abs(r134a.saturation_temperature(292803.0) - 273.15), 2e-4)
    check("T_sat(1317905 Pa) - 323.15 K", abs(r134a.saturation_temperature(1317905.0) - 323.15), 2e-4)
    check("p_dew(273.15 K) vs docs/model.md §7.1", abs(r134a.dew_pressure(273.15) / 292803.0 - 1.0), 2e-6)


@pytest.mark.parametrize("name", REQUIRED_FLUIDS)
def test_dew_line_round_trip_and_above_critical(fluids, name, check):
    fluid = fluids[name]
    temperature = 0.5 * (fluid.triple_temperature + fluid.critical_temperature)
    pressure = fluid.dew_pressure(temperature)
    check("dew line T -> p -> T", abs(fluid.saturation_temperature(pressure) - temperature) / temperature, 1e-8)
    # the saturated vapour is the limit of the superheated gas at that pressure
    dew_density = fluid.dew_density(temperature)
    just_superheated = fluid.density(temperature + 1e-4, pressure)
    check("dew density vs gas at +0.1 mK", abs(just_superheated / dew_density - 1.0), 1e-4)
    assert fluid.saturation_temperature(1.01 * fluid.critical_pressure) is None
    with pytest.raises(ValueError, match="temperature="):
        fluid.dew_density(fluid.critical_temperature + 1.0)


@pytest.mark.parametrize("name", REQUIRED_FLUIDS)
def test_pressure_temperature_derivative_matches_finite_difference(fluids, name, check):
    # docs/model.md §11 T19: CoolProp (dp/dT)_rho vs a central difference of p at constant rho (1e-6)
    fluid = fluids[name]
    pressure = 2.0 * (fluid.dew_pressure(0.8 * fluid.critical_temperature)
                      if 0.8 * fluid.critical_temperature > fluid.triple_temperature else 1e5)
    for temperature in (fluid.critical_temperature + 20.0,
                        min(1.3 * fluid.critical_temperature, fluid.maximum_temperature - 1.0)):
        density = fluid.density(temperature, pressure)
        step = 1e-3
        difference = (fluid.properties(temperature + step, density).pressure
                      - fluid.properties(temperature - step, density).pressure) / (2.0 * step)
        exact = fluid.properties(temperature, density).pressure_temperature_derivative
        check("T19 (dp/dT)_rho vs finite difference", abs(difference / exact - 1.0), 1e-6)


def test_heat_capacities_obey_the_thermodynamic_identity(fluids, check):
    # c_p - c_v = T (dp/dT)_rho^2 / (rho^2 (dp/drho)_T), with (dp/drho)_T by a central difference
    fluid = fluids["R134a"]
    temperature, density = 320.0, 30.0
    state = fluid.properties(temperature, density)
    step = 1e-4 * density
    slope = (fluid.properties(temperature, density + step).pressure
             - fluid.properties(temperature, density - step).pressure) / (2.0 * step)
    identity = temperature * state.pressure_temperature_derivative ** 2 / (density ** 2 * slope)
    difference = state.isobaric_heat_capacity - state.isochoric_heat_capacity
    check("c_p - c_v identity", abs(identity / difference - 1.0), 1e-6)


def test_ideal_gas_exponent_textbook_values_and_dilute_limit(fluids, check):
    air = fluids["Air"]
    check("k of air at 300 K vs 1.400", abs(air.ideal_gas_exponent(300.0) - 1.400), 2e-3)
    # c_p0 depends on T only and is the dilute limit of c_p: k -> c_p/c_v as rho -> 0 (R of the EOS vs 8314.462/M)
    for name in ("R134a", "CO2", "R290"):
        fluid = fluids[name]
        temperature = fluid.critical_temperature
        dilute = fluid.properties(temperature, 1e-6 * fluid.critical_density)
        ratio = dilute.isobaric_heat_capacity / dilute.isochoric_heat_capacity
        check(f"k dilute limit {name}", abs(fluid.ideal_gas_exponent(temperature) / ratio - 1.0), 1e-5)
    # k falls as T rises (more internal degrees of freedom are excited)
    r134a = fluids["R134a"]
    assert r134a.ideal_gas_exponent(250.0) > r134a.ideal_gas_exponent(400.0) > 1.0


def test_isentropic_and_pressure_temperature_flashes_round_trip(fluids, check):
    fluid = fluids["R134a"]
    suction_pressure, suction_temperature, discharge_pressure = MODEL_DOC_SUCTION
    density = fluid.density(suction_temperature, suction_pressure)
    suction = fluid.properties(suction_temperature, density)
    check("p(T, rho(T, p)) = p", abs(suction.pressure / suction_pressure - 1.0), 1e-10)
    end = fluid.state_at_pressure_entropy(discharge_pressure, suction.entropy)
    exact_end = fluid.properties(end.temperature, end.density)
    check("isentrope end pressure", abs(exact_end.pressure / discharge_pressure - 1.0), 1e-8)
    check("isentrope end entropy", abs(exact_end.entropy / suction.entropy - 1.0), 1e-8)
    check("isentropic enthalpy", abs(fluid.isentropic_enthalpy(discharge_pressure, suction.entropy)
                                     / exact_end.enthalpy - 1.0), 1e-8)
    assert end.temperature > suction_temperature and exact_end.enthalpy > suction.enthalpy


def test_isentrope_of_dilute_air_follows_the_ideal_gas_law(fluids, check):
    # air at 1-5 bar is nearly ideal with nearly constant k: T2/T1 = (p2/p1)^((k-1)/k) to a few 1e-3
    air = fluids["Air"]
    entropy = air.properties(293.15, air.density(293.15, 101325.0)).entropy
    end = air.state_at_pressure_entropy(5e5, entropy)
    k = air.ideal_gas_exponent(0.5 * (293.15 + end.temperature))
    check("air isentrope vs ideal gas", abs(end.temperature / (293.15 * (5e5 / 101325.0) ** ((k - 1) / k)) - 1), 3e-3)


def test_two_phase_state_is_refused_by_properties(fluids):
    fluid = fluids["R134a"]
    midway = 0.5 * (fluid.dew_density(273.15) + 1000.0)
    assert 0.0 < fluid.vapour_quality(273.15, midway) < 1.0
    with pytest.raises(ValueError, match="two-phase"):
        fluid.properties(273.15, midway)
    assert fluid.vapour_quality(300.0, 1.0) is None


@pytest.mark.parametrize("method, args, name", [
    ("properties", (-1.0, 1.0), "temperature"), ("properties", (300.0, 0.0), "density"),
    ("properties", (float("nan"), 1.0), "temperature"), ("density", (300.0, -5.0), "pressure"),
    ("saturation_temperature", ("x",), "pressure"), ("state_at_pressure_entropy", (1e5, math.inf), "entropy"),
    ("properties", (1e4, 1.0), "temperature"),
])
def test_bad_state_inputs_name_the_variable(fluids, method, args, name):
    with pytest.raises(ValueError, match=rf"{name}=.*allowed"):
        getattr(fluids["R134a"], method)(*args)


def test_spec_operating_points_are_accepted(fluids, check):
    check("docs/model.md §7.1 suction superheat 10 K", abs(check_operating_point(fluids["R134a"], *MODEL_DOC_SUCTION) - 10.0), 0.01)
    assert check_operating_point(fluids["Air"], 101325.0, 293.15, 5e5) > 100.0
    # supercritical suction gas (CO2 above p_crit and T_crit) is outside the dome: accepted
    assert check_operating_point(fluids["CO2"], 8e6, 350.0, 12e6) > 40.0


@pytest.mark.parametrize("name", REQUIRED_FLUIDS)
def test_superheat_margin_is_enforced_at_the_suction(fluids, name):
    fluid = fluids[name]
    suction_pressure = 0.3 * fluid.critical_pressure
    dew = fluid.saturation_temperature(suction_pressure)
    check_operating_point(fluid, suction_pressure, dew + SUPERHEAT_MARGIN + 0.01, 2.0 * suction_pressure)
    with pytest.raises(ValueError, match=r"suction_temperature=.*allowed: >= .*dew temperature"):
        check_operating_point(fluid, suction_pressure, dew + 0.5 * SUPERHEAT_MARGIN, 2.0 * suction_pressure)


def test_operating_point_errors_name_variable_value_and_range(fluids):
    r134a, co2 = fluids["R134a"], fluids["CO2"]
    p_s, t_s, p_d = MODEL_DOC_SUCTION
    with pytest.raises(ValueError, match=r"discharge_pressure=292800\.0 .*allowed: > suction_pressure"):
        check_operating_point(r134a, p_s, t_s, p_s)
    with pytest.raises(ValueError, match=r"discharge_pressure=100000\.0 .*allowed: > suction_pressure"):
        check_operating_point(r134a, p_s, t_s, 1e5)
    for args, name in (((-p_s, t_s, p_d), "suction_pressure"), ((p_s, 0.0, p_d), "suction_temperature"),
                       ((p_s, t_s, float("nan")), "discharge_pressure"), ((p_s, None, p_d), "suction_temperature")):
        with pytest.raises(ValueError, match=rf"{name}=.*allowed: a finite number > 0"):
            check_operating_point(r134a, *args)
    # above the critical pressure a gas must be above the critical temperature (colder is a compressed liquid)
    with pytest.raises(ValueError, match=r"suction_temperature=300\.0 .*critical"):
        check_operating_point(co2, 8e6, 300.0, 12e6)
    # wet suction: T_s at the dew point
    with pytest.raises(ValueError, match=r"suction_temperature=273\.15 .*dew temperature"):
        check_operating_point(r134a, 292803.0, 273.15, p_d)
