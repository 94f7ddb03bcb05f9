"""Vane-tip-centre displacement laws s(theta) and their first three derivatives (docs/model.md §2.3).

All laws are periodic in the lobe angle 2 pi / z, zero at the valleys theta = 2 pi j / z and equal to the
stroke h at mid-lobe. Derivatives are with respect to the rotor angle theta.
"""
import math

import numpy as np
from ...thermo.choices import Choices
from ...kernels.kernel import kernel

DISPLACEMENT_LAWS = Choices("harmonic", "cycloidal", "harmonic_dwell", "polynomial_345")
HARMONIC, CYCLOIDAL, HARMONIC_DWELL, POLYNOMIAL_345 = DISPLACEMENT_LAWS.codes(
    "harmonic", "cycloidal", "harmonic_dwell", "polynomial_345")

TWO_PI = 2.0 * math.pi


@kernel
def _harmonic(theta, stroke, lobes):
    """s = (h/2)(1 - cos z theta) and derivatives (docs/model.md §2.3 option 1)."""
    c = math.cos(lobes * theta)
    s = math.sin(lobes * theta)
    half = 0.5 * stroke
    return (half * (1.0 - c), half * lobes * s, half * lobes * lobes * c, -half * lobes ** 3 * s)


@kernel
def _rise_return(theta, stroke, lobes, law):
    """Symmetric rise over zeta in [0, pi] and mirrored return, x = zeta/pi (docs/model.md §2.3 options 2 and 4)."""
    zeta = (lobes * theta) % TWO_PI
    rising = zeta <= math.pi
    x = zeta / math.pi if rising else (TWO_PI - zeta) / math.pi
    dx = lobes / math.pi if rising else -lobes / math.pi          # dx/dtheta
    if law == CYCLOIDAL:
        a = TWO_PI * x
        f0 = x - math.sin(a) / TWO_PI
        f1 = 1.0 - math.cos(a)
        f2 = TWO_PI * math.sin(a)
        f3 = TWO_PI * TWO_PI * math.cos(a)
    else:  # 3-4-5 polynomial
        f0 = x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x)
        f1 = 30.0 * x * x * (1.0 - x) ** 2
        f2 = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x)
        f3 = 60.0 * (1.0 - 6.0 * x + 6.0 * x * x)
    return stroke * f0, stroke * f1 * dx, stroke * f2 * dx * dx, stroke * f3 * dx ** 3


@kernel
def _harmonic_with_dwells(theta, stroke, lobes, bottom_dwell, top_dwell):
    """Bottom dwell beta0 centred on the valley, cosine rise, top dwell beta1, cosine return (docs/model.md §2.3 option 3).

    The law is C1: s and s' are continuous, s'' jumps by (h/2)(pi/beta_r)^2 at the ends of each rise/return.
    """
    lobe = TWO_PI / lobes
    phase = theta % lobe
    rise = 0.5 * (lobe - bottom_dwell - top_dwell)
    k = math.pi / rise
    start_rise = 0.5 * bottom_dwell
    start_return = start_rise + rise + top_dwell
    if phase < start_rise or phase >= start_return + rise:
        return 0.0, 0.0, 0.0, 0.0
    if phase < start_rise + rise:
        a = k * (phase - start_rise)
        sign = 1.0
    elif phase < start_return:
        return stroke, 0.0, 0.0, 0.0
    else:
        a = k * (start_return + rise - phase)
        sign = -1.0
    half = 0.5 * stroke
    return (half * (1.0 - math.cos(a)), sign * half * k * math.sin(a), half * k * k * math.cos(a),
            -sign * half * k ** 3 * math.sin(a))


@kernel
def displacement_given_trig(theta, cos_theta, sin_theta, law, stroke, lobes, bottom_dwell, top_dwell):
    """`displacement` when cos(theta) and sin(theta) are known: for the harmonic law cos(z theta) and sin(z theta)
    follow by complex powers (de Moivre), saving a trigonometric evaluation in the closest-point loop."""
    if law != HARMONIC:
        return displacement(theta, law, stroke, lobes, bottom_dwell, top_dwell)
    c = 1.0
    s = 0.0
    for _ in range(int(lobes)):
        c, s = c * cos_theta - s * sin_theta, s * cos_theta + c * sin_theta
    half = 0.5 * stroke
    return (half * (1.0 - c), half * lobes * s, half * lobes * lobes * c, -half * lobes ** 3 * s)


@kernel
def displacement(theta, law, stroke, lobes, bottom_dwell, top_dwell):
    """(s, ds/dtheta, d2s/dtheta2, d3s/dtheta3) of the chosen law at rotor angle theta."""
    if law == HARMONIC:
        return _harmonic(theta, stroke, lobes)
    if law == HARMONIC_DWELL:
        return _harmonic_with_dwells(theta, stroke, lobes, bottom_dwell, top_dwell)
    return _rise_return(theta, stroke, lobes, law)


@kernel(allocates=True)
def displacement_on_grid(angles, law, stroke, lobes, bottom_dwell, top_dwell):
    """s(theta) at every angle of an array."""
    values = np.empty(angles.size)
    for i in range(angles.size):
        values[i] = displacement(angles[i], law, stroke, lobes, bottom_dwell, top_dwell)[0]
    return values
