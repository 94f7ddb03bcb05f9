"""Level 1: real-gas chambers coupled to the vane (issue 3; docs/model.md §7, §11 T19).

Checks: per-revolution mass and energy conservation with every flow path open; a closed chamber compressed by the
mechanism follows CoolProp's isentrope; the control-volume equations against closed forms; the nozzle paths'
continuity; agreement with the Level 0.5 recipe for a nearly ideal gas; the clearance trends of T14; bad input.
"""
import math

import CoolProp
import numpy as np
import pytest
from scipy.optimize import brentq

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.errors import IntegrationError
from rotary_vane.mechanics.loop.layout import GAS_BLOCK
from rotary_vane.mechanics.loop.outputs import OUTPUT_INDEX
from rotary_vane.mechanics.performance import revolutions
from rotary_vane.thermo.chamber_model import LEADING_MASS, LEADING_TEMPERATURE, TRAILING_MASS, TRAILING_TEMPERATURE
from rotary_vane.thermo.control_volume import LINEAR_FLOW_BAND, chamber_derivatives, signed_nozzle_flow

OPERATING = dict(pressure_model="real_gas", slot_clearance=5e-5, stator_clearance=5e-5)


def run(revs=4, rpm=1500.0, **changes):
    params = CompressorParameters(**{**OPERATING, **changes})
    sim = Simulation(params, constant_speed(rpm))
    sim.advance(revs * 60.0 / rpm)
    return sim


@pytest.fixture(scope="module")
def nominal():
    return run()


def test_mass_is_conserved_per_revolution(nominal):
    """T19: |sum m_in - sum m_out - dm| per revolution < 1e-9 kg, every path open (ports, valve, leaks)."""
    for rev in revolutions(nominal):
        delivered = rev.discharge_mass_flow * (rev.end_time - rev.start_time)
        assert delivered > 1e-5
        assert abs(rev.gas_mass_residual * delivered) < 1e-9


def test_energy_is_conserved_per_revolution(nominal):
    """T19: sum(m h)_in - sum(m h)_out + W_pv - dU = 0 to 1e-4 of the compression work, per revolution."""
    for rev in revolutions(nominal):
        assert abs(rev.gas_energy_residual) < 1e-4


def test_steady_state_within_a_few_revolutions(nominal):
    """From suction conditions the per-revolution means settle: revolutions 3 and 4 agree within 0.1 %."""
    third, fourth = revolutions(nominal)[-2:]
    for name in ("input_power", "output_power", "discharge_mass_flow"):
        assert abs(getattr(fourth, name) / getattr(third, name) - 1.0) < 1e-3, name


def test_gas_power_matches_the_chambers_pv_work(nominal):
    """P_out (gas forces on vane and rotor, docs/model.md §6.4) and the chambers' -sum p dV/dt differ only by the work of
    the load-free gaps and the back chamber, which is small: within 2 %."""
    rev = revolutions(nominal)[-1]
    assert abs(rev.indicated_power / rev.output_power - 1.0) < 0.02


def test_per_revolution_figures_against_coolprop(nominal):
    """docs/model.md §6.4 with CoolProp's own flashes: the discharge temperature is T(p_d, h_d) of the HmassP flash to
    1e-6 K (its convergence error is up to 4e-7 K), and eta_is = m_dot_d (h(p_d, s_1) - h_1) / <P_in> to 1e-9."""
    p = nominal.params
    state = CoolProp.AbstractState("HEOS", p.fluid)
    state.update(CoolProp.PT_INPUTS, p.suction_pressure, p.suction_temperature)
    suction_enthalpy, suction_entropy = state.hmass(), state.smass()
    state.update(CoolProp.PSmass_INPUTS, p.discharge_pressure, suction_entropy)
    isentropic_enthalpy = state.hmass()
    for rev in revolutions(nominal):
        state.update(CoolProp.HmassP_INPUTS, rev.discharge_enthalpy, p.discharge_pressure)
        assert abs(rev.discharge_temperature - state.T()) < 1e-6
        assert rev.discharge_temperature > p.suction_temperature + 40.0
        expected = rev.discharge_mass_flow * (isentropic_enthalpy - suction_enthalpy) / rev.input_power
        assert rev.isentropic_efficiency == pytest.approx(expected, rel=1e-9)


def test_a_refused_chamber_state_stops_the_run_with_its_exact_vapour_quality():
    """On per-point tables (a discharge pressure above R134a's declared input range, 2.12 MPa) a chamber pushed
    into the dome stops the run; the message names the chamber and its vapour quality, which comes from CoolProp
    (made only then: the run itself needs no CoolProp once its data are cached)."""
    sim = run(revs=0.025, discharge_pressure=2.5e6)
    assert sim.gas.input_range is None
    sim.state[GAS_BLOCK + LEADING_TEMPERATURE] = 260.0           # R134a at 260 K and the chamber's density: wet
    density = sim.state[GAS_BLOCK + LEADING_MASS] / sim.last_output[OUTPUT_INDEX["leading_volume"]]
    quality = CoolProp.CoolProp.PropsSI("Q", "T", 260.0, "D", density, "R134a")
    with pytest.raises(IntegrationError, match="leading chamber") as stopped:
        sim.advance(sim.time + 1e-3)
    assert f"vapour quality {quality:.4g} from HEOS" in str(stopped.value)


def test_the_failed_evaluation_keeps_its_refused_chamber_states_for_the_stop_message():
    """mechanics.gas.refused_state: an evaluation the tables refuse keeps its node states (the failed attempt's,
    which the message reports); an accepted evaluation leaves them, and a stage that is not a number (computed from
    a refused stage's NaN rates) does not overwrite them."""
    sim = run(revs=0.025, discharge_pressure=2.5e6)
    work = sim.gas.flow_work
    assert math.isnan(work["refused_time"][0])
    refused = sim.state.copy()
    refused[GAS_BLOCK + LEADING_TEMPERATURE] = 260.0              # wet R134a: refused by the per-point table
    assert sim.evaluate(sim.time, refused)[0] != 0
    density = refused[GAS_BLOCK + LEADING_MASS] / sim.last_output[OUTPUT_INDEX["leading_volume"]]
    kept = (work["refused_temperature"][0, 1], work["refused_density"][0, 1])
    assert work["refused_time"][0] == sim.time and kept == pytest.approx((260.0, density), rel=1e-12)
    assert sim.evaluate(sim.time + 1e-6, sim.state)[0] == 0
    not_a_number = refused.copy()
    not_a_number[GAS_BLOCK + TRAILING_TEMPERATURE] = math.nan
    assert sim.evaluate(sim.time + 2e-6, not_a_number)[0] != 0
    assert work["refused_time"][0] == sim.time
    assert (work["refused_temperature"][0, 1], work["refused_density"][0, 1]) == kept


# point 163 of the random sweep (docs/model.md §7.3, density bound), to 4 digits: an Air machine whose 2.8 mm2
# discharge port cannot pass its gas at 490 rpm, so that its leading chamber is over-compressed above 3 p_d
PORT_BOUND_AIR = dict(
    lobes=2, displacement_law="harmonic", stroke=0.009238, bottom_dwell=0.8691, top_dwell=0.7752, rotor_radius=0.1297,
    vane_thickness=0.007969, vane_length=0.09504, axial_length=0.2443, slot_bottom_radius=0.03109,
    edge_radius=0.003065, slot_clearance=0.0003117, stator_clearance=2.985e-05, vane_density=13770.0,
    rotor_inertia=8.671, youngs_modulus=8.585e11, poisson_ratio=0.08382, restitution=0.5629,
    onset_velocity_floor=0.01845, stiffness_model="johnson_line", friction_model="threlfall",
    friction_coefficient=0.07622, friction_velocity=0.007535, friction_velocity_full=0.0002789,
    pressure_model="real_gas", fluid="Air", suction_pressure=565400.0, suction_temperature=591.9,
    discharge_pressure=696900.0, suction_close_angle=0.1275, dead_volume=2.123e-09, suction_port_area=0.001634,
    suction_port_coefficient=0.1602, discharge_port_area=2.828e-06, discharge_port_coefficient=0.6594,
    end_valley_leak_law="nozzle", end_valley_leak_coefficient=0.1973, start_valley_leak_law="friction_corrected",
    start_valley_leak_coefficient=0.1907, tip_leak_law="friction_corrected", tip_leak_coefficient=0.2761,
    slot_leak_law="sealed", integrator="dopri5", relative_tolerance=8.421e-06, tolerance_scale=2.627,
    initial_step=5.136e-09, max_step=1.227e-06, mode_dwell_time=0.003071)


def test_a_chamber_over_compressed_above_three_discharge_pressures_stays_in_its_per_point_table():
    """docs/model.md §7.3 (density bound): the over-compressed leading chamber is hot and leaves a (T, rho) table
    through its density bound; with the bound at 3 p_d this machine stopped at 3.1 p_d, with it on the suction
    isentrope at 4 p_d it completes a revolution, its pressures finite over a peak above 3 p_d."""
    rpm = 490.1
    sim = Simulation(CompressorParameters(**PORT_BOUND_AIR), constant_speed(rpm), initial_angle=0.0,
                     keep_history=True)
    assert sim.gas.input_range is None                          # Air: per-point tables
    sim.advance(60.0 / rpm * 1.0001)
    leading = sim.history["leading_pressure"]
    assert np.all(np.isfinite(leading))
    assert leading.max() > 3.0 * PORT_BOUND_AIR["discharge_pressure"]


def test_on_the_fluid_wide_tables_a_chamber_in_the_dome_is_a_mixture_with_its_quality():
    """docs/model.md §7.3.1: on the fluid-wide tables (the default R134a point) the same push into the dome runs on
    as an equilibrium mixture, and the output row gives the chamber's vapour quality (CoolProp's, to 1e-4)."""
    sim = run(revs=0.025)
    assert sim.gas.input_range is not None
    sim.state[GAS_BLOCK + LEADING_TEMPERATURE] = 260.0
    density = sim.state[GAS_BLOCK + LEADING_MASS] / sim.last_output[OUTPUT_INDEX["leading_volume"]]
    quality = CoolProp.CoolProp.PropsSI("Q", "T", 260.0, "D", density, "R134a")
    status, _, row = sim.evaluate(sim.time, sim.state)
    assert status == 0 and 0.0 < quality < 1.0
    assert row["leading_quality"] == pytest.approx(quality, abs=1e-4) and row["trailing_quality"] == 1.0
    sim.advance(sim.time + 1e-3)
    assert math.isfinite(sim.outputs["leading_pressure"])


def test_closed_chamber_follows_the_isentrope():
    """No leaks (c = 0 closes the valley seal; the tip stays in contact), valve shut until p > p_d, adiabatic:
    between suction close (phi_sc) and the valve opening the leading chamber's p(rho) follows CoolProp's
    isentrope s = s(T, rho at phi_sc) to 1e-4 relative."""
    sim = run(revs=1.2, slot_clearance=0.0, stator_clearance=0.0)
    h = sim.history
    lobe = 2 * math.pi / 3
    phase = h["rotor_angle"] - np.floor(h["rotor_angle"] / lobe) * lobe
    lobe_index = np.floor(h["rotor_angle"] / lobe)
    in_lobe = lobe_index == 1
    opening = np.flatnonzero(in_lobe & (h["discharge_mass_flow"] > 0.0))[0]       # the valve's first opening
    closed = in_lobe & (phase > sim.params.suction_close_angle) & (np.arange(len(h)) < opening)
    assert closed.sum() > 100
    assert np.all(h["tip_leak_mass_flow"][closed] == 0.0)
    state = CoolProp.AbstractState("HEOS", "R134a")
    temperature = h["leading_temperature"][closed]
    volume = h["leading_volume"][closed]
    # the closed chamber's mass is constant: its density is m / V with m from the first closed row
    first = np.flatnonzero(closed)[0]
    state.update(CoolProp.PT_INPUTS, h["leading_pressure"][first], h["leading_temperature"][first])
    entropy = state.smass()
    mass = state.rhomass() * volume[0]
    density = mass / volume

    def isentrope_density(pressure):
        state.update(CoolProp.PSmass_INPUTS, pressure, entropy)
        return state.rhomass()

    worst = 0.0
    for rho, p in zip(density[::5], h["leading_pressure"][closed][::5]):
        isentropic_pressure = brentq(lambda x: isentrope_density(x) - rho, 0.5 * p, 2.0 * p, xtol=1e-9 * p)
        worst = max(worst, abs(p / isentropic_pressure - 1.0))
    assert h["leading_pressure"][closed].max() > 3 * sim.params.suction_pressure
    assert worst < 1e-4, worst
    assert temperature.max() > temperature.min() + 30.0


def test_chamber_equations_closed_forms():
    """docs/model.md §7.3 against closed forms: a closed chamber (no flow) keeps its mass (drho/dt = -rho V'/V) and, for
    an ideal gas (dp/dT)_rho = p/T, heats as dT/dt = -(R/c_v) T V'/V; a pure inflow at the chamber's own enthalpy
    into a rigid ideal-gas chamber heats it as dT/dt = R T m' / (m c_v) (flow work of the entering gas)."""
    t, rho, volume, rate = 300.0, 10.0, 1e-5, -2e-3
    gas_constant, cv = 287.0, 718.0
    p = rho * gas_constant * t
    h = (cv + gas_constant) * t
    dT, drho = chamber_derivatives(t, rho, volume, rate, 0.0, 0.0, 0.0, h, cv, p / t, 0.0)
    assert drho == pytest.approx(-rho * rate / volume, rel=1e-14)
    assert dT == pytest.approx(-gas_constant / cv * t * rate / volume, rel=1e-14)
    inflow = 1e-3
    dT, drho = chamber_derivatives(t, rho, volume, 0.0, inflow, inflow * h, 0.0, h, cv, p / t, 0.0)
    assert drho == pytest.approx(inflow / volume, rel=1e-14)
    # ideal gas, rigid, inflow at the chamber's own enthalpy: dT/dt = T (p/T) v m' / (m c_v) = R T m' / (m c_v)
    assert dT == pytest.approx(gas_constant * t * inflow / (rho * volume * cv), rel=1e-12)


def test_nozzle_paths_are_continuous_and_antisymmetric():
    """The signed nozzle flow is antisymmetric in its two sides, continuous at the edge of its linear band
    (docs/model.md §7.4 law outside it) and at the critical ratio, and choked below it (independent of p_down)."""
    args = (0.7, 20e-6)
    k, r = 1.1, 81.5
    p_up, t_up = 1e6, 330.0
    forward = signed_nozzle_flow(*args, p_up, t_up, 0.8e6, 300.0, k, r)
    backward = signed_nozzle_flow(*args, 0.8e6, 300.0, p_up, t_up, k, r)
    assert backward == -forward
    edge = p_up * (1 - LINEAR_FLOW_BAND)
    inside = signed_nozzle_flow(*args, p_up, t_up, edge * (1 + 1e-12), t_up, k, r)
    outside = signed_nozzle_flow(*args, p_up, t_up, edge * (1 - 1e-12), t_up, k, r)
    assert inside == pytest.approx(outside, rel=1e-9)
    critical = (2 / (k + 1)) ** (k / (k - 1))
    below = signed_nozzle_flow(*args, p_up, t_up, p_up * critical * (1 - 1e-9), t_up, k, r)
    above = signed_nozzle_flow(*args, p_up, t_up, p_up * critical * (1 + 1e-9), t_up, k, r)
    assert below == pytest.approx(above, rel=1e-7)
    assert signed_nozzle_flow(*args, p_up, t_up, 0.1 * p_up, t_up, k, r) == below
    assert signed_nozzle_flow(*args, p_up, t_up, p_up, t_up, k, r) == 0.0


def test_nearly_ideal_gas_agrees_with_level_half():
    """Air at 1 -> 3 bar is nearly ideal: Level 1 and the Level 0.5 ideal-gas recipe (k = 1.4, R = 287) give
    <P_out> within 10 % at c = 0 with an unthrottled suction port. They still differ in geometry: the thin-vane
    volume of Level 0.5 ignores the vane's thickness (up to 4.9 % of the lobe volume at mid-lobe, z = 3), and the
    Level 1 trailing chamber re-expands the dead-volume gas; measured +8.5 %."""
    common = dict(fluid="Air", suction_pressure=1.0e5, suction_temperature=293.15, discharge_pressure=3.0e5,
                  suction_port_area=1e-3)
    level1 = run(revs=3, **common, slot_clearance=0.0, stator_clearance=0.0)
    level05 = Simulation(CompressorParameters(**common, pressure_model="ideal_gas_table", heat_capacity_ratio=1.4,
                                              gas_constant=287.0), constant_speed(1500.0))
    level05.advance(3 * 60.0 / 1500.0)
    out1 = revolutions(level1)[-1].output_power
    out05 = revolutions(level05)[-1].output_power
    assert abs(out1 / out05 - 1.0) < 0.10, (out1, out05)


@pytest.mark.slow
def test_clearance_trends_hold_with_level_1():
    """docs/model.md §11 T14 with Level 1: eta_m, <P_in> and <P_out> fall and <P_fric> does not fall as c grows."""
    results = []
    for c in (0.0, 0.02e-3, 0.05e-3, 0.1e-3, 0.2e-3):
        results.append(revolutions(run(revs=3, slot_clearance=c, stator_clearance=c))[-1])
    eta = [r.mechanical_efficiency for r in results]
    assert all(a > b for a, b in zip(eta, eta[1:])), eta
    for name in ("input_power", "output_power"):
        values = [getattr(r, name) for r in results]
        assert all(a > b for a, b in zip(values, values[1:])), (name, values)
    friction = [r.friction_power for r in results]
    assert all(b >= a for a, b in zip(friction, friction[1:])), friction


@pytest.mark.parametrize("changes, named", [
    (dict(fluid="R134x"), "fluid"),
    (dict(suction_temperature=270.0), "suction_temperature"),
    (dict(discharge_pressure=0.2e6), "discharge_pressure"),
    (dict(suction_temperature=-5.0), "suction_temperature"),
    (dict(suction_port_area=0.0), "suction_port_area"),
])
def test_bad_gas_input_is_refused_before_any_work(changes, named):
    with pytest.raises(ValueError, match=named):
        CompressorParameters(**{**OPERATING, **changes})


def test_unknown_fluid_message_says_how_to_list_names():
    with pytest.raises(ValueError, match="FluidsList"):
        CompressorParameters(**{**OPERATING, "fluid": "NoSuchFluid"})


@pytest.mark.parametrize("clearance", [0.5e-3, 0.6e-3])
def test_wide_clearances_run_with_the_valley_switch_conserving_mass_and_energy(clearance):
    """At c = 0.5-0.6 mm the chamber beside the vane at the valley is smaller than the old leading chamber (the
    wide valley gap, docs/model.md §7.2): the switch keeps the gas at its density and passes the surplus to the new
    leading chamber, so the run goes on and each revolution still balances mass (1e-9 kg of about 1e-4 kg in the
    chambers) and energy (1e-4)."""
    simulation = run(revs=3, slot_clearance=clearance, stator_clearance=clearance)
    history = simulation.history
    for rev in revolutions(simulation):
        # these leaks keep the chambers below discharge pressure: nothing is delivered, so the balance is absolute
        rows = np.searchsorted(history["time"], [rev.start_time, rev.end_time])
        change = {name: np.diff(history[name][rows])[0] for name in ("chamber_mass", "mass_suction", "mass_discharge")}
        assert abs(change["chamber_mass"] - change["mass_suction"] + change["mass_discharge"]) < 1e-9
        assert abs(rev.gas_energy_residual) < 1e-4
        assert abs(rev.ledger_residual) < 1e-3


def test_a_valley_gap_too_wide_for_the_dead_volume_is_refused_before_any_work():
    """c = 1 mm with the default dead volume: refused at construction, naming stator_clearance and the dead volume
    that would do; with that dead volume the same machine runs."""
    with pytest.raises(ValueError, match=r"'stator_clearance' = 0.001 m .* dead_volume >= ([0-9.e-]+) m3") as error:
        Simulation(CompressorParameters(**{**OPERATING, "slot_clearance": 1e-3, "stator_clearance": 1e-3}))
    needed = float(error.value.args[0].rsplit(">= ", 1)[1].split(" ")[0])
    simulation = run(revs=1.05, slot_clearance=1e-3, stator_clearance=1e-3, dead_volume=needed * 1.01)
    assert math.isfinite(simulation.last_output[OUTPUT_INDEX["leading_pressure"]])


def test_adding_a_fluid_is_its_coolprop_name():
    """docs/model.md §14.4: R32, named nowhere in the code, at a duty of its own (evaporating at 0 °C with 10 K
    superheat, condensing at 40 °C: from CoolProp here) needs no code: its operating point, property and nozzle
    tables are built on first use, the back node is at p_d on CoolProp's suction isentrope, the chambers' pressures
    in one right-hand side are CoolProp's p(T, rho) of their states, and a revolution delivers gas and balances
    its mass."""
    fluid = "R32"
    suction_pressure = CoolProp.CoolProp.PropsSI("P", "T", 273.15, "Q", 1, fluid)
    discharge_pressure = CoolProp.CoolProp.PropsSI("P", "T", 313.15, "Q", 1, fluid)
    params = CompressorParameters(**OPERATING, fluid=fluid, suction_pressure=suction_pressure,
                                  suction_temperature=283.15, discharge_pressure=discharge_pressure)
    sim = Simulation(params, constant_speed(1500.0))
    entropy = CoolProp.CoolProp.PropsSI("S", "P", suction_pressure, "T", 283.15, fluid)
    back = sim.gas.chambers[0]
    assert back["discharge_pressure"] == discharge_pressure
    assert back["discharge_temperature"] == pytest.approx(
        CoolProp.CoolProp.PropsSI("T", "P", discharge_pressure, "S", entropy, fluid), rel=1e-6)
    y = sim.state.copy()
    y[GAS_BLOCK + LEADING_TEMPERATURE] += 40.0                 # a compressed leading chamber, off the suction state
    status, rates, row = sim.evaluate(0.0, y)
    assert status == 0 and np.all(np.isfinite(rates))
    for chamber, temperature, mass in (
            ("leading", y[GAS_BLOCK + LEADING_TEMPERATURE], y[GAS_BLOCK + LEADING_MASS]),
            ("trailing", y[GAS_BLOCK + TRAILING_TEMPERATURE], y[GAS_BLOCK + TRAILING_MASS])):
        density = mass / row[f"{chamber}_volume"]
        expected = CoolProp.CoolProp.PropsSI("P", "T", temperature, "D", density, fluid)
        assert row[f"{chamber}_pressure"] == pytest.approx(expected, rel=1e-5), chamber
    sim.advance(0.09)                                          # two revolutions at 1500 rpm, and a little
    figures = revolutions(sim)[-1]
    assert figures.discharge_mass_flow > 0.0 and abs(figures.gas_mass_residual) < 1e-12
