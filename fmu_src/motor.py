"""The drive motor as an FMI 2.0 co-simulation slave: load torque in, shaft speed, torque and powers out.

The physics (Kloss induction motor, DC motor, the shaft equation and its RK4 substeps) is
`rotary_vane.mechanics.reduced.drive_motor`; this module declares the FMU variables and maps the FMI calls onto it.
"""
from __future__ import annotations

import math

from pythonfmu.default_experiment import DefaultExperiment

from ..mechanics.reduced.drive_motor import MOTOR_TYPES, DcMotor, InductionMotor, rk4
from ..mechanics.loop.speed import RPM

from . import state_schema as schema
from .declared_slave import DeclaredSlave, number
from .slave import StepFailed

MAX_SUBSTEPS = 1_000_000                      # RK4 substeps in one communication step (about 4 s of wall time)


# ------------------------------------------------------------------------------------------------------------
# The FMI slave.

PARAMETERS = {
    "motor_type": dict(unit="", default="induction", choices=MOTOR_TYPES,
                       description="motor model: Kloss steady-state induction motor or DC motor with armature "
                                   "circuit"),
    "rated_power": number("W", 1500.0, 1.0, 1e7, "induction: rated (nameplate) mechanical power P_r"),
    "rated_speed": number("rpm", 1440.0, 1.0, 1e5, "induction: rated speed n_r, below the synchronous speed "
                                                    "60 f/p"),
    "supply_frequency": number("Hz", 50.0, 0.1, 1000.0, "induction: supply frequency f"),
    "pole_pairs": number("1", 2, 1, 50, "induction: number of pole pairs p", integer=True),
    "breakdown_torque_ratio": number("1", 2.5, 1.01, 10.0, "induction: breakdown torque / rated torque "
                                                           "k = T_b/T_r"),
    "armature_resistance": number("Ohm", 0.3, 1e-6, 1e3, "dc: armature resistance R"),
    "armature_inductance": number("H", 1e-3, 1e-9, 10.0, "dc: armature inductance L"),
    "torque_constant": number("N.m/A", 0.28, 1e-6, 100.0, "dc: torque constant K (= back-emf constant in V.s/rad)"),
    "motor_inertia": number("kg.m2", 4.0e-3, 0.0, 1e3, "moment of inertia of the motor rotor J_motor"),
    "load_inertia": number("kg.m2", 5.5e-4, 0.0, 1e3, "moment of inertia of the driven load on the shaft J_load "
                                                       "(the compressor's rotor_inertia; then give the compressor "
                                                       "rotor_inertia = 0, else its torque counts it again)"),
    "initial_speed": number("rpm", 0.0, -1e5, 1e5, "shaft speed at the start time"),
}
INPUTS = {  # name -> (unit, start, limit on |value|, description)
    "load_torque": ("N.m", 0.0, 1e6, "load torque on the shaft, held over each communication step "
                                     "(connect the compressor's shaft_torque_mean)"),
    "voltage": ("V", 48.0, 1e5, "dc: armature supply voltage V, held over each communication step "
                                "(not used by the induction motor)"),
}
OUTPUTS = {  # name -> (unit, description)
    "shaft_speed": ("rpm", "shaft speed at the end of the step (the initial speed before the first step)"),
    "motor_torque": ("N.m", "electromagnetic torque of the motor at the end of the step"),
    "electrical_power": ("W", "electrical input power at the end of the step (induction: air-gap power T w_s)"),
    "efficiency": ("1", "mechanical power T w / electrical power at the end of the step (0 when not motoring)"),
    "shaft_angle": ("rad", "cumulative shaft angle turned since the start"),
    "current": ("A", "dc: armature current at the end of the step (0 for the induction motor)"),
    "electrical_energy": ("J", "cumulative electrical energy taken from the supply since the start"),
    "motor_work": ("J", "cumulative work of the motor torque on the shaft since the start (integral of T w)"),
}


# a saved motor (MotorSlave.snapshot); parameter values as an importer may have set them (ranges: check_built)
MODEL_SCHEMA = schema.Record({
    "parameters": schema.Record({name: schema.Text(length=10 ** 6) if "choices" in meta else
                          schema.Integer(-2 ** 63, 2 ** 63) if meta["integer"] else schema.Real(finite=False)
                          for name, meta in PARAMETERS.items()}),
    "built": schema.Boolean(),
    "time": schema.Real(0.0, math.inf),
    "state": schema.Sequence(schema.Real(), 5),
    "outputs": schema.Record({name: schema.Real() for name in OUTPUTS}),
    "inputs": schema.Record({name: schema.Real(finite=False) for name in INPUTS}),  # a bad input discards the next step
})


class MotorSlave(DeclaredSlave):
    """Drive motor (Kloss induction motor or DC motor) integrating the shaft: load torque in, speed out."""

    description = ("Drive motor on a rigid shaft: steady-state Kloss induction motor or DC motor with armature "
                   "circuit; load torque in, shaft speed [rpm], torque, powers and energies out.")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.5, step_size=1e-3)
    example_start_values = {"motor_type": "induction", "load_torque": 2.5, "load_inertia": 5.5e-4}
    declared_parameters = PARAMETERS
    state_schema = MODEL_SCHEMA
    documentation_note = ("Plain Python, no compiled kernels. Couple shaft_speed to the compressor's shaft_speed "
                          "and the compressor's shaft_torque_mean to load_torque; put the compressor's rotor "
                          "inertia into load_inertia and set the compressor's rotor_inertia to 0.")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.model: InductionMotor | DcMotor | None = None
        self.max_substep = 0.0
        self.time = 0.0                               # model time since the start time [s]
        self.state = (0.0,) * 5                       # (w, i, theta, electrical energy, motor work)
        self.outputs = dict.fromkeys(OUTPUTS, 0.0)
        self.register_declared_variables([(name, unit, start, text) for name, (unit, start, _, text) in INPUTS.items()],
                                         OUTPUTS)

    def _output(self, name):
        if self.model is None and name == "shaft_speed":
            return self.initial_speed                 # initialization mode: the output is the initial speed
        return self.outputs[name]

    # model ------------------------------------------------------------------------------------------------------
    def initialize(self):
        self.check_parameters(self.parameter_values())
        self._build_model()
        self.time = 0.0
        self.state = (self.initial_speed * RPM, 0.0, 0.0, 0.0, 0.0)
        self._update_outputs()

    def _build_model(self):
        """The motor model of the current (validated) parameters."""
        inertia = self.motor_inertia + self.load_inertia
        if self.motor_type == "induction":
            self.model = InductionMotor.from_nameplate(self.rated_power, self.rated_speed * RPM,
                                                       self.supply_frequency, self.pole_pairs,
                                                       self.breakdown_torque_ratio, inertia)
        else:
            self.model = DcMotor(self.armature_resistance, self.armature_inductance, self.torque_constant, inertia)
        self.max_substep = self.model.substep()

    def input_error(self):
        for name, (unit, _, limit, _) in INPUTS.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and abs(value) <= limit):
                return f"input '{name}' = {value!r} {unit} is invalid: allowed a finite value in [{-limit:g}, {limit:g}] {unit}"
        return None

    def advance(self, end_time, step_size):
        substeps = max(1, math.ceil(step_size / self.max_substep))
        if substeps > MAX_SUBSTEPS:
            raise StepFailed(f"communication step size = {step_size!r} s is too large: allowed up to "
                             f"{MAX_SUBSTEPS * self.max_substep:g} s ({MAX_SUBSTEPS} RK4 substeps of at most "
                             f"{self.max_substep:g} s)")
        state = rk4(self.model, self.state, step_size, substeps, self.load_torque, self.voltage)
        if not all(math.isfinite(value) for value in state):
            raise StepFailed(f"the motor state became non-finite at t = {end_time + self.start_time!r} s: {state}")
        self.state, self.time = state, end_time
        self._update_outputs()

    def _update_outputs(self):
        y, values = self.state, self.outputs
        torque = self.model.motor_torque(y)
        electrical = self.model.electrical_power(y, self.voltage)
        mechanical = torque * y[0]
        values.update(shaft_speed=y[0] / RPM, motor_torque=torque, electrical_power=electrical,
                      efficiency=mechanical / electrical if electrical > 0.0 and mechanical > 0.0 else 0.0,
                      shaft_angle=y[2], current=y[1], electrical_energy=y[3], motor_work=y[4])

    # state --------------------------------------------------------------------------------------------------
    @classmethod
    def check_parameters(cls, values: dict) -> None:
        """Each parameter in its range, and their relations; ValueError naming the parameter otherwise."""
        super().check_parameters(values)
        inertia = values["motor_inertia"] + values["load_inertia"]
        if not inertia > 0.0:
            raise ValueError(f"motor_inertia + load_inertia = {inertia!r} kg.m2 is invalid: allowed > 0 kg.m2")
        if values["motor_type"] == "induction":
            synchronous_rpm = 60.0 * values["supply_frequency"] / values["pole_pairs"]
            if not values["rated_speed"] < synchronous_rpm:
                raise ValueError(f"parameter 'rated_speed' = {values['rated_speed']!r} rpm is out of range: "
                                 f"allowed (0, {synchronous_rpm:g}) rpm, below the synchronous speed 60 f/p")

    def snapshot(self):
        return dict(parameters=self.parameter_values(), built=self.model is not None,
                    time=self.time, state=list(self.state), outputs=dict(self.outputs),
                    inputs={name: getattr(self, name) for name in INPUTS})

    def restore(self, state):
        """Restore a state; the motor model is rebuilt from the state's parameters."""
        values = [float(value) for value in state["state"]]
        if len(values) != 5:
            raise ValueError("the state is not this motor's")
        self.restore_settings(state, INPUTS)
        self.model = None
        if state["built"]:
            self._build_model()
        self.time, self.state = float(state["time"]), tuple(values)
        self.outputs = {name: float(state["outputs"][name]) for name in OUTPUTS}
