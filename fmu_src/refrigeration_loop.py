"""The refrigeration loop as an FMI 2.0 co-simulation slave: the compressor's cumulative mass and enthalpy exchange
and the secondary inlet temperatures in; the suction state, the discharge pressure, heat flows and the charge out.

The physics (docs/model.md §16) is `rotary_vane.mechanics.reduced.refrigeration_loop`; this module declares the FMU
variables (docs/model.md §16.7) and maps the FMI calls onto it. The fluid is R134a, on its fluid-wide property table
with the dome (thermo.fluid_envelope).
"""
from __future__ import annotations

import math

import numpy as np
from pythonfmu.default_experiment import DefaultExperiment

from ..mechanics.reduced import refrigeration_loop as loop
from ..thermo.fluid_envelope import SUCTION_QUALITY_MIN, fluid_property_table_for

from . import state_schema as schema
from .declared_slave import DeclaredSlave, number
from .slave import StepFailed

FLUID = "R134a"


PARAMETERS = {
    "refrigerant_charge": number("kg", 0.8, 1e-3, 100.0, "refrigerant (R134a) mass in the loop"),
    "condenser_volume": number("m3", 1.5e-3, 1e-6, 1.0, "internal volume of the condenser V_c"),
    "evaporator_volume": number("m3", 1.5e-3, 1e-6, 1.0, "internal volume of the evaporator V_e"),
    "condenser_ua": number("W/K", 300.0, 1e-3, 1e6, "condenser conductance UA_c to its secondary stream"),
    "evaporator_ua": number("W/K", 250.0, 1e-3, 1e6, "evaporator conductance UA_e to its secondary stream (of "
                                                     "its wetted part)"),
    "valve_kind": dict(unit="", default="thermostatic", choices=loop.VALVE_KINDS,
                       description="expansion valve: fixed orifice, or thermostatic (proportional in the superheat)"),
    "valve_area": number("m2", 1e-6, 1e-10, 1e-2, "orifice area A (thermostatic: fully open)"),
    "discharge_coefficient": number("1", 0.7, 0.01, 1.0, "orifice discharge coefficient C_d"),
    "static_superheat": number("K", 4.0, 0.0, 30.0, "thermostatic: superheat at which the valve starts to open"),
    "superheat_band": number("K", 6.0, 0.1, 50.0, "thermostatic: superheat rise from closed to fully open"),
    "suction_line_effectiveness": number("1", 0.6, 0.0, 1.0, "effectiveness of the evaporator's dry part heating "
                                                              "the suction vapour towards the secondary inlet "
                                                              "temperature"),
    "separation_fill": number("1", 0.2, 0.01, 1.0, "volume fraction of liquid (condenser) or vapour (evaporator) "
                                                    "below which the outlet draws the mixture instead of one phase"),
    "dryout_quality": number("1", 0.7, 0.0, 0.99, "evaporator mean vapour quality above which part of its surface "
                                                   "is dry"),
    "initial_temperature": number("K", 288.15, 233.15, 333.15, "temperature of the loop at standstill (equal "
                                                                "pressures) at the start time; the compressor takes "
                                                                "suction pressures up to p_sat(20 degC)"),
}
VECTOR_ORDER = ("condenser_volume", "evaporator_volume", "condenser_ua", "evaporator_ua", "valve_kind", "valve_area",
                "discharge_coefficient", "static_superheat", "superheat_band", "suction_line_effectiveness",
                "separation_fill", "dryout_quality")       # mechanics.reduced.refrigeration_loop's indices
SECONDARY_TEMPERATURE_RANGE = (200.0, 400.0)              # K
INPUTS = {  # name -> (unit, start, description)
    "drawn_mass": ("kg", 0.0, "cumulative mass the compressor drew from the suction since the start (connect the "
                              "compressor's drawn_mass)"),
    "drawn_enthalpy": ("J", 0.0, "cumulative energy the compressor drew from the suction since the start (connect "
                                 "the compressor's drawn_enthalpy)"),
    "delivered_mass": ("kg", 0.0, "cumulative mass the compressor delivered to the discharge since the start "
                                  "(connect the compressor's delivered_mass)"),
    "delivered_enthalpy": ("J", 0.0, "cumulative enthalpy the compressor delivered since the start (connect the "
                                     "compressor's delivered_enthalpy)"),
    "condenser_secondary_temperature": ("K", 313.15, "inlet temperature of the condenser's secondary stream"),
    "evaporator_secondary_temperature": ("K", 285.15, "inlet temperature of the evaporator's secondary stream"),
}
OUTPUTS = {  # name -> (unit, description)
    "suction_pressure": ("Pa", "evaporator pressure = compressor suction pressure p_s"),
    "suction_temperature": ("K", "temperature of the suction vapour after the suction line"),
    "suction_enthalpy": ("J/kg", "specific enthalpy of the suction state (connect to the compressor's "
                                 "suction_enthalpy)"),
    "suction_quality": ("1", "vapour quality of the suction state (1: dry)"),
    "discharge_pressure": ("Pa", "condenser pressure = compressor discharge pressure p_d"),
    "condenser_temperature": ("K", "condenser refrigerant temperature"),
    "evaporator_temperature": ("K", "evaporator refrigerant temperature"),
    "condenser_quality": ("1", "mean vapour quality in the condenser"),
    "evaporator_quality": ("1", "mean vapour quality in the evaporator"),
    "condenser_heat_flow": ("W", "heat released to the condenser's secondary stream, mean over the last step"),
    "evaporator_heat_flow": ("W", "heat taken from the evaporator's secondary stream (evaporator and suction line), "
                                  "mean over the last step: the capacity"),
    "valve_opening": ("1", "open fraction of the valve area"),
    "valve_mass_flow": ("kg/s", "mass flow through the expansion valve at the end of the step"),
    "refrigerant_charge_in_loop": ("kg", "refrigerant mass in condenser and evaporator (the charge minus what the "
                                         "compressor holds)"),
}

MODEL_SCHEMA = schema.Record({
    "parameters": schema.Record({name: schema.Text(length=10 ** 6) if "choices" in meta else schema.Real(finite=False)
                                 for name, meta in PARAMETERS.items()}),
    "built": schema.Boolean(),
    "time": schema.Real(0.0, math.inf),
    "state": schema.Sequence(schema.Real(), loop.STATE_COUNT),
    "guesses": schema.Sequence(schema.Real(), 2),
    "exchange": schema.Sequence(schema.Real(), loop.EXCHANGE_COUNT),
    "drawn_rate": schema.Real(),
    "secondary_temperatures": schema.Sequence(schema.Real(), 2),
    "outputs": schema.Record({name: schema.Real(finite=False) for name in OUTPUTS}),
    "inputs": schema.Record({name: schema.Real(finite=False) for name in INPUTS}),
})


def parameter_vector(values: dict) -> np.ndarray:
    """The loop's parameter vector (mechanics.reduced.refrigeration_loop indices) of checked parameter values."""
    return np.array([float(loop.VALVE_KINDS.index(values[name])) if name == "valve_kind" else float(values[name])
                     for name in VECTOR_ORDER])


class LoopSlave(DeclaredSlave):
    """Refrigeration loop (condenser, expansion valve, evaporator, suction line) around the compressor."""

    description = ("Lumped R134a vapour-compression loop: two-phase condenser and evaporator volumes, fixed or "
                   "thermostatic expansion valve, suction line; the compressor's cumulative mass and enthalpy "
                   "exchange in, suction state and discharge pressure out.")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=60.0, step_size=0.1)
    declared_parameters = PARAMETERS
    state_schema = MODEL_SCHEMA
    example_start_values = {"refrigerant_charge": 0.8}
    documentation_note = ("Connect the compressor's drawn_mass, drawn_enthalpy, delivered_mass and "
                          "delivered_enthalpy to the inputs of the same names, and suction_pressure, suction_enthalpy "
                          "and discharge_pressure to the compressor's inputs (its suction_state_input = enthalpy).")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.model: loop.RefrigerationLoop | None = None
        self._standstill = None                   # (parameter values, their standstill loop or None, refusal)
        self.time = 0.0
        self.register_declared_variables([(name, *spec) for name, spec in INPUTS.items()], OUTPUTS)

    def _output(self, name):
        model = self.model if self.model is not None else self._standstill_model()
        if model is None:
            return math.nan
        if name == "refrigerant_charge_in_loop":
            return model.charge
        return model.outputs[name]

    def _standstill_model(self) -> loop.RefrigerationLoop | None:
        """Before exitInitializationMode: the standstill loop of the parameters as they are now (built again only
        when they change), so that a master can pass the outputs on during initialization; None while they are
        invalid (undefined_reason says why)."""
        values = self.parameter_values()
        key = tuple(values.items())
        if self._standstill is None or self._standstill[0] != key:
            try:
                self.check_parameters(values)
                self._standstill = (key, self._build_model(values), None)
            except ValueError as refusal:
                self._standstill = (key, None, str(refusal))
        return self._standstill[1]

    def undefined_reason(self, name):
        if self.model is None and self._standstill is not None and self._standstill[2] is not None:
            return f"no standstill state before initialization: {self._standstill[2]}"
        return "no defined value"

    def initialize(self):
        self.check_parameters(self.parameter_values())
        self.model = self._build_model(self.parameter_values())
        self.time = 0.0

    @staticmethod
    def _build_model(values) -> loop.RefrigerationLoop:
        try:
            return loop.RefrigerationLoop(parameter_vector(values), fluid_property_table_for(FLUID),
                                          values["initial_temperature"], values["refrigerant_charge"],
                                          SUCTION_QUALITY_MIN)
        except loop.LoopFailure as failure:
            raise ValueError(f"parameters 'refrigerant_charge' = {values['refrigerant_charge']!r} kg and "
                             f"'initial_temperature' = {values['initial_temperature']!r} K give no loop state: "
                             f"{failure}") from None

    def input_error(self):
        low, high = SECONDARY_TEMPERATURE_RANGE
        for name, (unit, _, _) in INPUTS.items():
            value = getattr(self, name)
            if not math.isfinite(value):
                return f"input '{name}' = {value!r} {unit} is invalid: allowed a finite value"
            if name.endswith("secondary_temperature") and not low <= value <= high:
                return f"input '{name}' = {value!r} K is out of range: allowed [{low:g}, {high:g}] K"
        return None

    def advance(self, end_time, step_size):
        try:
            self.model.step(step_size, (self.drawn_mass, self.drawn_enthalpy, self.delivered_mass,
                                        self.delivered_enthalpy),
                            self.condenser_secondary_temperature, self.evaporator_secondary_temperature)
        except loop.LoopFailure as failure:
            raise StepFailed(f"at t = {end_time + self.start_time!r} s {failure}") from None
        self.time = end_time

    # state --------------------------------------------------------------------------------------------------
    def snapshot(self):
        model = self.model
        built = model is not None
        return dict(parameters=self.parameter_values(), built=built, time=self.time,
                    state=[float(v) for v in model.state] if built else [0.0] * loop.STATE_COUNT,
                    guesses=[float(v) for v in model.guesses] if built else [0.0, 0.0],
                    exchange=[float(v) for v in model.exchange] if built else [0.0] * loop.EXCHANGE_COUNT,
                    drawn_rate=model.drawn_rate if built else 0.0,
                    secondary_temperatures=list(model.secondary_temperatures) if built else [0.0, 0.0],
                    outputs={name: self._output(name) if built else 0.0 for name in OUTPUTS},
                    inputs={name: getattr(self, name) for name in INPUTS})

    def restore(self, state):
        """Restore a state; the loop is rebuilt from the state's parameters, then given the saved state."""
        self.restore_settings(state, INPUTS)
        self.model = None
        if state["built"]:
            model = self._build_model(state["parameters"])
            model.state = np.array(state["state"], dtype=float)
            model.guesses = np.array(state["guesses"], dtype=float)
            model.exchange = np.array(state["exchange"], dtype=float)
            model.drawn_rate = float(state["drawn_rate"])
            model.secondary_temperatures = tuple(float(v) for v in state["secondary_temperatures"])
            model.outputs = {name: float(value) for name, value in state["outputs"].items()
                             if name != "refrigerant_charge_in_loop"}
            self.model = model
        self.time = float(state["time"])
