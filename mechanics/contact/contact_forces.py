"""Contact forces of the contact regions (mechanics.contact.regions) on the vane, and their reactions on the rotor and
the stator (docs/model.md §5.1-§5.4).

For each region in contact: the elastic force and its hysteresis damping along n, regularised friction against the
slip of the vane point P relative to the other body, applied at the same point P on both bodies. The per-region
values (normal and friction force, penetration and its rate) go into the output row.
"""
import math
from typing import NamedTuple


from ...kernels.kernel import kernel

from .detection import region_candidate
from .contact_laws import elastic_force, friction_coefficient_effective, normal_force
from ..loop.layout import MEM_ONSET_VELOCITY
from ..loop.outputs import O
from .regions import REGION_BODY, REGION_COUNT, REGION_DETECTOR, REGION_MEMORY_SLOT, REGION_SIDE, ROTOR


class ContactLoads(NamedTuple):
    """Resultants of the contact forces (docs/model.md §5.4): on the vane (force, moment about G), the reactions on
    the rotor (force, moment about O: Q2phi) and on the stator (force, moment about O: lambda3), the friction and
    damping powers, the power of the elastic forces sum F_el delta_dot and the stored elastic energy (the two
    differ where a stiffness changes in a closed contact, docs/model.md §6.4), the contact-mode mask and the
    largest penetration beyond a force law's validity limit."""
    vane_fx: float
    vane_fy: float
    vane_moment: float
    rotor_fx: float
    rotor_fy: float
    rotor_moment: float
    stator_fx: float
    stator_fy: float
    stator_moment: float
    friction_power: float
    damping_power: float
    elastic_power: float
    elastic_energy: float
    mode: int
    law_excess: float


@kernel
def contact_loads(pose, slots, tip, memory, m, out):
    """Forces of all regions (docs/model.md §5); writes normal_force, friction_force, penetration and
    penetration_rate of each region into the output row `out`.

    F_n = F_el(delta) [1 + 3(1 - c_e^2)/4 delta_dot/delta_dot^-],  F_t = -mu_eff(|v_t|) F_n v_t/|v_t|,
    P_fric = sum mu_eff F_n |v_t|,  P_damp = sum (F_n - F_el) delta_dot,  P_el = sum F_el delta_dot.
    """
    p = pose
    vane_fx = vane_fy = vane_moment = 0.0
    rotor_fx = rotor_fy = rotor_moment = 0.0
    stator_fx = stator_fy = stator_moment = 0.0
    friction_power = damping_power = elastic_power = elastic_energy = law_excess = 0.0
    mode = 0
    for region in range(REGION_COUNT):
        contact = region_candidate(REGION_DETECTOR[region], REGION_SIDE[region], slots, tip, pose, m)
        out[O.normal_force + region] = 0.0
        out[O.friction_force + region] = 0.0
        if contact.penetration == -math.inf:      # no valid candidate in this region: not applicable
            out[O.penetration + region] = math.nan
            out[O.penetration_rate + region] = math.nan
            continue
        delta = contact.penetration
        out[O.penetration + region] = delta
        # relative velocity of the vane point P against the other body (the rotor turns, the stator stands)
        rel_vx = p.vx - p.phi_dot * (contact.point_y - p.gy)
        rel_vy = p.vy + p.phi_dot * (contact.point_x - p.gx)
        rotor = REGION_BODY[region] == ROTOR
        if rotor:
            rel_vx += p.omega * contact.point_y
            rel_vy -= p.omega * contact.point_x
        normal_speed = rel_vx * contact.normal_x + rel_vy * contact.normal_y
        rate = -normal_speed
        out[O.penetration_rate + region] = rate
        if delta <= 0.0:
            continue
        mode |= 1 << region
        onset = memory[MEM_ONSET_VELOCITY + REGION_MEMORY_SLOT[region]]
        if onset <= 0.0:
            onset = max(abs(rate), m.onset_velocity_floor)
        elastic, energy, excess = elastic_force(delta, contact.vane_curvature, contact.other_curvature, m)
        law_excess = max(law_excess, excess)
        force_n = normal_force(elastic, rate, onset, m.restitution)
        slip_x = rel_vx - normal_speed * contact.normal_x
        slip_y = rel_vy - normal_speed * contact.normal_y
        slip = math.sqrt(slip_x * slip_x + slip_y * slip_y)
        fx = force_n * contact.normal_x
        fy = force_n * contact.normal_y
        if slip > 0.0:
            friction = friction_coefficient_effective(slip, m) * force_n
            fx -= friction * slip_x / slip
            fy -= friction * slip_y / slip
            friction_power += friction * slip
            out[O.friction_force + region] = friction
        damping_power += (force_n - elastic) * rate
        elastic_power += elastic * rate
        elastic_energy += energy
        out[O.normal_force + region] = force_n
        # same application point on both bodies (docs/model.md §5.4)
        vane_fx += fx
        vane_fy += fy
        vane_moment += (contact.point_x - p.gx) * fy - (contact.point_y - p.gy) * fx
        reaction_moment = -(contact.point_x * fy - contact.point_y * fx)
        if rotor:
            rotor_fx -= fx
            rotor_fy -= fy
            rotor_moment += reaction_moment
        else:
            stator_fx -= fx
            stator_fy -= fy
            stator_moment += reaction_moment
    return ContactLoads(vane_fx, vane_fy, vane_moment, rotor_fx, rotor_fy, rotor_moment, stator_fx, stator_fy,
                        stator_moment, friction_power, damping_power, elastic_power, elastic_energy, mode, law_excess)
