"""A drive motor as an FMI 2.0 co-simulation slave: load torque in, shaft speed, torque and powers out.

Two motor models share one shaft (FMI_NOTES "Motor coupling": the motor integrates the shaft, the load takes
speed and returns torque):

    (J_motor + J_load) dw/dt = T_motor - T_load,        dtheta/dt = w

J_load is the inertia of the driven rotor, so T_load must not contain it again: with the compressor FMU, whose
driving torque includes J2 dw/dt of the speed it is given, set load_inertia = J2 and the compressor's
rotor_inertia = 0, so that all the shaft's inertia is on the side that integrates the shaft.

* ``induction``: steady-state Kloss torque-speed curve from the nameplate (rated power P_r, rated speed n_r,
  supply frequency f, pole pairs p, breakdown torque ratio k = T_b/T_r):

      w_s = 2 pi f / p,   s = (w_s - w)/w_s,   s_r = (w_s - w_r)/w_s,   T_r = P_r / w_r,   T_b = k T_r
      s_b = s_r (k + sqrt(k^2 - 1))              (Kloss relation T_r = 2 T_b / (s_r/s_b + s_b/s_r) solved for s_b)
      T   = 2 T_b / (s/s_b + s_b/s) = 2 T_b s s_b / (s^2 + s_b^2)      (T = 0 at s = 0; valid for s < 0 and s > 1)

  Electrical power is the air-gap power P_el = T w_s: stator copper and iron losses are neglected, so the only
  loss is the rotor slip power P_el - T w = s T w_s. No electrical state (current output is 0).
* ``dc`` (separately excited or permanent magnet): armature circuit with the back-emf K w,

      L di/dt = V - R i - K w,    T = K i,    P_el = V i,    copper loss R i^2.

Efficiency is T w / P_el while motoring (both positive), else 0. The cumulative electrical energy and the work of
the motor torque on the shaft are integrated with the states, so energy balances hold at any communication step.

Each communication step is integrated with fixed-size RK4 substeps, h <= h_max, chosen at initialization from the
stiffest time scale: induction h_max = 0.5 J / max|dT/dw| with max|dT/dw| = 2 T_b / (s_b w_s) (the slope at
s = 0); dc h_max = 0.5 / (R/L + K/sqrt(L J)), an upper bound on the magnitude of the eigenvalues of the (i, w)
system. The inputs (load torque, voltage) are held over the step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Causality, Fmi2Variability

from .slave import GuardedSlave
from .variables import RealVariable, declared_parameter, output

RPM = 2.0 * math.pi / 60.0                    # rad/s per rpm
MOTOR_TYPES = ("induction", "dc")
MAX_SUBSTEPS = 1_000_000                      # RK4 substeps in one communication step (about 4 s of wall time)


# ------------------------------------------------------------------------------------------------------------
# The models (SI units; speeds in rad/s). State y = (w, i, theta, electrical energy, motor work).

@dataclass(frozen=True)
class InductionMotor:
    """Kloss steady-state torque-speed curve on a rigid shaft of inertia J (see the module docstring)."""

    synchronous_speed: float          # w_s [rad/s]
    breakdown_torque: float           # T_b [N.m]
    breakdown_slip: float             # s_b [1]
    inertia: float                    # J = J_motor + J_load [kg.m2]

    @classmethod
    def from_nameplate(cls, rated_power, rated_speed, supply_frequency, pole_pairs, breakdown_torque_ratio,
                       inertia):
        """s_b from the Kloss relation at the rated point: s_b = s_r (k + sqrt(k^2 - 1)), T_b = k P_r / w_r."""
        synchronous = 2.0 * math.pi * supply_frequency / pole_pairs
        rated_slip = (synchronous - rated_speed) / synchronous
        k = breakdown_torque_ratio
        return cls(synchronous, k * rated_power / rated_speed, rated_slip * (k + math.sqrt(k * k - 1.0)), inertia)

    def torque(self, speed: float) -> float:
        """T = 2 T_b s s_b / (s^2 + s_b^2), s = (w_s - w)/w_s."""
        slip = (self.synchronous_speed - speed) / self.synchronous_speed
        return 2.0 * self.breakdown_torque * slip * self.breakdown_slip / (slip * slip + self.breakdown_slip ** 2)

    def substep(self) -> float:
        """h_max = 0.5 J / max|dT/dw|, max|dT/dw| = 2 T_b / (s_b w_s) at s = 0."""
        return 0.5 * self.inertia * self.breakdown_slip * self.synchronous_speed / (2.0 * self.breakdown_torque)

    def derivatives(self, y, load_torque, voltage):
        """dw/dt = (T - T_load)/J, di/dt = 0, dtheta/dt = w, dE_el/dt = T w_s, dW/dt = T w."""
        speed = y[0]
        torque = self.torque(speed)
        return ((torque - load_torque) / self.inertia, 0.0, speed, torque * self.synchronous_speed, torque * speed)

    def motor_torque(self, y) -> float:
        return self.torque(y[0])

    def electrical_power(self, y, voltage) -> float:
        """Air-gap power T w_s (stator losses neglected)."""
        return self.torque(y[0]) * self.synchronous_speed


@dataclass(frozen=True)
class DcMotor:
    """Separately excited / permanent-magnet DC motor on a rigid shaft of inertia J (see the module docstring)."""

    resistance: float                 # R [Ohm]
    inductance: float                 # L [H]
    torque_constant: float            # K [N.m/A] = [V.s/rad]
    inertia: float                    # J [kg.m2]

    def substep(self) -> float:
        """h_max = 0.5 / (R/L + K/sqrt(L J)): |eigenvalues| of [[-R/L, -K/L], [K/J, 0]] are below the sum."""
        return 0.5 / (self.resistance / self.inductance
                      + self.torque_constant / math.sqrt(self.inductance * self.inertia))

    def derivatives(self, y, load_torque, voltage):
        """dw/dt = (K i - T_load)/J, L di/dt = V - R i - K w, dtheta/dt = w, dE_el/dt = V i, dW/dt = K i w."""
        speed, current = y[0], y[1]
        torque = self.torque_constant * current
        return ((torque - load_torque) / self.inertia,
                (voltage - self.resistance * current - self.torque_constant * speed) / self.inductance,
                speed, voltage * current, torque * speed)

    def motor_torque(self, y) -> float:
        return self.torque_constant * y[1]

    def electrical_power(self, y, voltage) -> float:
        return voltage * y[1]


def rk4(model, y, step, substeps, load_torque, voltage):
    """Classical fourth-order Runge-Kutta over `step` in `substeps` equal substeps, inputs held."""
    h = step / substeps
    f = model.derivatives
    for _ in range(substeps):
        k1 = f(y, load_torque, voltage)
        k2 = f(tuple(a + 0.5 * h * b for a, b in zip(y, k1)), load_torque, voltage)
        k3 = f(tuple(a + 0.5 * h * b for a, b in zip(y, k2)), load_torque, voltage)
        k4 = f(tuple(a + h * b for a, b in zip(y, k3)), load_torque, voltage)
        y = tuple(a + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4) for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4))
    return y


# ------------------------------------------------------------------------------------------------------------
# The FMI slave.

def _number(unit, default, minimum, maximum, description, *, exclusive_minimum=False, integer=False):
    return dict(unit=unit, default=default, min=minimum, max=maximum, exclusive_min=exclusive_minimum,
                integer=integer, description=description)


PARAMETERS = {
    "motor_type": dict(unit="", default="induction", choices=MOTOR_TYPES,
                       description="motor model: Kloss steady-state induction motor or DC motor with armature "
                                   "circuit"),
    "rated_power": _number("W", 1500.0, 0.0, 1e7, "induction: rated (nameplate) mechanical power P_r",
                           exclusive_minimum=True),
    "rated_speed": _number("rpm", 1440.0, 0.0, 1e5, "induction: rated speed n_r, below the synchronous speed "
                                                    "60 f/p", exclusive_minimum=True),
    "supply_frequency": _number("Hz", 50.0, 0.0, 1000.0, "induction: supply frequency f", exclusive_minimum=True),
    "pole_pairs": _number("1", 2, 1, 50, "induction: number of pole pairs p", integer=True),
    "breakdown_torque_ratio": _number("1", 2.5, 1.0, 10.0, "induction: breakdown torque / rated torque "
                                                           "k = T_b/T_r", exclusive_minimum=True),
    "armature_resistance": _number("Ohm", 0.3, 0.0, 1e3, "dc: armature resistance R", exclusive_minimum=True),
    "armature_inductance": _number("H", 1e-3, 0.0, 10.0, "dc: armature inductance L", exclusive_minimum=True),
    "torque_constant": _number("N.m/A", 0.28, 0.0, 100.0, "dc: torque constant K (= back-emf constant in V.s/rad)",
                               exclusive_minimum=True),
    "motor_inertia": _number("kg.m2", 4.0e-3, 0.0, 1e3, "moment of inertia of the motor rotor J_motor"),
    "load_inertia": _number("kg.m2", 5.5e-4, 0.0, 1e3, "moment of inertia of the driven load on the shaft J_load "
                                                       "(the compressor's rotor_inertia; then give the compressor "
                                                       "rotor_inertia = 0, else its torque counts it again)"),
    "initial_speed": _number("rpm", 0.0, -1e5, 1e5, "shaft speed at the start time"),
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


def check_parameter(name, value, meta):
    """Raise ValueError naming the parameter, its value and the allowed values or range."""
    if "choices" in meta:
        if value not in meta["choices"]:
            raise ValueError(f"parameter '{name}' = {value!r} is invalid: allowed one of {', '.join(meta['choices'])}")
        return
    unit = "" if meta["unit"] == "1" else f" {meta['unit']}"
    low = "(" if meta["exclusive_min"] else "["
    allowed = f"{'an integer' if meta['integer'] else 'a finite value'} in {low}{meta['min']:g}, {meta['max']:g}]{unit}"
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or (meta["integer"] and value != int(value)) or value > meta["max"] \
            or value < meta["min"] or (meta["exclusive_min"] and value == meta["min"]):
        raise ValueError(f"parameter '{name}' = {value!r}{unit} is out of range: allowed {allowed}")


class MotorSlave(GuardedSlave):
    """Drive motor (Kloss induction motor or DC motor) integrating the shaft: load torque in, speed out."""

    description = ("Drive motor on a rigid shaft: steady-state Kloss induction motor or DC motor with armature "
                   "circuit; load torque in, shaft speed [rpm], torque, powers and energies out.")
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=0.5, step_size=1e-3)
    example_start_values = {"motor_type": "induction", "load_torque": 2.5, "load_inertia": 5.5e-4}
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
        for name, (unit, start, _, text) in INPUTS.items():
            setattr(self, name, start)
            self.register_variable(RealVariable(name, unit, causality=Fmi2Causality.input,
                                                variability=Fmi2Variability.continuous, description=text))
        for name, meta in PARAMETERS.items():
            setattr(self, name, meta["default"])
            self.register_variable(declared_parameter(name, meta))
        for name, (unit, text) in OUTPUTS.items():
            self.register_variable(output(name, unit, text, getter=lambda name=name: self._output(name)))

    def _output(self, name):
        if self.model is None and name == "shaft_speed":
            return self.initial_speed                 # initialization mode: the output is the initial speed
        return self.outputs[name]

    # model ------------------------------------------------------------------------------------------------------
    def initialize(self):
        for name, meta in PARAMETERS.items():
            check_parameter(name, getattr(self, name), meta)
        inertia = self.motor_inertia + self.load_inertia
        if not inertia > 0.0:
            raise ValueError(f"motor_inertia + load_inertia = {inertia!r} kg.m2 is invalid: allowed > 0 kg.m2")
        if self.motor_type == "induction":
            synchronous_rpm = 60.0 * self.supply_frequency / self.pole_pairs
            if not self.rated_speed < synchronous_rpm:
                raise ValueError(f"parameter 'rated_speed' = {self.rated_speed!r} rpm is out of range: allowed "
                                 f"(0, {synchronous_rpm:g}) rpm, below the synchronous speed 60 f/p")
            self.model = InductionMotor.from_nameplate(self.rated_power, self.rated_speed * RPM,
                                                       self.supply_frequency, self.pole_pairs,
                                                       self.breakdown_torque_ratio, inertia)
        else:
            self.model = DcMotor(self.armature_resistance, self.armature_inductance, self.torque_constant, inertia)
        self.max_substep = self.model.substep()
        self.time = 0.0
        self.state = (self.initial_speed * RPM, 0.0, 0.0, 0.0, 0.0)
        self._update_outputs()

    def advance(self, time, step_size):
        if abs(time - self.time) > 1e-9 * max(1.0, abs(time)):
            return self.refuse(f"communication point t = {time + self.start_time!r} s does not continue the "
                               f"model time {self.time + self.start_time!r} s")
        substeps = max(1, math.ceil(step_size / self.max_substep))
        if substeps > MAX_SUBSTEPS:
            return self.refuse(f"communication step size = {step_size!r} s is too large: allowed up to "
                               f"{MAX_SUBSTEPS * self.max_substep:g} s ({MAX_SUBSTEPS} RK4 substeps of at most "
                               f"{self.max_substep:g} s)")
        for name, (unit, _, limit, _) in INPUTS.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and abs(value) <= limit):
                return self.refuse(f"input '{name}' = {value!r} {unit} is invalid: allowed a finite value in "
                                   f"[{-limit:g}, {limit:g}] {unit}")
        state = rk4(self.model, self.state, step_size, substeps, self.load_torque, self.voltage)
        if not all(math.isfinite(value) for value in state):
            return self.refuse(f"the motor state became non-finite at t = {time + step_size + self.start_time!r} "
                               f"s: {state}; step discarded")
        self.state, self.time = state, time + step_size           # the host's time: no drift of sums
        self._update_outputs()
        return True

    def _update_outputs(self):
        y, values = self.state, self.outputs
        torque = self.model.motor_torque(y)
        electrical = self.model.electrical_power(y, self.voltage)
        mechanical = torque * y[0]
        values.update(shaft_speed=y[0] / RPM, motor_torque=torque, electrical_power=electrical,
                      efficiency=mechanical / electrical if electrical > 0.0 and mechanical > 0.0 else 0.0,
                      shaft_angle=y[2], current=y[1], electrical_energy=y[3], motor_work=y[4])

    # state --------------------------------------------------------------------------------------------------
    def snapshot(self):
        return dict(model=self.model, max_substep=self.max_substep, time=self.time, state=self.state,
                    outputs=dict(self.outputs), failure=self.failure,
                    inputs={name: getattr(self, name) for name in INPUTS})

    def restore(self, state):
        for name in ("model", "max_substep", "time", "state", "outputs", "failure"):
            setattr(self, name, state[name])
        for name, value in state["inputs"].items():
            setattr(self, name, value)
