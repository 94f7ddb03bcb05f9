"""Drive-motor physics for motor-compressor coupling studies: the motor integrates the shaft, the load (the
compressor) takes speed and returns torque (docs/model.md §12). Plain Python, no compiled kernels.

Two motor models share one shaft:

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

MOTOR_TYPES = ("induction", "dc")


# State y = (w, i, theta, electrical energy, motor work), SI units, speeds in rad/s.

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
