"""The refrigeration loop (mechanics/reduced/refrigeration_loop.py, docs/model.md §16): conservation over a run with a
prescribed compressor exchange, the steady state against an independent steady cycle from CoolProp states, and
the refusals (bad parameters by name, an emptied evaporator as a failed step with the state untouched).

The steady reference solves the steady equations of docs/model.md §16 (condenser and evaporator energy balances,
the thermostatic valve's law, the suction line) with CoolProp's saturated states and scipy, not with the loop's
property table or integrator."""
import math

import numpy as np
import pytest
from pythonfmu.enums import Fmi2Status
from scipy.optimize import brentq, fsolve

from rotary_vane.examples.steady_cycle import saturated as sat
from rotary_vane.fmu_src.refrigeration_loop import PARAMETERS, LoopSlave
from rotary_vane.fmu_src.slave import INITIALIZED

MASS_FLOW = 0.01                 # kg/s, the prescribed compressor
DISCHARGE_ENTHALPY = 440e3       # J/kg
CONDENSER_SECONDARY, EVAPORATOR_SECONDARY = 313.15, 285.15   # K


def started_slave(**values) -> LoopSlave:
    slave = LoopSlave(instance_name="test")
    for name, value in values.items():
        setattr(slave, name, value)
    slave.setup_experiment(0.0)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    assert slave.phase == INITIALIZED, [entry.msg for entry in slave.log_queue]
    return slave


def run(slave, steps, step, mass_flow, enthalpy, drawn_fraction=1.0, back_flow_energy=0.0):
    """Advance with a compressor delivering `mass_flow(t)` [kg/s] at `enthalpy(t)` [J/kg] and drawing
    `drawn_fraction` of it (its inventory changes if that is not 1) at the suction enthalpy the loop gives, less
    the fraction `back_flow_energy` of that energy (what leaks and the valley switch return, docs/model.md §16.5)."""
    for k in range(steps):
        t = k * step
        drawn = mass_flow(t) * drawn_fraction * step
        slave.drawn_enthalpy += drawn * slave.model.outputs["suction_enthalpy"] * (1.0 - back_flow_energy)
        slave.drawn_mass += drawn
        slave.delivered_mass += mass_flow(t) * step
        slave.delivered_enthalpy += mass_flow(t) * step * enthalpy(t)
        assert slave.do_step(t, step), [entry.msg for entry in slave.log_queue]


@pytest.fixture(scope="module")
def balance_run():
    slave = started_slave()
    y0 = slave.model.state.copy()
    run(slave, 300, 0.2, lambda t: 0.01 * (1.0 + 0.3 * math.sin(t)), lambda t: 430e3 + 10e3 * math.cos(0.5 * t),
        0.9, back_flow_energy=0.005)
    return slave, y0


def test_charge_changes_only_by_the_compressor_exchange(balance_run):
    slave, y0 = balance_run
    expected = y0[0] + y0[2] + slave.delivered_mass - slave.drawn_mass
    assert slave.model.charge == pytest.approx(expected, rel=1e-9)
    assert abs(slave.delivered_mass - slave.drawn_mass) > 1e-3        # the exchange did move the charge


def test_energy_changes_only_by_the_exchange_and_the_heats(balance_run):
    """The drawn energy is the compressor's, not drawn mass x suction enthalpy (0.5 % apart here, as back-flow
    makes them in a coupled run): the loop's energy follows it exactly (docs/model.md §16.5)."""
    slave, y0 = balance_run
    y = slave.model.state
    heats = y[4] + y[5] + y[6]                  # condenser, evaporator, suction line (cumulative)
    expected = y0[1] + y0[3] + slave.delivered_enthalpy - slave.drawn_enthalpy + heats
    assert y[1] + y[3] == pytest.approx(expected, rel=1e-9, abs=1e-9 * abs(y[1] + y[3]))


def steady_cycle():
    """Capacity [W] and COP of the steady loop with the default thermostatic valve, from CoolProp (module
    docstring): T_c from the condenser balance with saturated liquid leaving, then (T_e, dry fraction d) from the
    evaporator balance and the valve passing the prescribed flow at the superheat eps d (T_sec - T_e)."""
    import CoolProp.CoolProp as CP
    p = {name: meta["default"] for name, meta in PARAMETERS.items()}

    condensing = brentq(lambda t: MASS_FLOW * (DISCHARGE_ENTHALPY - sat("H", t, 0))
                        - p["condenser_ua"] * (t - CONDENSER_SECONDARY), CONDENSER_SECONDARY, 360.0)
    liquid_enthalpy, liquid_density = sat("H", condensing, 0), sat("D", condensing, 0)
    condenser_pressure = sat("P", condensing, 0)

    def residuals(unknowns):
        evaporating, dry = unknowns
        dp = condenser_pressure - sat("P", evaporating, 1)
        area = MASS_FLOW * (dp * dp + 1000.0 ** 2) ** 0.25 / (p["discharge_coefficient"] * math.sqrt(2 * liquid_density) * dp)
        superheat = p["static_superheat"] + p["superheat_band"] * area / p["valve_area"]
        return [superheat - p["suction_line_effectiveness"] * dry * (EVAPORATOR_SECONDARY - evaporating),
                MASS_FLOW * (sat("H", evaporating, 1) - liquid_enthalpy)
                - (1 - dry) * p["evaporator_ua"] * (EVAPORATOR_SECONDARY - evaporating)]

    evaporating, dry = fsolve(residuals, [272.0, 0.5], xtol=1e-12)
    superheat = p["suction_line_effectiveness"] * dry * (EVAPORATOR_SECONDARY - evaporating)
    suction_enthalpy = CP.PropsSI("H", "P", sat("P", evaporating, 1), "T", evaporating + superheat, "R134a")
    capacity = MASS_FLOW * (suction_enthalpy - liquid_enthalpy)
    return capacity, capacity / (MASS_FLOW * (DISCHARGE_ENTHALPY - suction_enthalpy)), condenser_pressure


def test_steady_state_matches_an_independent_steady_cycle():
    slave = started_slave()
    run(slave, 400, 0.5, lambda t: MASS_FLOW, lambda t: DISCHARGE_ENTHALPY)
    capacity, cop, condenser_pressure = steady_cycle()
    out = slave.model.outputs
    loop_cop = out["evaporator_heat_flow"] / (MASS_FLOW * (DISCHARGE_ENTHALPY - out["suction_enthalpy"]))
    print(f"thermostatic: capacity {out['evaporator_heat_flow']:.8g} W vs {capacity:.8g} W, COP {loop_cop:.8g} vs "
          f"{cop:.8g}")
    assert out["evaporator_heat_flow"] == pytest.approx(capacity, rel=1e-3)
    assert loop_cop == pytest.approx(cop, rel=1e-3)
    assert out["discharge_pressure"] == pytest.approx(condenser_pressure, rel=1e-3)


@pytest.mark.parametrize("name, value", [("condenser_ua", -1.0), ("valve_kind", "needle"), ("separation_fill", 0.0),
                                         ("refrigerant_charge", math.nan), ("dryout_quality", 1.0)])
def test_bad_parameters_are_refused_by_name(name, value):
    values = {n: meta["default"] for n, meta in PARAMETERS.items()}
    values[name] = value
    with pytest.raises(ValueError, match=f"parameter '{name}'"):
        LoopSlave.check_parameters(values)


def test_an_emptied_evaporator_discards_the_step_and_keeps_the_state():
    # the valve feeds almost nothing, a warm, well-coupled evaporator boils its liquid off before it cools
    slave = started_slave(valve_kind="fixed_orifice", valve_area=1e-10, evaporator_ua=5000.0,
                          evaporator_secondary_temperature=300.0)
    saved = None
    for k in range(2000):
        saved = slave.model.state.copy()
        slave.drawn_enthalpy += 0.02 * 0.5 * slave.model.outputs["suction_enthalpy"]
        slave.drawn_mass += 0.02 * 0.5
        slave.delivered_mass += 0.02 * 0.5
        slave.delivered_enthalpy += 0.02 * 0.5 * DISCHARGE_ENTHALPY
        if not slave.do_step(k * 0.5, 0.5):
            break
    else:
        pytest.fail("the evaporator never ran empty")
    message = slave.log_queue[-1].msg
    assert slave.log_queue[-1].status == Fmi2Status.discard
    assert "evaporator ran empty" in message and f"t = {k * 0.5 + 0.5!r} s" in message, message
    assert np.array_equal(slave.model.state, saved)


def loop_vector(**changes):
    from rotary_vane.fmu_src.refrigeration_loop import parameter_vector
    return parameter_vector({**{n: meta["default"] for n, meta in PARAMETERS.items()}, **changes})


def test_a_flooding_suction_is_refused_and_the_loop_kept():
    """separation_fill = 1: the evaporator's outlet carries liquid whenever vapour does not fill it, so at
    standstill its suction is wet (docs/model.md §16.2); a limit above that quality refuses it, at the start and
    after a step, with the loop as before."""
    from rotary_vane.mechanics.reduced.refrigeration_loop import LoopFailure, RefrigerationLoop
    from rotary_vane.thermo.fluid_envelope import fluid_property_table_for
    table = fluid_property_table_for("R134a")
    wet = RefrigerationLoop(loop_vector(separation_fill=1.0), table, 298.15, 0.8, 0.5)
    quality = wet.outputs["suction_quality"]
    assert 0.5 < quality < 0.95
    with pytest.raises(LoopFailure, match="the compressor would flood: suction vapour quality"):
        RefrigerationLoop(loop_vector(separation_fill=1.0), table, 298.15, 0.8, 0.99)
    wet.suction_quality_min = quality + 1e-3          # the next state, no drier, floods
    before = wet.state.copy(), dict(wet.outputs)
    with pytest.raises(LoopFailure, match="would flood"):
        wet.step(0.1, (0.0, 0.0, 0.0, 0.0), CONDENSER_SECONDARY, 298.15)
    assert np.array_equal(wet.state, before[0]) and wet.outputs == before[1]


FIXED_ORIFICE_AREA = 3.6e-7     # m2: passes a little more than 10 g/s of saturated liquid, so the outlet flashes


def steady_fixed_orifice_cycle():
    """Capacity [W] and COP of the steady loop with a fixed orifice that would pass more than the compressor's flow
    of saturated liquid, from CoolProp: the condenser's outlet then flashes (quality x_o > 0) until the orifice
    passes exactly the compressor's flow, and the evaporator, holding most of the charge, stays wetted (no dry part,
    no superheat): (T_c, T_e, x_o) solve the two energy balances and the orifice law (docs/model.md §16.2-16.3)."""
    p = {name: meta["default"] for name, meta in PARAMETERS.items()}

    def outlet(condensing, quality):
        return sat("H", condensing, quality), sat("D", condensing, quality)

    def residuals(unknowns):
        condensing, evaporating, quality = unknowns
        enthalpy, density = outlet(condensing, quality)
        dp = sat("P", condensing, 0) - sat("P", evaporating, 1)
        flow = (p["discharge_coefficient"] * FIXED_ORIFICE_AREA * math.sqrt(2 * density) * dp
                / (dp * dp + 1000.0 ** 2) ** 0.25)
        return [MASS_FLOW * (DISCHARGE_ENTHALPY - enthalpy) - p["condenser_ua"] * (condensing - CONDENSER_SECONDARY),
                MASS_FLOW * (sat("H", evaporating, 1) - enthalpy)
                - p["evaporator_ua"] * (EVAPORATOR_SECONDARY - evaporating),
                (flow - MASS_FLOW) / MASS_FLOW]

    condensing, evaporating, quality = fsolve(residuals, [318.0, 278.0, 0.01], xtol=1e-12)
    assert 0.0 < quality < 0.1
    capacity = MASS_FLOW * (sat("H", evaporating, 1) - outlet(condensing, quality)[0])
    return capacity, capacity / (MASS_FLOW * (DISCHARGE_ENTHALPY - sat("H", evaporating, 1)))


def test_fixed_orifice_steady_state_matches_an_independent_steady_cycle():
    slave = started_slave(valve_kind="fixed_orifice", valve_area=FIXED_ORIFICE_AREA)
    run(slave, 400, 0.5, lambda t: MASS_FLOW, lambda t: DISCHARGE_ENTHALPY)
    capacity, cop = steady_fixed_orifice_cycle()
    out = slave.model.outputs
    loop_cop = out["evaporator_heat_flow"] / (MASS_FLOW * (DISCHARGE_ENTHALPY - out["suction_enthalpy"]))
    print(f"fixed orifice: capacity {out['evaporator_heat_flow']:.8g} W vs {capacity:.8g} W, COP {loop_cop:.8g} vs "
          f"{cop:.8g}")
    assert out["suction_temperature"] == out["evaporator_temperature"]      # no superheat: the evaporator is wetted
    assert out["evaporator_heat_flow"] == pytest.approx(capacity, rel=1e-3)
    assert loop_cop == pytest.approx(cop, rel=1e-3)
