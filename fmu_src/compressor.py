"""The compressor as an FMI 2.0 co-simulation slave: shaft speed in [rpm], torque and powers out.

A thin map of FMI calls onto `mechanics.Simulation` (one per instance): parameters generated from the parameter
declarations, outputs from the output declarations (mechanics.loop.outputs: end-of-step values read from the last
output row, per-revolution figures from the last completed revolution the time loop summarised), the speed
and boundary inputs held or ramped over each communication step, the whole simulation state saved and restored. Outputs are
read when the importer asks for them: a step does nothing in Python beyond one call of the time loop.
"""
from __future__ import annotations

import math

from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Status, Fmi2Variability
from pythonfmu.variables import Boolean

from ..mechanics import CompressorParameters, IntegrationError, Simulation, constant_speed, declarations
from ..mechanics.parameters import OPERATING_POINT, is_numeric
from ..mechanics.simulation import WORK_PER_MS
from ..mechanics.loop.layout import WORK_IN
from ..mechanics.loop.machine import machine_from_parameters
from ..mechanics.contact.modes import MODE_COUNT
from ..mechanics.loop.outputs import OUTPUT_INDEX, REAL_GAS, REVOLUTION, fmu_outputs
from ..kernels.compile_cache import cache_root, shipped_kernel_misses, shipped_kernels_refusal

from . import compressor_state
from .periodic_map_mode import FIDELITIES, PeriodicMapRun, check_fidelity
from . import state_schema as schema
from .slave import GuardedSlave, StepFailed
from .boundary_inputs import (BOUNDARY_INPUTS, FLOW_RESULTS, SUCTION_STATE_INPUTS, boundary_input_variable,
                              build_point, check_suction_state_input, flow_results, step_means)
from .variables import RealVariable, declared_parameter, integer_output, output, parameter

OUTPUTS = fmu_outputs()
REAL_GAS_FIGURES = tuple(d.name for d in OUTPUTS if d.per == REVOLUTION and d.models == REAL_GAS)
MAX_SHAFT_SPEED = 30000.0             # rpm: far above any vane compressor; beyond it the input is refused
# FMU-only parameters (the physics parameters come from mechanics.parameters)
RUN_PARAMETERS = {
    "pressure_table_speed": ("rpm", 1500.0, 1.0, 1e5,
                             "operating speed at which the Level 0.5 pressure table is built"),
    "initial_rotor_angle": ("rad", 0.0, -1e3, 1e3, "rotor angle theta at the start time"),
    "work_bound": ("1", float(WORK_PER_MS), 1.0, 1e12,
                   "most integrator step attempts per ms of a communication step (plus 1000): a step that needs more "
                   "is discarded (fmi2Discard) instead of running on; the default is ten times what valid runs need"),
}
# outputs of the communication step itself
STEP_RESULTS = {
    "shaft_torque_mean": ("N.m", "shaft work over the last step / angle turned in it (the instantaneous torque if "
                                 "the rotor stood still)"),
    "shaft_work": ("J", "cumulative shaft work since the start"),
    "shaft_angle": ("rad", "cumulative rotor angle turned since the start"),
    **{name: (unit, text) for name, (unit, text, _) in FLOW_RESULTS.items()},
}
PARAMETER_NAMES = (*(name for name, _, _ in declarations()), *RUN_PARAMETERS, "interpolate_speed", "fidelity",
                   "suction_state_input")
# parameter values as an importer may have set them (ranges are checked at initialization and for a built model);
# the operating-point parameters are those the model was built with (the boundary inputs' values then)
PARAMETER_TYPES = schema.Record({
    **{name: (schema.Text(length=10 ** 6) if not is_numeric(meta) else
              schema.Integer(-2 ** 63, 2 ** 63) if meta["integer"] else schema.Real(finite=False))
       for name, _, meta in declarations()},
    **{name: schema.Real(finite=False) for name in RUN_PARAMETERS}, "interpolate_speed": schema.Boolean(),
    "fidelity": schema.Text(), "suction_state_input": schema.Text()})
MODEL_SCHEMA = schema.Record({
    "parameters": PARAMETER_TYPES,
    "shaft_speed": schema.Real(finite=False),     # an input may hold any value; a bad one discards the next step
    "boundary_inputs": schema.Record({name: schema.Real(finite=False) for name in BOUNDARY_INPUTS}),
    "step_results": schema.Record({name: schema.Real() for name in STEP_RESULTS}),
    "map_values": schema.Mapping(tuple(d.name for d in OUTPUTS), schema.Real(finite=False)),
    "warned_revolution": schema.Nullable(schema.Real()),
    "simulation": schema.Nullable(compressor_state.SIMULATION),
    "map_run": schema.Nullable(compressor_state.MAP_RUN),
})


class CompressorSlave(GuardedSlave):
    """Single sliding-vane rotary compressor with clearance, contact and friction (docs/model.md §1-§8)."""

    description = ("Single sliding-vane rotary compressor with vane clearance, Hertz contact with hysteresis "
                   "damping and regularised friction; shaft speed in, driving torque and powers out.")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.2, step_size=1e-3)
    example_start_values = {"shaft_speed": 1500.0, "slot_clearance": 5e-5, "stator_clearance": 5e-5}
    documentation_note = ("Coupled to a motor model that integrates the shaft with the rotor inertia, set "
                          "rotor_inertia = 0 here: the driving torque otherwise contains J2 dw/dt a second time.")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.simulation: Simulation | None = None
        self.map_run: PeriodicMapRun | None = None
        self.map_values: dict[str, float] = {}
        self.fidelity = "detailed"
        self.shaft_speed = 1500.0
        self.interpolate_speed = True
        self.step_results = dict.fromkeys(STEP_RESULTS, 0.0)
        self.warned_revolution = None                # end time of the last revolution whose NaN figures were reported
        self.warned_law_excess = False               # the contact-law excess is logged once per run
        self.built_with = None                       # the parameters the model was built with
        self.register_variable(RealVariable(
            "shaft_speed", "rpm", causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
            minimum=0.0, maximum=MAX_SHAFT_SPEED, description="rotor speed; held or ramped over each communication step"))
        for name, default, meta in declarations():
            setattr(self, name, default)
            if name not in BOUNDARY_INPUTS:
                self.register_variable(declared_parameter(name, meta))
        for name in BOUNDARY_INPUTS:
            setattr(self, name, BOUNDARY_INPUTS[name].start)
            self.register_variable(boundary_input_variable(name))
        self.suction_state_input = SUCTION_STATE_INPUTS[0]
        self.register_variable(declared_parameter("suction_state_input", dict(
            choices=SUCTION_STATE_INPUTS, description="which input defines the suction state with suction_pressure: "
                                                      "suction_temperature (a superheated gas) or suction_enthalpy "
                                                      "(any state, wet ones too); the other one is ignored")))
        for name, (unit, default, low, high, text) in RUN_PARAMETERS.items():
            setattr(self, name, default)
            self.register_variable(parameter(name, unit, text, low, high))
        self.register_variable(Boolean(
            "interpolate_speed", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
            initial=Fmi2Initial.exact,
            description="true: the speed and the boundary inputs move linearly from their last values to the "
                        "inputs over each step (continuous inputs); false: the inputs are held over the step"))
        self.register_variable(declared_parameter("fidelity", dict(
            choices=FIDELITIES, description="detailed: every vane impact resolved; periodic_map: the detailed "
                                             "model's periodic steady state tabulated over 10-120 % of "
                                             "pressure_table_speed at initialization (real_gas: over speed x "
                                             "suction pressure x discharge pressure, following those inputs), "
                                             "interpolated at run time")))
        owner = self.owner
        for declared in OUTPUTS:
            getter = (_figure_getter(owner, declared) if declared.per == REVOLUTION
                      else _column_getter(owner, declared, OUTPUT_INDEX[declared.source]))
            self.register_variable(output(declared.name, declared.unit, declared.description, getter))
        for name, (unit, text) in STEP_RESULTS.items():
            self.register_variable(output(name, unit, text, lambda name=name: owner.step_results[name]))
        self.register_variable(integer_output("contact_mode", "bit mask of the regions in contact (bit k-1 for "
                                                              "region ck) at the end of the step",
                                              getter=lambda: owner.contact_mode))
        self.register_variable(integer_output("contact_mode_count", "distinct contact modes so far (cumulative "
                                                                    "dwell >= mode_dwell_time)",
                                              getter=lambda: owner.contact_mode_count))

    # outputs, read when the importer asks ----------------------------------------------------------------------
    @property
    def contact_mode(self) -> int:
        if self.map_run is not None:
            return self.map_run.contact_mode
        return int(self.simulation.last_output[OUTPUT_INDEX["contact_mode"]]) if self.simulation is not None else 0

    @property
    def contact_mode_count(self) -> int:
        if self.simulation is None:
            return 0
        dwell = self.simulation.run_dwell.reshape(-1, MODE_COUNT).sum(axis=0)
        return int((dwell >= self.mode_dwell_time).sum())

    def figure(self, declared) -> float:
        """A per-revolution figure of the last completed revolution: 0 before the first one and for a figure the
        pressure model does not define (the real-gas figures under the pressure tables); NaN (reported with
        fmi2Warning) where the model defines it but the revolution gave it no value."""
        if self.map_run is not None:
            return self.map_values.get(declared.name, 0.0)
        summary = self.simulation.last_revolution if self.simulation is not None else None
        if summary is None or self.pressure_model not in declared.models:
            return 0.0
        return float(getattr(summary, declared.source))

    def undefined_reason(self, name):
        summary = self.simulation.last_revolution if self.simulation is not None else None
        if summary is not None and name in REAL_GAS_FIGURES:
            return (f"the revolution ending at t = {summary.end_time + self.start_time:.9g} s delivered no gas to "
                    f"the discharge (discharge_pressure = {self.discharge_pressure:g} Pa not reached)")
        return "no defined value"

    # model ------------------------------------------------------------------------------------------------------
    def initialize(self):
        check_suction_state_input(self.suction_state_input)
        values = {name: getattr(self, name) for name, _, _ in declarations()}
        params = CompressorParameters(**{**values, **build_point(values)})
        if not (math.isfinite(self.shaft_speed) and 0.0 <= self.shaft_speed <= MAX_SHAFT_SPEED):
            raise ValueError(f"input 'shaft_speed' = {self.shaft_speed!r} rpm at initialization is invalid: "
                             f"allowed [0, {MAX_SHAFT_SPEED:g}] rpm")
        for name, (_, _, low, high, _) in RUN_PARAMETERS.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(f"parameter '{name}' = {value!r} is out of range: allowed [{low:g}, {high:g}]")
        check_fidelity(self.fidelity)
        refusal = shipped_kernels_refusal()
        if refusal is not None:
            self.report(f"the kernels compiled into this FMU are not used: {refusal}; numba loads them from, or "
                        f"compiles them into, {cache_root()} (about 30 s, once per machine)", Fmi2Status.ok)
        self._build(params, self.shaft_speed)
        if self.simulation is not None:
            self.simulation.set_boundary(**self._boundary())       # the inputs' values at the start time
        self._report_kernel_misses()

    def _boundary(self) -> dict:
        """The boundary inputs as Simulation.set_boundary takes them (the one suction_state_input names)."""
        ignored = "suction_enthalpy" if self.suction_state_input == "temperature" else "suction_temperature"
        return {name: getattr(self, name) for name in BOUNDARY_INPUTS if name != ignored}

    def _report_kernel_misses(self):
        """A message (fmi2OK, as the refusal of the shipped kernels: a matter of time, not of results; on stderr and,
        with debug logging, in the logger), once per kernel and process, for a kernel that numba did not find among
        the usable shipped ones (it then loads it from, or compiles it into, the user's cache: seconds to 30 s). The
        kernels that only a failed step's diagnosis calls are not shipped."""
        misses = shipped_kernel_misses()
        if misses:
            self.report(f"{'; '.join(misses)[:1500]}: numba loads them from, or compiles them into, {cache_root()} "
                        f"(seconds to 30 s, once per machine)", Fmi2Status.ok)

    def _build(self, params, speed_rpm):
        """The model of `params` at its start (the speed is the input at the start time)."""
        self.simulation = self.map_run = None
        self.warned_law_excess = False
        self.built_with = {**self._parameter_values(), **{name: getattr(params, name) for name in OPERATING_POINT}}
        if self.fidelity == "periodic_map":
            self.map_run = PeriodicMapRun(params, self.pressure_table_speed, speed_rpm, self.initial_rotor_angle,
                                          self._boundary())
            return
        self.simulation = Simulation(params, constant_speed(speed_rpm), initial_angle=self.initial_rotor_angle,
                                     keep_history=False, table_speed_rpm=self.pressure_table_speed)
        self.simulation.warn_contact_law = False          # logged once per run by advance()
        self.simulation.work_per_ms = self.work_bound

    def input_error(self):
        if not (0.0 <= self.shaft_speed <= MAX_SHAFT_SPEED):
            return f"input 'shaft_speed' = {self.shaft_speed!r} rpm is invalid: allowed [0, {MAX_SHAFT_SPEED:g}] rpm"
        return None

    def advance(self, end_time, step_size):
        if self.map_run is not None:
            return self._advance_map(end_time, step_size)
        simulation = self.simulation
        work_before, angle_before = simulation.state[WORK_IN], simulation.rotor_angle
        flows_before = flow_results(simulation, None, step_size)
        last_before = simulation.last_revolution
        try:       # the speed and the boundary inputs held or interpolated over the step alike
            simulation.advance(end_time, speed_rpm=self.shaft_speed, interpolate=self.interpolate_speed,
                               boundary=self._boundary())
        except ValueError as error:           # a boundary input the run cannot take, refused before any change
            raise StepFailed(str(error)) from None
        except IntegrationError as error:
            raise StepFailed(f"the simulation stopped: {error}") from None
        work, angle = simulation.state[WORK_IN] - work_before, simulation.rotor_angle - angle_before
        results = self.step_results
        results.update(flow_results(simulation, flows_before, step_size))
        results["shaft_torque_mean"] = (float(work / angle) if angle > 0.0 else
                                        float(simulation.last_output[OUTPUT_INDEX["driving_torque"]]))
        results["shaft_work"] = float(simulation.state[WORK_IN])
        results["shaft_angle"] = simulation.rotor_angle - self.initial_rotor_angle
        if simulation.last_revolution is not last_before:
            self._warn_undefined_figures()
        self._report_kernel_misses()
        if simulation.contact_law_excess > 0.0 and not self.warned_law_excess:
            self.warned_law_excess = True
            self.report(simulation.law_excess_text(simulation.contact_law_excess), Fmi2Status.warning)

    def _warn_undefined_figures(self):
        """fmi2Warning once per revolution whose figures have no value (a revolution that delivered no gas)."""
        summary = self.simulation.last_revolution
        undefined = [d.name for d in OUTPUTS if d.per == REVOLUTION and not math.isfinite(self.figure(d))]
        if undefined and summary.end_time != self.warned_revolution:
            self.warned_revolution = summary.end_time
            self.report(f"{', '.join(undefined)} = nan: {self.undefined_reason(undefined[0])}", Fmi2Status.warning)

    def _advance_map(self, end_time, step_size):
        """One step of the periodic_map fidelity (fmu_src.periodic_map_mode), to the model time `end_time`."""
        run = self.map_run
        if not run.follows_fluid:
            for name, value in self._boundary().items():        # a pressure-table map is for one operating point
                if value != self.built_with.get(name):
                    raise StepFailed(f"input '{name}' = {value!r} is out of range: allowed "
                                     f"{self.built_with.get(name)!r}, the value the periodic map was tabulated at "
                                     f"(fidelity 'periodic_map' of pressure_model {self.pressure_model!r} is built "
                                     f"for one operating point; the real_gas one follows the inputs)")
        flows_before = dict(run.flows)
        try:
            work, angle = run.advance(step_size, self.shaft_speed, self.interpolate_speed, self._boundary())
        except ValueError as error:          # outside the table's box: refused before any change
            raise StepFailed(str(error)) from None
        run.time = end_time                    # the exact sum of the step sizes (the clock's), not a float sum
        self.map_values = run.outputs()
        results = self.step_results
        results["shaft_torque_mean"] = work / angle if angle > 0.0 else self.map_values["shaft_torque"]
        results["shaft_work"] = run.work
        results["shaft_angle"] = run.angle - self.initial_rotor_angle
        if run.follows_fluid:
            empty = (run.delivered_enthalpy_per_mass()
                     if run.flows["delivered_mass"] == flows_before["delivered_mass"] else 0.0)
            results.update(step_means(run.flows, flows_before, step_size, empty))

    # state --------------------------------------------------------------------------------------------------
    @classmethod
    def model_schema(cls):
        return MODEL_SCHEMA

    @classmethod
    def model_relations(cls):
        return (_check_built_model,)

    @classmethod
    def model_time(cls, model):
        built = model["simulation"] or model["map_run"]
        return None if built is None else built["time"]

    def changed_parameters(self):
        defaults = {**{name: default for name, default, _ in declarations()},
                    **{name: spec[1] for name, spec in RUN_PARAMETERS.items()}, "interpolate_speed": True,
                    "fidelity": "detailed", "suction_state_input": SUCTION_STATE_INPUTS[0]}
        return {name: value for name, value in self._parameter_values().items() if value != defaults[name]}

    def _parameter_values(self):
        return {name: getattr(self, name) for name in PARAMETER_NAMES}

    def snapshot(self):
        # after initialization the parameters are those the model was built with (fixed parameters cannot change)
        parameters = self.built_with if self.built_with is not None else self._parameter_values()
        return dict(parameters=parameters, shaft_speed=self.shaft_speed,
                    boundary_inputs={name: getattr(self, name) for name in BOUNDARY_INPUTS},
                    step_results=dict(self.step_results),
                    map_values=dict(self.map_values), warned_revolution=self.warned_revolution,
                    simulation=compressor_state.simulation_state(self.simulation) if self.simulation else None,
                    map_run=self.map_run.get_state() if self.map_run else None)

    def restore(self, state):
        """Restore a state; the model is rebuilt from the state's parameters unless it was built with them."""
        parameters = state["parameters"]
        if set(parameters) != set(self._parameter_values()):
            raise ValueError("the state's parameters are not this model's")
        for name, value in parameters.items():
            setattr(self, name, value)
        self.shaft_speed = float(state["shaft_speed"])
        for name, value in state["boundary_inputs"].items():
            setattr(self, name, float(value))
        self.step_results = {name: float(state["step_results"][name]) for name in STEP_RESULTS}
        self.map_values = {name: float(value) for name, value in state["map_values"].items()}
        self.warned_revolution = state["warned_revolution"]
        kind = "map" if state["map_run"] is not None else "detailed" if state["simulation"] is not None else None
        built = "map" if self.map_run is not None else "detailed" if self.simulation is not None else None
        if kind is None:                            # a state from before initialization
            self.simulation = self.map_run = None
            self.built_with = None
            return
        if kind != built or self.built_with != parameters:
            self._build(CompressorParameters(**{name: parameters[name] for name, _, _ in declarations()}), 0.0)
        if kind == "map":
            saved = state["map_run"]
            if set(saved) != set(self.map_run.get_state()):
                raise ValueError("the state's periodic-map run is not this model's")
            self.map_run.set_state({name: float(value) for name, value in saved.items()})
            return
        compressor_state.restore_simulation(self.simulation, state["simulation"])


def _check_built_model(tree) -> None:
    """A saved model that is built: its parameters are valid (each in its range, their relations), its kind is
    its fidelity's, its integrator controls are sane (compressor_state.check_controls)."""
    model = tree["model"]
    parameters = model["parameters"]
    if model["simulation"] is None and model["map_run"] is None:
        return
    if model["simulation"] is not None and model["map_run"] is not None:
        raise ValueError("the state is inconsistent: it holds both a detailed and a periodic-map run")
    compressor = CompressorParameters(**{name: parameters[name] for name, _, _ in declarations()})
    for name, (_, _, low, high, _) in RUN_PARAMETERS.items():
        if not (math.isfinite(parameters[name]) and low <= parameters[name] <= high):
            raise ValueError(f"parameter '{name}' = {parameters[name]!r} is out of range: allowed [{low:g}, {high:g}]")
    check_fidelity(parameters["fidelity"])
    check_suction_state_input(parameters["suction_state_input"])
    if (model["map_run"] is not None) != (parameters["fidelity"] == "periodic_map") or \
            (model["map_run"] is None and model["map_values"]):
        kind = "periodic-map" if model["map_run"] else "detailed"
        raise ValueError(f"the state is inconsistent: a {kind} run with fidelity {parameters['fidelity']!r}"
                         f"{' and periodic-map values' if model['map_values'] else ''}")
    if model["simulation"] is not None:
        compressor_state.check_controls(model["simulation"], machine_from_parameters(compressor))
        compressor_state.check_rows(model["simulation"], parameters["pressure_model"])


def _column_getter(owner, declared, column):
    """The end-of-step value of an output column (the instance is held weakly: no reference cycle); 0, as for a
    figure, where the pressure model does not define it (the chamber qualities under the pressure tables)."""
    def value():
        if owner.map_run is not None:
            return owner.map_values.get(declared.name, 0.0)
        if owner.simulation is None or owner.pressure_model not in declared.models:
            return 0.0
        return float(owner.simulation.last_output[column])
    return value


def _figure_getter(owner, declared):
    return lambda: owner.figure(declared)
