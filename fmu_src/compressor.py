"""The compressor as an FMI 2.0 co-simulation slave: shaft speed in [rpm], torque and powers out.

A thin map of FMI calls onto `mechanics.Simulation` (one per instance): parameters generated from the parameter
declarations, the speed input held or ramped over each communication step, per-revolution figures from a
`RevolutionMonitor`, the whole simulation state saved and restored.
"""
from __future__ import annotations

import math

from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Status, Fmi2Variability
from pythonfmu.variables import Boolean

from rotary_vane.mechanics import CompressorParameters, IntegrationError, Simulation, constant_speed, declarations
from rotary_vane.mechanics.layout import OUTPUT_INDEX, WORK_IN
from rotary_vane.mechanics.performance import RevolutionMonitor

from . import compressor_state
from .periodic_map_mode import FIDELITIES, PeriodicMapRun, check_fidelity
from .slave import GuardedSlave, StepFailed
from .variables import RealVariable, declared_parameter, integer_output, output, parameter

# output name -> (unit, description); filled from the simulation after every step
END_OF_STEP = {
    "shaft_torque": ("N.m", "driving torque on the rotor T_d = -lambda6 at the end of the step"),
    "stator_reaction_moment": ("N.m", "stator reaction moment lambda3 (contact + gas) at the end of the step"),
    **{f"contact_force_{k}": ("N", f"normal force in contact region c{k} at the end of the step")
       for k in range(1, 7)},
    "vane_displacement": ("m", "vane radial displacement s_r (docs/model.md §3.4) at the end of the step"),
    "vane_velocity": ("m/s", "vane radial velocity v_r at the end of the step"),
    "vane_acceleration": ("m/s2", "vane radial acceleration a_r at the end of the step"),
    "vane_tilt": ("rad", "vane tilt phi3 - theta at the end of the step"),
    "vane_tangential_velocity": ("m/s", "vane tangential velocity v_theta (docs/model.md §3.4) at the end of the step"),
    "vane_tangential_acceleration": ("m/s2", "vane tangential acceleration a_theta at the end of the step"),
    "leading_chamber_pressure": ("Pa", "leading-chamber pressure at the end of the step"),
    "trailing_chamber_pressure": ("Pa", "trailing-chamber pressure at the end of the step"),
}
SOURCE_COLUMN = {
    "shaft_torque": "driving_torque", "vane_displacement": "vane_displacement",
    "vane_velocity": "vane_radial_velocity", "vane_acceleration": "vane_radial_acceleration",
    "vane_tilt": "vane_tilt", "vane_tangential_velocity": "vane_tangential_velocity",
    "vane_tangential_acceleration": "vane_tangential_acceleration", "leading_chamber_pressure": "leading_pressure",
    "trailing_chamber_pressure": "trailing_pressure",
    **{f"contact_force_{k}": f"normal_force_{k}" for k in range(1, 7)},
}
PER_REVOLUTION = {
    "input_power": ("W", "mean shaft input power over the last completed revolution (0 before the first)"),
    "output_power": ("W", "mean power delivered to the gas over the last completed revolution"),
    "friction_power": ("W", "mean friction power over the last completed revolution"),
    "damping_power": ("W", "mean contact-damping power over the last completed revolution"),
    "mechanical_efficiency": ("1", "output power / input power over the last completed revolution"),
    "max_contact_force": ("N", "largest normal force of any region over the last completed revolution"),
}
# per-revolution figures of the real-gas chambers (pressure_model real_gas; 0 with the pressure tables)
PER_REVOLUTION_GAS = {
    "suction_mass_flow": ("kg/s", "mean net mass flow drawn from the suction side over the last completed "
                                  "revolution (real_gas)"),
    "discharge_mass_flow": ("kg/s", "mean mass flow through the discharge valve over the last completed "
                                    "revolution (real_gas)"),
    "discharge_temperature": ("K", "mixed temperature of the gas discharged over the last completed revolution, "
                                   "at discharge pressure (real_gas)"),
    "indicated_power": ("W", "mean p-V power on the chambers over the last completed revolution (real_gas)"),
    "volumetric_efficiency": ("1", "delivered mass / (suction density x lobe volume x lobes) per revolution "
                                   "(real_gas)"),
    "isentropic_efficiency": ("1", "discharge mass flow x (h_2s - h_1) / input power over the last completed "
                                   "revolution (real_gas)"),
}
MAX_SHAFT_SPEED = 30000.0             # rpm: far above any vane compressor; beyond it the input is refused
# FMU-only parameters (the physics parameters come from mechanics.parameters)
RUN_PARAMETERS = {
    "pressure_table_speed": ("rpm", 1500.0, 1.0, 1e5,
                             "operating speed at which the Level 0.5 pressure table is built"),
    "initial_rotor_angle": ("rad", 0.0, -1e3, 1e3, "rotor angle theta at the start time"),
}

PARAMETER_NAMES = (*(name for name, _, _ in declarations()), *RUN_PARAMETERS, "interpolate_speed", "fidelity")


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
        self.monitor: RevolutionMonitor | None = None
        self.map_run: PeriodicMapRun | None = None
        self.fidelity = "detailed"
        self.shaft_speed = 1500.0
        self.interpolate_speed = True
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
        self.outputs = dict.fromkeys([*END_OF_STEP, "shaft_torque_mean", "shaft_work", "shaft_angle",
                                      *PER_REVOLUTION, *PER_REVOLUTION_GAS], 0.0)
        self.contact_mode = 0
        self.contact_mode_count = 0
        self.warned_revolution = None                # end time of the last revolution whose NaN figures were reported
        self.built_with = None                       # the parameters the model was built with
        for name, (unit, text) in {**END_OF_STEP, **PER_REVOLUTION, **PER_REVOLUTION_GAS}.items():
            self._register_output(name, unit, text)
        self._register_output("shaft_torque_mean", "N.m", "shaft work over the last step / angle turned in it "
                                                          "(the instantaneous torque if the rotor stood still)")
        self._register_output("shaft_work", "J", "cumulative shaft work since the start")
        self._register_output("shaft_angle", "rad", "cumulative rotor angle turned since the start")
        self.register_variable(integer_output("contact_mode", "bit mask of the regions in contact "
                                                              "(bit k-1 for region ck) at the end of the step"))
        self.register_variable(integer_output("contact_mode_count", "distinct contact modes so far (cumulative "
                                                                    "dwell >= mode_dwell_time)"))

    def _register_output(self, name, unit, text):
        owner = self.owner
        self.register_variable(output(name, unit, text, getter=lambda: owner.outputs[name]))

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
        check_fidelity(self.fidelity)
        self._build(params, self.shaft_speed)

    def _build(self, params, speed_rpm):
        """The model of `params` at its start (the speed is the input at the start time)."""
        self.simulation = self.monitor = self.map_run = None
        self.built_with = self._parameter_values()
        if self.fidelity == "periodic_map":
            self.map_run = PeriodicMapRun(params, self.pressure_table_speed, speed_rpm, self.initial_rotor_angle)
            return
        self.monitor = RevolutionMonitor(params)
        self.simulation = Simulation(params, constant_speed(speed_rpm), initial_angle=self.initial_rotor_angle,
                                     keep_history=False, table_speed_rpm=self.pressure_table_speed,
                                     observers=[self.monitor])

    def input_error(self):
        if not (0.0 <= self.shaft_speed <= MAX_SHAFT_SPEED):
            return f"input 'shaft_speed' = {self.shaft_speed!r} rpm is invalid: allowed [0, {MAX_SHAFT_SPEED:g}] rpm"
        return None

    def advance(self, end_time, step_size):
        if self.map_run is not None:
            return self._advance_map(step_size)
        simulation = self.simulation
        work_before, angle_before = simulation.state[WORK_IN], simulation.rotor_angle
        try:
            simulation.advance(end_time, speed_rpm=self.shaft_speed, interpolate=self.interpolate_speed)
        except IntegrationError as error:
            raise StepFailed(f"the simulation stopped: {error}") from None
        self._update_outputs(simulation.state[WORK_IN] - work_before, simulation.rotor_angle - angle_before)

    def _update_outputs(self, work, angle):
        row = self.simulation.last_output
        values = self.outputs
        for name, column in SOURCE_COLUMN.items():
            values[name] = float(row[OUTPUT_INDEX[column]])
        values["stator_reaction_moment"] = float(row[OUTPUT_INDEX["stator_contact_moment"]]
                                                 + row[OUTPUT_INDEX["stator_gas_moment"]])
        values["shaft_torque_mean"] = work / angle if angle > 0.0 else values["shaft_torque"]
        values["shaft_work"] = float(self.simulation.state[WORK_IN])
        values["shaft_angle"] = self.simulation.rotor_angle - self.initial_rotor_angle
        last = self.monitor.last
        if last is not None:
            for name in ("input_power", "output_power", "friction_power", "damping_power",
                         "mechanical_efficiency"):
                values[name] = float(getattr(last, name))
            values["max_contact_force"] = float(max(last.max_normal_force))
            if self.simulation.gas_reference is not None:
                figures = self.simulation.gas_reference.figures(last)
                for name in PER_REVOLUTION_GAS:
                    values[name] = float(figures[name])
                undefined = [name for name in PER_REVOLUTION_GAS if not math.isfinite(values[name])]
                if undefined and last.end_time != self.warned_revolution:
                    self.warned_revolution = last.end_time
                    self.report(f"{', '.join(undefined)} = nan: {self.undefined_reason(undefined[0])}",
                                Fmi2Status.warning)
        self.contact_mode = int(row[OUTPUT_INDEX["contact_mode"]])
        self.contact_mode_count = len(self.monitor.distinct_modes)

    def undefined_reason(self, name):
        last = self.monitor.last if self.monitor is not None else None
        if name in PER_REVOLUTION_GAS and last is not None:
            return (f"the revolution ending at t = {last.end_time + self.start_time:.9g} s delivered no gas to the "
                    f"discharge (discharge_pressure = {self.discharge_pressure:g} Pa not reached)")
        return "no defined value"

    def _advance_map(self, step_size):
        """One step of the periodic_map fidelity (fmu_src.periodic_map_mode)."""
        run = self.map_run
        work, angle = run.advance(step_size, self.shaft_speed, self.interpolate_speed)
        self.outputs.update(run.outputs())
        self.outputs["shaft_torque_mean"] = work / angle if angle > 0.0 else self.outputs["shaft_torque"]
        self.outputs["shaft_work"] = run.work
        self.outputs["shaft_angle"] = run.angle - self.initial_rotor_angle
        self.contact_mode = run.contact_mode

    # state --------------------------------------------------------------------------------------------------
    def _parameter_values(self):
        return {name: getattr(self, name) for name in PARAMETER_NAMES}

    def snapshot(self):
        # after initialization the parameters are those the model was built with (fixed parameters cannot change)
        parameters = self.built_with if self.built_with is not None else self._parameter_values()
        return dict(parameters=parameters, shaft_speed=self.shaft_speed, outputs=dict(self.outputs),
                    contact_mode=self.contact_mode, contact_mode_count=self.contact_mode_count,
                    warned_revolution=self.warned_revolution,
                    simulation=compressor_state.simulation_state(self.simulation) if self.simulation else None,
                    monitor=compressor_state.monitor_state(self.monitor) if self.monitor else None,
                    map_run=self.map_run.get_state() if self.map_run else None)

    @classmethod
    def serializable(cls, tree):
        model = tree["model"]
        if model["monitor"] is None:
            return tree
        return {**tree, "model": {**model, "monitor": compressor_state.compact(model["monitor"])}}

    def restore(self, state):
        """Restore a state; the model is rebuilt from the state's parameters unless it was built with them."""
        parameters = state["parameters"]
        if set(parameters) != set(self._parameter_values()):
            raise ValueError("the state's parameters are not this model's")
        for name, value in parameters.items():
            setattr(self, name, value)
        self.shaft_speed = float(state["shaft_speed"])
        self.outputs = {name: float(state["outputs"][name]) for name in self.outputs}
        self.contact_mode, self.contact_mode_count = int(state["contact_mode"]), int(state["contact_mode_count"])
        self.warned_revolution = state["warned_revolution"]
        kind = "map" if state["map_run"] is not None else "detailed" if state["simulation"] is not None else None
        built = "map" if self.map_run is not None else "detailed" if self.simulation is not None else None
        if kind is None:                            # a state from before initialization
            self.simulation = self.monitor = self.map_run = None
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
        self.monitor = compressor_state.restore_monitor(self.simulation.params, state["monitor"])
        self.simulation.observers = [self.monitor]
