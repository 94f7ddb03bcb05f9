"""Friction self-locking of the vane in its slot, checked before any work (docs/model.md §5.5).

On the return stroke the stator pushes the vane back into its slot through the tip. The push makes the pressure
angle beta with the vane axis (tan beta = |ds/dtheta| / (R0 + s), the pitch curve of §2.4) and the tip friction
mu F adds to its transverse part: Q = F (sin beta + mu cos beta) across the vane, P = F (cos beta - mu sin beta)
along it. The vane tilts in its clearance until it bears on one slot-mouth edge and, on the other wall, on its
bottom corner, a distance e (the engaged length) apart; with the tip a distance l beyond the mouth, the moments give
N_mouth = Q (l + e)/e and N_corner = Q l/e, whose friction mu (N_mouth + N_corner) = mu Q (1 + 2 l/e) resists the
push. The vane jams (the stator's push only raises the slot forces that hold it) when

    J = mu (tan beta + mu) / (1 - mu tan beta) (1 + 2 l/e) >= 1,    or 1 - mu tan beta <= 0,

the jamming condition of a translating cam follower in its guide. The vane's inertia, the gas forces and the
friction moments of the faces' half thickness are left out: the gas load across the vane adds to Q and not to P, so
a vane that meets the condition locks whatever the gas does.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..geometry.stator import lobe_profile


class LockingMargin(NamedTuple):
    index: float                 # max over the return stroke of J (module docstring); >= 1: the vane locks
    pressure_angle: float        # beta where J is largest [rad]
    tip_beyond_mouth: float      # l there: tip apex beyond the slot-mouth edges [m]
    engaged_length: float        # e there: slot mouth to the vane's bottom face [m]
    largest_friction: float      # the friction_coefficient at which the largest J is 1 (the allowed bound)


def _locking_index(mu: float, tan_beta: np.ndarray, lever: np.ndarray) -> np.ndarray:
    """J of the module docstring at each sample (inf where 1 - mu tan beta <= 0)."""
    denominator = 1.0 - mu * tan_beta
    with np.errstate(divide="ignore"):
        return np.where(denominator > 0.0, mu * (tan_beta + mu) / np.maximum(denominator, 0.0) * lever, np.inf)


def locking_margin(params) -> LockingMargin:
    """How close the vane comes to locking in its slot over a lobe (module docstring)."""
    s, slope, _ = lobe_profile(params)
    base_radius = params.base_radius
    returning = slope < 0.0                          # the stator pushes the vane in (every lobe returns: h > 0)
    s, slope = s[returning], slope[returning]
    tan_beta = -slope / (base_radius + s)
    tip_beyond = base_radius + s + params.tip_radius - params.mouth_radius
    engaged = params.mouth_radius - (base_radius + s - (params.vane_length - params.tip_radius))
    lever = 1.0 + 2.0 * np.maximum(tip_beyond, 0.0) / engaged
    index = _locking_index(params.friction_coefficient, tan_beta, lever)
    k = int(np.argmax(index))
    return LockingMargin(float(index[k]), math.atan(tan_beta[k]), float(tip_beyond[k]), float(engaged[k]),
                         float(np.min(_locking_friction(tan_beta, lever))))


def _locking_friction(tan_beta: np.ndarray, lever: np.ndarray) -> np.ndarray:
    """The mu at which J = 1 at each sample: the positive root of lever mu^2 + (lever + 1) tan beta mu - 1 = 0
    (J = 1 with the denominator multiplied out; there 1 - mu tan beta = lever mu (tan beta + mu) > 0). J grows
    with mu, so the vane locks nowhere on the stroke for mu below the smallest root."""
    b = (lever + 1.0) * tan_beta
    return 2.0 / (b + np.sqrt(b * b + 4.0 * lever))


def check_vane_not_self_locking(params) -> None:
    """Raise ValueError naming friction_coefficient if the vane locks in its slot (docs/model.md §5.5)."""
    margin = locking_margin(params)
    if margin.index < 1.0:
        return
    raise ValueError(
        f"parameter 'friction_coefficient' = {params.friction_coefficient!r} is out of range for this vane and "
        f"profile: allowed < {margin.largest_friction:.4g}. On the return stroke the stator pushes the tip at a "
        f"pressure angle of {math.degrees(margin.pressure_angle):.3g} deg with the tip {margin.tip_beyond_mouth * 1e3:.3g} mm "
        f"beyond the slot mouth and {margin.engaged_length * 1e3:.3g} mm of the vane engaged: the friction at the "
        f"slot mouth and the vane's bottom corner then holds any push (locking index {margin.index:.3g} >= 1), the "
        f"vane self-locks in its slot (docs/model.md §5.5); lower friction_coefficient, the stroke or the lobes' "
        f"steepness, or lengthen vane_length")
