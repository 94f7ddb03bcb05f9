"""Contact force laws: elastic stiffness (Hertz point or Johnson line contact), Lankarani-Nikravesh damping and
regularised friction (docs/model.md §5.1-§5.3).

Pure functions of the penetration delta, its rate, the curvatures at the contact point and the stored impact
velocity. Every law is defined for every delta > 0 and never raises: the line-contact law is solved by a bracketed
Newton iteration with bisection fallback, and beyond its validity limit it continues along its tangent (the
excess is reported by the caller, docs/model.md §5.2).
"""
import math
from ...thermo.choices import Choices
from ...kernels.kernel import kernel

STIFFNESS_MODELS = Choices("hertz_point", "johnson_line")
FRICTION_MODELS = Choices("threlfall", "ambrosio")
HERTZ_POINT, JOHNSON_LINE = STIFFNESS_MODELS.codes("hertz_point", "johnson_line")
THRELFALL, AMBROSIO = FRICTION_MODELS.codes("threlfall", "ambrosio")
HERTZ_EXPONENT = 1.5
SMALLEST_CURVATURE_SUM = 1e-9          # 1/m: a conformal contact (1/R* -> 0) is taken as R* = 1e9 m


@kernel
def hertz_stiffness(vane_curvature, other_curvature, effective_modulus):
    """K = (4/3) E* sqrt(R*),  1/R* = 1/R_i + 1/R_j (concave negative, plane 0) (docs/model.md §5.2 option P)."""
    return 4.0 / 3.0 * effective_modulus / math.sqrt(max(vane_curvature + other_curvature, SMALLEST_CURVATURE_SUM))


@kernel
def line_contact_constants(vane_curvature, other_curvature, m):
    """(A, B) of the Johnson line contact delta(F) = F (A - B ln F) (docs/model.md §5.2 option L):

    b = sqrt(4 F R*/(pi L E*)),  delta = F/(pi L) sum_curved c_k (2 ln(4 R_k/b) - 1),  c_k = (1 - nu^2)/E.
    """
    equivalent_radius = 1.0 / max(vane_curvature + other_curvature, SMALLEST_CURVATURE_SUM)
    log_width_factor = math.log(4.0 * equivalent_radius / (math.pi * m.axial_length * m.effective_modulus))
    a = 0.0
    b = 0.0
    for curvature in (vane_curvature, other_curvature):
        if curvature != 0.0:
            radius = 1.0 / abs(curvature)
            a += m.compliance * (2.0 * math.log(4.0 * radius) - log_width_factor - 1.0)
            b += m.compliance
    scale = 1.0 / (math.pi * m.axial_length)
    return a * scale, b * scale


@kernel
def line_contact_limit(a, b):
    """(F_s, delta_s): the end of the line law's validity range, F_s = exp(A/B - 2) = F*/e (docs/model.md §5.2).

    d delta/dF = A - B ln F - B falls to 0 at F* = exp(A/B - 1), beyond which delta(F) decreases; at F_s it is B.
    """
    force = math.exp(a / b - 2.0)
    return force, 2.0 * b * force


@kernel
def _line_contact_force(penetration, a, b, force_limit):
    """F in (0, F_s] with F (A - B ln F) = delta < delta_s: Newton in x = ln F, kept inside a shrinking bracket
    [x_lo, x_hi] on which g(x) = e^x (A - B x) - delta changes sign (g increases on x < A/B - 1, for any sign of A);
    bisection whenever a Newton step leaves the bracket. A Newton step below the resolution of x ends the
    iteration before the bracket test: g is convex there, so Newton converges from above and its converged iterate
    is the upper bound itself, which the strict test refuses (measured: up to 48 iterations of bisection from the
    lower bound instead of 6, and the root to only 1e-13)."""
    x_high = math.log(force_limit)
    guess = math.log(penetration / (abs(a) + b))    # F ~ delta/|A - B x|; A < 0 for a nearly conformal pair
    x_low = min(guess - 40.0, x_high - 1.0)         # g(x_low) < 0: e^x (|A| + B |x|) < delta there
    x = min(max(guess, x_low), x_high)
    for _ in range(200):
        force = math.exp(x)
        residual = force * (a - b * x) - penetration
        if residual > 0.0:
            x_high = x
        else:
            x_low = x
        slope = force * (a - b * x - b)
        step = residual / slope if slope > 0.0 else math.inf
        candidate = x - step
        if abs(step) <= 1e-14 * max(1.0, abs(x)):
            x = candidate
            break
        if not (x_low < candidate < x_high):
            candidate = 0.5 * (x_low + x_high)
        if abs(candidate - x) <= 1e-14 * max(1.0, abs(x)):
            x = candidate
            break
        x = candidate
    return math.exp(x)


@kernel
def elastic_force(penetration, vane_curvature, other_curvature, m):
    """(elastic normal force F_el, stored elastic energy, penetration beyond the law's validity limit) at
    delta > 0 (docs/model.md §5.1-§5.2).

    Option P: F = K delta^1.5, energy K delta^2.5 / 2.5 (valid for every delta; excess 0).
    Option L: F solves delta = F (A - B ln F) for delta <= delta_s, energy A F^2/2 - B F^2 ln F/2 - B F^2/4;
      beyond, the tangent F = F_s + (delta - delta_s)/B with energy E_s + F_s e + e^2/(2B), e = delta - delta_s
      (continuous and monotone; e is returned as the excess).
    """
    if m.stiffness_model == HERTZ_POINT:
        stiffness = hertz_stiffness(vane_curvature, other_curvature, m.effective_modulus)
        force = stiffness * penetration * math.sqrt(penetration)      # K delta^1.5
        return force, force * penetration / (HERTZ_EXPONENT + 1.0), 0.0
    a, b = line_contact_constants(vane_curvature, other_curvature, m)
    force_limit, penetration_limit = line_contact_limit(a, b)
    if penetration < penetration_limit:
        force = _line_contact_force(penetration, a, b, force_limit)
        energy = force * force * (0.5 * a - 0.5 * b * math.log(force) - 0.25 * b)
        return force, energy, 0.0
    excess = penetration - penetration_limit
    energy_limit = force_limit * force_limit * (0.5 * a - 0.5 * b * math.log(force_limit) - 0.25 * b)
    return (force_limit + excess / b, energy_limit + force_limit * excess + 0.5 * excess * excess / b, excess)


@kernel
def normal_force(elastic, penetration_rate, onset_velocity, restitution):
    """Lankarani-Nikravesh: F_n = F_el [1 + 3(1 - c_e^2)/4 * delta_dot/delta_dot^-], clamped at 0 (docs/model.md §5.1)."""
    force = elastic * (1.0 + 0.75 * (1.0 - restitution * restitution) * penetration_rate / onset_velocity)
    return force if force > 0.0 else 0.0


@kernel
def friction_coefficient_effective(slip_speed, m):
    """mu_eff(|v_t|): Threlfall mu (1 - exp(-3|v_t|/v_0)) or Ambrosio's piecewise-linear ramp (docs/model.md §5.3)."""
    if m.friction_model == THRELFALL:
        exponent = 3.0 * slip_speed / m.friction_velocity
        if exponent > 40.0:         # 1 - exp(-40) is 1.0 in double precision
            return m.friction_coefficient
        return m.friction_coefficient * (1.0 - math.exp(-exponent))
    if slip_speed < m.friction_velocity:
        return 0.0
    if slip_speed > m.friction_velocity_full:
        return m.friction_coefficient
    return m.friction_coefficient * (slip_speed - m.friction_velocity) / (m.friction_velocity_full
                                                                          - m.friction_velocity)
