"""The compressor FMU's boundary inputs (suction and discharge conditions) and its conservative flow outputs.

Inputs (continuous; held over each communication step, or moved linearly from their last values as the speed
when `interpolate_speed` is true: mechanics.gas.boundary, docs/model.md §7.3.3): `suction_pressure`,
`discharge_pressure`, and the suction state by `suction_temperature` or by `suction_enthalpy`, as the fixed
parameter `suction_state_input` says ("temperature", the default, or "enthalpy"; the other input is ignored). Their
start values are the defaults of the parameters of the same names (mechanics.parameters; `suction_enthalpy`:
h(p_s, T_s) of those). Declared min and max: the input range of the tables the FMU ships for its default fluid,
R134a (thermo.fluid_envelope.input_range), with the suction pressure allowed up to the largest discharge
pressure (pressures equalised at standstill); tests/fmu/test_fmu_boundary_inputs.py checks them against
CoolProp. Another fluid's own range is checked when a step takes the value.

The model is built at initialization for the inputs' start values when they are a valid operating point
(mechanics.parameters); a real-gas run whose start values are not one (equal pressures, a wet suction state) is
built at the parameters' defaults and takes the inputs as its boundary before the first step (refused by name if
its tables cannot hold them). At the start p_d >= p_s is required; a reversed difference is taken in a transient.

Flow outputs (FLOW_RESULTS), from the chamber model's cumulative flows in the state (thermo.chamber_state), so
that a host integrating the step means conserves mass and energy across the interface exactly: the drawn mass is
the net mass from the suction side (ports, valley leaks, chambers filled from or vented to the idle lobes), the
drawn enthalpy the energy those same flows carry (upwind enthalpy through the ports and seals, so that back-flow
carries the chamber's; internal energy of the gas the valley switch moves, whose volume moves with it: docs/model.md
§7.2, §16.5), the delivered mass and enthalpy the net flow to the discharge side (discharge valve minus what returns
to the chambers from the back chamber, which holds discharge-side gas, through the slot side faces). In a step that
delivered nothing (the valve is shut for part of every lobe, so at 1 ms steps that is common) the mean discharge
enthalpy is the discharge plenum's (the back node's): finite, so that a host multiplying it by the step's mass gets
0 and not NaN, and fmi2OK (a NaN would come with fmi2Warning from every read in normal operation). No step-mean
suction enthalpy: the net drawn mass of a step passes through 0 when back-flow balances the inflow, and the ratio
would then mean nothing.
"""
from __future__ import annotations

from typing import NamedTuple

from pythonfmu.enums import Fmi2Causality, Fmi2Variability

from ..mechanics.loop.layout import GAS_BLOCK
from ..mechanics.parameters import CompressorParameters
from ..thermo.chamber_state import (ENERGY_BACK_CHAMBER, ENERGY_DISCHARGE, ENERGY_SUCTION, MASS_BACK_CHAMBER,
                                    MASS_DISCHARGE, MASS_SUCTION)

from .variables import RealVariable


class BoundaryInput(NamedTuple):
    unit: str
    start: float
    minimum: float
    maximum: float
    description: str


# R134a (the FMU's shipped tables): p_s in [p_sat(-40 °C), p_d,max], p_d up to p_sat(70 °C), T_s from the dew point
# at p_s,min plus the 1 K superheat margin to T_sat(p_s,max) + 30 K, h_s from the mixture of quality 0.5 at p_s,min
# to the gas at (p_s,min, T_s,max)
PRESSURE_MIN, PRESSURE_MAX = 51208.97602521801, 2116825.6950330404
BOUNDARY_INPUTS = {
    "suction_pressure": BoundaryInput("Pa", 0.2928e6, PRESSURE_MIN, PRESSURE_MAX, "suction pressure p_s"),
    "discharge_pressure": BoundaryInput("Pa", 1.3179e6, PRESSURE_MIN, PRESSURE_MAX,
                                        "discharge (and back-chamber) pressure p_d"),
    "suction_temperature": BoundaryInput("K", 283.15, 234.15, 323.15,
                                         "suction temperature T_s (used if suction_state_input = temperature)"),
    "suction_enthalpy": BoundaryInput("J/kg", 407514.2819788059, 261073.4948074663, 447009.60550416645,
                                      "suction specific enthalpy h_s (used if suction_state_input = enthalpy)"),
}
SUCTION_STATE_INPUTS = ("temperature", "enthalpy")

FLOW_RESULTS = {
    "drawn_mass": ("kg", "cumulative net mass drawn from the suction side since the start", None),
    "drawn_enthalpy": ("J", "cumulative net energy drawn from the suction side since the start, over the flows "
                            "drawn_mass sums: their enthalpy through the ports and valley seals (either way), the "
                            "internal energy of the gas the valley switch moves", None),
    "delivered_mass": ("kg", "cumulative net mass delivered to the discharge side since the start", None),
    "delivered_enthalpy": ("J", "cumulative net enthalpy delivered to the discharge side since the start", None),
    "suction_mass_flow_mean": ("kg/s", "drawn mass over the last step / step size", "drawn_mass"),
    "discharge_mass_flow_mean": ("kg/s", "delivered mass over the last step / step size", "delivered_mass"),
    "discharge_enthalpy_mean": ("J/kg", "delivered enthalpy over the last step / delivered mass over it; the "
                                        "discharge plenum's enthalpy (p_d on the suction isentrope) in a step "
                                        "that delivered nothing", None),
}


def boundary_input_variable(name: str) -> RealVariable:
    spec = BOUNDARY_INPUTS[name]
    return RealVariable(name, spec.unit, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
                        minimum=spec.minimum, maximum=spec.maximum,
                        description=f"{spec.description}; held or interpolated over each communication step "
                                    f"as interpolate_speed says")


def check_suction_state_input(value) -> None:
    if value not in SUCTION_STATE_INPUTS:
        raise ValueError(f"parameter 'suction_state_input' = {value!r} is out of range: allowed one of "
                         f"{', '.join(SUCTION_STATE_INPUTS)}")


def build_point(values: dict) -> dict:
    """The operating point (p_s, T_s, p_d) the model is built for: the inputs' values when they make valid
    parameters, else, for a real-gas run, the parameters' defaults (module docstring); the inputs' values for the
    pressure-table models, whose errors name them."""
    point = {name: values[name] for name in ("suction_pressure", "suction_temperature", "discharge_pressure")}
    p_s, p_d = point["suction_pressure"], point["discharge_pressure"]
    if isinstance(p_s, float) and isinstance(p_d, float) and p_d < p_s:
        raise ValueError(f"input 'discharge_pressure' = {p_d!r} Pa at initialization is out of range: allowed >= "
                         f"suction_pressure = {p_s!r} Pa (a reversed pressure difference is taken in a transient, "
                         f"not at the start)")
    try:
        CompressorParameters(**values)
    except ValueError:
        if values.get("pressure_model") == "real_gas":
            return {name: BOUNDARY_INPUTS[name].start for name in point}
    return point


def flow_results(simulation, before: dict | None, step_size: float) -> dict:
    """The cumulative flows of the state (module docstring); with `before` (this function's values at the step's
    start) also the step means."""
    if simulation.params.pressure_model != "real_gas":
        cumulative = dict(drawn_mass=0.0, drawn_enthalpy=0.0, delivered_mass=0.0, delivered_enthalpy=0.0)
    else:
        y = simulation.state
        cumulative = dict(drawn_mass=float(y[GAS_BLOCK + MASS_SUCTION]),
                          drawn_enthalpy=float(y[GAS_BLOCK + ENERGY_SUCTION]),
                          delivered_mass=float(y[GAS_BLOCK + MASS_DISCHARGE] - y[GAS_BLOCK + MASS_BACK_CHAMBER]),
                          delivered_enthalpy=float(y[GAS_BLOCK + ENERGY_DISCHARGE]
                                                   - y[GAS_BLOCK + ENERGY_BACK_CHAMBER]))
    if before is None:
        return cumulative
    if simulation.params.pressure_model != "real_gas":
        return {**step_means(cumulative, before, step_size, 0.0), "discharge_enthalpy_mean": 0.0}
    return step_means(cumulative, before, step_size, simulation.boundary.back.enthalpy)


def step_means(cumulative: dict, before: dict, step_size: float, empty_enthalpy: float) -> dict:
    """The cumulative flows and their step means (FLOW_RESULTS) from the cumulative flows at the step's end and
    start; `empty_enthalpy`: the discharge_enthalpy_mean of a step that delivered nothing (module docstring)."""
    delivered = cumulative["delivered_mass"] - before["delivered_mass"]
    enthalpy = cumulative["delivered_enthalpy"] - before["delivered_enthalpy"]
    means = {name: (cumulative[source] - before[source]) / step_size
             for name, (_, _, source) in FLOW_RESULTS.items() if source is not None}
    means["discharge_enthalpy_mean"] = enthalpy / delivered if delivered != 0.0 else empty_enthalpy
    return {**cumulative, **means}
