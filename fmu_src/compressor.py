"""The compressor as an FMI 2.0 co-simulation slave: shaft speed in [rpm], torque and powers out.

A thin map of FMI calls onto `mechanics.Simulation` (one per instance): parameters generated from the parameter
declarations, outputs from the output declarations (mechanics.outputs: end-of-step values read from the last
output row, per-revolution figures from the last completed revolution the time loop summarised), the speed
input held or ramped over each communication step, the whole simulation state saved and restored. Outputs are
read when the importer asks for them: a step does nothing in Python beyond one call of the time loop.
"""
from __future__ import annotations

import math

from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Variability
from pythonfmu.variables import Boolean

from rotary_vane.mechanics import CompressorParameters, IntegrationError, Simulation, constant_speed, declarations
from rotary_vane.mechanics.layout import WORK_IN
from rotary_vane.mechanics.modes import MODE_COUNT
from rotary_vane.mechanics.outputs import OUTPUT_INDEX, REVOLUTION, fmu_outputs

from .periodic_map_mode import FIDELITIES, PeriodicMapRun, check_fidelity
from .slave import GuardedSlave
from .variables import RealVariable, declared_parameter, integer_output, output, parameter

OUTPUTS = fmu_outputs()
MAX_SHAFT_SPEED = 30000.0             # rpm: far above any vane compressor; beyond it the input is refused
# FMU-only parameters (the physics parameters come from mechanics.parameters)
RUN_PARAMETERS = {
    "pressure_table_speed": ("rpm", 1500.0, 1.0, 1e5,
                             "operating speed at which the Level 0.5 pressure table is built"),
    "initial_rotor_angle": ("rad", 0.0, -1e3, 1e3, "rotor angle theta at the start time"),
}
# outputs of the communication step itself
STEP_RESULTS = {
    "shaft_torque_mean": ("N.m", "shaft work over the last step / angle turned in it (the instantaneous torque if "
                                 "the rotor stood still)"),
    "shaft_work": ("J", "cumulative shaft work since the start"),
    "shaft_angle": ("rad", "cumulative rotor angle turned since the start"),
}


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
        self.register_variable(RealVariable(
            "shaft_speed", "rpm", causality=Fmi2Causality.input, variability=Fmi2Variability.continuous,
            minimum=0.0, maximum=MAX_SHAFT_SPEED, description="rotor speed; held or ramped over each communication step"))
        for name, default, meta in declarations():
            setattr(self, name, default)
            self.register_variable(declared_parameter(name, meta))
        for name, (unit, default, low, high, text) in RUN_PARAMETERS.items():
            setattr(self, name, default)
            self.register_variable(parameter(name, unit, text, low, high))
        self.register_variable(Boolean(
            "interpolate_speed", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
            initial=Fmi2Initial.exact,
            description="true: the speed moves linearly from its last value to the input over each step "
                        "(continuous speed); false: the input is held over the step"))
        self.register_variable(declared_parameter("fidelity", dict(
            choices=FIDELITIES, description="detailed: every vane impact resolved; periodic_map: the detailed "
                                             "model's periodic steady state tabulated over 10-120 % of "
                                             "pressure_table_speed at initialization, interpolated at run time")))
        for declared in OUTPUTS:
            getter = (self._figure_getter(declared.name, declared.source) if declared.per == REVOLUTION
                      else self._column_getter(declared.name, OUTPUT_INDEX[declared.source]))
            self.register_variable(output(declared.name, declared.unit, declared.description, getter))
        for name, (unit, text) in STEP_RESULTS.items():
            self.register_variable(output(name, unit, text, lambda name=name: self.step_results[name]))
        self.register_variable(integer_output("contact_mode", "bit mask of the regions in contact (bit k-1 for "
                                                              "region ck) at the end of the step",
                                              getter=self._contact_mode))
        self.register_variable(integer_output("contact_mode_count", "distinct contact modes so far (cumulative "
                                                                    "dwell >= mode_dwell_time)",
                                              getter=self._contact_mode_count))

    # outputs, read on demand ----------------------------------------------------------------------------------
    def _column_getter(self, name, column):
        def value():
            if self.map_run is not None:
                return self.map_values.get(name, 0.0)
            return float(self.simulation.last_output[column]) if self.simulation is not None else 0.0
        return value

    def _figure_getter(self, name, figure):
        """A per-revolution figure; 0 before the first completed revolution and for figures the pressure model
        does not define (the real-gas figures under the pressure tables)."""
        def value():
            if self.map_run is not None:
                return self.map_values.get(name, 0.0)
            summary = self.simulation.last_revolution if self.simulation is not None else None
            number = getattr(summary, figure) if summary is not None else 0.0
            return float(number) if math.isfinite(number) else 0.0
        return value

    def _contact_mode(self):
        if self.map_run is not None:
            return self.map_run.contact_mode
        return int(self.simulation.last_output[OUTPUT_INDEX["contact_mode"]]) if self.simulation is not None else 0

    def _contact_mode_count(self):
        if self.simulation is None:
            return 0
        dwell = self.simulation.run_dwell.reshape(-1, MODE_COUNT).sum(axis=0)
        return int((dwell >= self.mode_dwell_time).sum())

    # model ------------------------------------------------------------------------------------------------------
    def initialize(self):
        params = CompressorParameters(**{name: getattr(self, name) for name, _, _ in declarations()})
        if not (math.isfinite(self.shaft_speed) and 0.0 <= self.shaft_speed <= MAX_SHAFT_SPEED):
            raise ValueError(f"input 'shaft_speed' = {self.shaft_speed!r} rpm at initialization is invalid: "
                             f"allowed [0, {MAX_SHAFT_SPEED:g}] rpm")
        for name, (_, _, low, high, _) in RUN_PARAMETERS.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(f"parameter '{name}' = {value!r} is out of range: allowed [{low:g}, {high:g}]")
        if check_fidelity(self.fidelity) == "periodic_map":
            self.map_run = PeriodicMapRun(params, self.pressure_table_speed, self.shaft_speed,
                                          self.initial_rotor_angle)
            return
        self.simulation = Simulation(params, constant_speed(self.shaft_speed), initial_angle=self.initial_rotor_angle,
                                     keep_history=False, table_speed_rpm=self.pressure_table_speed)

    def advance(self, time, step_size):
        if self.map_run is not None:
            return self._advance_map(time, step_size)
        simulation = self.simulation
        if not math.isclose(time, simulation.time, rel_tol=1e-12, abs_tol=1e-12):
            return self.refuse(f"communication point t = {time + self.start_time!r} s does not continue the "
                               f"model time {simulation.time + self.start_time!r} s")
        if not (0.0 <= self.shaft_speed <= MAX_SHAFT_SPEED):
            return self.refuse(f"input 'shaft_speed' = {self.shaft_speed!r} rpm is invalid: allowed "
                               f"[0, {MAX_SHAFT_SPEED:g}] rpm")
        if simulation.time + step_size == simulation.time:
            return True                             # below the resolution of the model time: nothing to do
        work_before, angle_before = simulation.state[WORK_IN], simulation.rotor_angle
        try:
            simulation.advance(simulation.time + step_size, speed_rpm=self.shaft_speed,
                               interpolate=self.interpolate_speed)
        except IntegrationError as error:
            self.failure = f"the simulation stopped: {error}"
            return self.refuse(self.failure)
        work, angle = simulation.state[WORK_IN] - work_before, simulation.rotor_angle - angle_before
        results = self.step_results
        results["shaft_torque_mean"] = (work / angle if angle > 0.0 else
                                        float(simulation.last_output[OUTPUT_INDEX["driving_torque"]]))
        results["shaft_work"] = float(simulation.state[WORK_IN])
        results["shaft_angle"] = simulation.rotor_angle - self.initial_rotor_angle
        return True

    def _advance_map(self, time, step_size):
        """One step of the periodic_map fidelity (fmu_src.periodic_map_mode)."""
        run = self.map_run
        if not math.isclose(time, run.time, rel_tol=1e-12, abs_tol=1e-12):
            return self.refuse(f"communication point t = {time + self.start_time!r} s does not continue the "
                               f"model time {run.time + self.start_time!r} s")
        if not (0.0 <= self.shaft_speed <= MAX_SHAFT_SPEED):
            return self.refuse(f"input 'shaft_speed' = {self.shaft_speed!r} rpm is invalid: allowed "
                               f"[0, {MAX_SHAFT_SPEED:g}] rpm")
        work, angle = run.advance(step_size, self.shaft_speed, self.interpolate_speed)
        self.map_values = run.outputs()
        results = self.step_results
        results["shaft_torque_mean"] = work / angle if angle > 0.0 else self.map_values["shaft_torque"]
        results["shaft_work"] = run.work
        results["shaft_angle"] = run.angle - self.initial_rotor_angle
        return True

    # state --------------------------------------------------------------------------------------------------
    def snapshot(self):
        parameters = {name: getattr(self, name) for name in [*(n for n, _, _ in declarations()), *RUN_PARAMETERS,
                                                              "interpolate_speed", "fidelity"]}
        return dict(simulation=self.simulation.get_state() if self.simulation else None,
                    map_run=self.map_run.get_state() if self.map_run else None, map_values=self.map_values,
                    step_results=self.step_results, parameters=parameters, start_time=self.start_time,
                    failure=self.failure, shaft_speed=self.shaft_speed)

    def restore(self, state):
        """Restore a state; an instance that is not initialized yet is built from the state's parameters."""
        for name, value in state["parameters"].items():
            setattr(self, name, value)
        for name in ("map_values", "step_results", "failure", "shaft_speed", "start_time"):
            setattr(self, name, state[name])
        if state.get("map_run") is not None:
            if self.map_run is None:
                self.initialize()
            self.map_run.set_state(state["map_run"])
            return
        if state["simulation"] is None:             # a state from before initialization
            self.simulation = self.map_run = None
            return
        if self.simulation is None:
            self.initialize()
        self.simulation.set_state(state["simulation"])
