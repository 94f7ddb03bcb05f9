"""Rotor speed input: constant, cycloidal or linear ramp, or a speed held or interpolated over an advance (docs/model.md §3.2).

A speed law is one segment starting at time t0 and rotor angle theta0 with speed omega0, moving to omega1 over
`duration` and constant after it. In the kernel it is the float array
[shape, t0, theta0, omega0, omega1, duration]; the rotor angle, speed and acceleration follow in closed form.
"""
import math
from dataclasses import dataclass

import numpy as np
from ...kernels.kernel import kernel

CONSTANT, LINEAR, CYCLOIDAL = 0, 1, 2
SHAPES = {"constant": CONSTANT, "linear": LINEAR, "cycloidal": CYCLOIDAL}
RPM = 2.0 * math.pi / 60.0           # rad/s per rpm


def check_speed(name: str, rpm: float) -> float:
    """Validate a speed typed in rpm; return it in rad/s. Raises ValueError naming the variable."""
    if isinstance(rpm, bool) or not isinstance(rpm, (int, float, np.floating, np.integer)) \
            or not math.isfinite(rpm) or rpm < 0.0:
        raise ValueError(f"'{name}' = {rpm!r} rpm is invalid: allowed a finite speed >= 0 rpm")
    return float(rpm) * RPM


@dataclass(frozen=True)
class SpeedLaw:
    """A speed segment; build one with `constant_speed`, `cycloidal_ramp` or `linear_ramp`."""
    shape: str
    target_rpm: float
    duration: float = 0.0
    start_rpm: float = 0.0

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise ValueError(f"'shape' = {self.shape!r} is invalid: allowed one of {', '.join(SHAPES)}")
        check_speed("target_rpm", self.target_rpm)
        check_speed("start_rpm", self.start_rpm)
        if self.shape != "constant" and not (math.isfinite(self.duration) and self.duration > 0.0):
            raise ValueError(f"'duration' = {self.duration!r} s is invalid: allowed a finite duration > 0 s")

    def segment(self, start_time: float, start_angle: float) -> np.ndarray:
        """The kernel array of this law starting at (start_time, start_angle)."""
        start = self.target_rpm if self.shape == "constant" else self.start_rpm
        return np.array([SHAPES[self.shape], start_time, start_angle, start * RPM, self.target_rpm * RPM,
                         self.duration], dtype=np.float64)


def constant_speed(rpm: float) -> SpeedLaw:
    """Constant speed: theta = theta0 + omega t."""
    return SpeedLaw("constant", rpm)


def cycloidal_ramp(rpm: float, duration: float = 0.4, start_rpm: float = 0.0) -> SpeedLaw:
    """The thesis start-up: omega = omega_ss (t/t_r - sin(2 pi t/t_r)/(2 pi)) for t < t_r (docs/model.md §3.2)."""
    return SpeedLaw("cycloidal", rpm, duration, start_rpm)


def linear_ramp(rpm: float, duration: float, start_rpm: float = 0.0) -> SpeedLaw:
    """Linear ramp from start_rpm to rpm over duration, then constant."""
    return SpeedLaw("linear", rpm, duration, start_rpm)


@kernel
def rotor_motion(t, law):
    """(theta, omega, theta_ddot) at time t under the speed segment `law` (docs/model.md §3.2).

    cycloidal, x = t - t0 < D:  omega = omega0 + dW (x/D - sin(2 pi x/D)/(2 pi)),
      theta = theta0 + omega0 x + dW (x^2/(2D) + D (cos(2 pi x/D) - 1)/(4 pi^2)),  theta_ddot = dW (1 - cos(2 pi x/D))/D
    linear, x < D:  omega = omega0 + a x,  theta = theta0 + omega0 x + a x^2/2,  a = dW/D
    after the ramp: omega = omega1,  theta = theta(t0 + D) + omega1 (x - D)
    """
    shape = law[0]
    elapsed = t - law[1]
    theta0 = law[2]
    omega0 = law[3]
    omega1 = law[4]
    duration = law[5]
    if shape == CONSTANT:
        return theta0 + omega0 * elapsed, omega0, 0.0
    change = omega1 - omega0
    if shape == LINEAR:
        rate = change / duration
        if elapsed < duration:
            return theta0 + omega0 * elapsed + 0.5 * rate * elapsed * elapsed, omega0 + rate * elapsed, rate
        return (theta0 + omega0 * duration + 0.5 * change * duration + omega1 * (elapsed - duration), omega1, 0.0)
    if elapsed < duration:
        phase = 2.0 * math.pi * elapsed / duration
        theta = theta0 + omega0 * elapsed + change * (elapsed * elapsed / (2.0 * duration)
                                                      + duration * (math.cos(phase) - 1.0) / (4.0 * math.pi ** 2))
        omega = omega0 + change * (elapsed / duration - math.sin(phase) / (2.0 * math.pi))
        return theta, omega, change * (1.0 - math.cos(phase)) / duration
    return theta0 + omega0 * duration + 0.5 * change * duration + omega1 * (elapsed - duration), omega1, 0.0


@kernel
def ramp_end_time(law):
    """Time at which the ramp ends (an integrator event), or +inf for a constant speed."""
    if law[0] == CONSTANT:
        return math.inf
    return law[1] + law[5]


@kernel
def time_of_angle(angle, t_low, t_high, law):
    """Time in [t_low, t_high] at which theta(t) = angle, by bisection (theta is non-decreasing)."""
    for _ in range(100):
        t_mid = 0.5 * (t_low + t_high)
        if t_mid <= t_low or t_mid >= t_high:
            break
        if rotor_motion(t_mid, law)[0] < angle:
            t_low = t_mid
        else:
            t_high = t_mid
    return t_high
