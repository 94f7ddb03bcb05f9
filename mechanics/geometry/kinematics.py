"""The vane's pose and velocity and the rotor's motion at one instant, and the kinematics reported to users
(docs/model.md §3.1, §3.4).

`vane_pose` is the first stage of every right-hand-side evaluation (mechanics.loop.dynamics): it turns the state vector
and the speed law into the named quantities every later stage reads.
"""
import math
from typing import NamedTuple


from ...kernels.kernel import kernel

from ..loop.layout import ANGLE, ANGULAR_VELOCITY, VX, VY, X, Y
from ..loop.speed import rotor_motion


class VanePose(NamedTuple):
    """Rotor motion and vane pose at time t (docs/model.md §1.2, §3.1).

    theta, omega, theta_ddot: rotor angle, speed, acceleration; er_x, er_y: e_r = (cos theta, sin theta);
    gx, gy, phi: vane centre of mass G and axis angle phi3; vx, vy, phi_dot: their rates;
    exi_x, exi_y: vane axis e_xi = (cos phi, sin phi); tip_x, tip_y: tip centre T = G + xi_T e_xi.
    """
    theta: float
    omega: float
    theta_ddot: float
    er_x: float
    er_y: float
    gx: float
    gy: float
    phi: float
    vx: float
    vy: float
    phi_dot: float
    exi_x: float
    exi_y: float
    tip_x: float
    tip_y: float


@kernel
def vane_pose(t, y, law, m):
    """The VanePose of state y at time t under the speed law (docs/model.md §3.2 for theta(t))."""
    theta, omega, theta_ddot = rotor_motion(t, law)
    phi = y[ANGLE]
    exi_x = math.cos(phi)
    exi_y = math.sin(phi)
    return VanePose(theta, omega, theta_ddot, math.cos(theta), math.sin(theta), y[X], y[Y], phi, y[VX], y[VY],
                    y[ANGULAR_VELOCITY], exi_x, exi_y, y[X] + m.tip_centre * exi_x, y[Y] + m.tip_centre * exi_y)


@kernel
def reported_kinematics(pose, ax, ay, alpha, m):
    """The thesis's relative kinematics (docs/model.md §3.4), from the pose and the vane's accelerations:

    s_r = T.e_r - R0,  v_r = v_T.e_r + omega eta_T,  a_r = a_T.e_r + 2 omega v_T.e_theta + theta_ddot eta_T - omega^2 xi_T,
    v_theta = v_G.e_theta,  a_theta = a_G.e_theta,  with xi_T = T.e_r, eta_T = T.e_theta.
    Returns (s_r, v_r, a_r, v_theta, a_theta).
    """
    p = pose
    rx = m.tip_centre * p.exi_x
    ry = m.tip_centre * p.exi_y
    tip_vx = p.vx - p.phi_dot * ry
    tip_vy = p.vy + p.phi_dot * rx
    tip_ax = ax - alpha * ry - p.phi_dot * p.phi_dot * rx
    tip_ay = ay + alpha * rx - p.phi_dot * p.phi_dot * ry
    xi_t = p.tip_x * p.er_x + p.tip_y * p.er_y
    eta_t = -p.tip_x * p.er_y + p.tip_y * p.er_x
    v_tangential_tip = -tip_vx * p.er_y + tip_vy * p.er_x
    return (xi_t - m.base_radius,
            tip_vx * p.er_x + tip_vy * p.er_y + p.omega * eta_t,
            tip_ax * p.er_x + tip_ay * p.er_y + 2.0 * p.omega * v_tangential_tip + p.theta_ddot * eta_t
            - p.omega * p.omega * xi_t,
            -p.vx * p.er_y + p.vy * p.er_x,
            -ax * p.er_y + ay * p.er_x)


@kernel
def pose_of(gx, gy, phi, theta, m, vx=0.0, vy=0.0, phi_dot=0.0, omega=0.0, theta_ddot=0.0):
    """The VanePose of a given vane pose and rotor angle (for calling the detectors and loads directly)."""
    exi_x, exi_y = math.cos(phi), math.sin(phi)
    return VanePose(theta, omega, theta_ddot, math.cos(theta), math.sin(theta), gx, gy, phi, vx, vy, phi_dot, exi_x,
                    exi_y, gx + m.tip_centre * exi_x, gy + m.tip_centre * exi_y)
