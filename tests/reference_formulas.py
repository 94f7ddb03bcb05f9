"""Independent reference formulas for the tests: closed forms of docs/model.md written with numpy/scipy (pitch
curve §2.3-§2.6, speed laws §3.2, E* §5.2, contact detection and generalized forces §4, §5, §6.2) and the flow-path
references of §7.4 (CoolProp's own isentropic expansion, PDSim's leakage correlation).

Nothing here is imported from the project's packages, so the tests compare the package against an independent
computation. Tests import what they use (`from reference_formulas import HarmonicPitch`; tests/ is on sys.path as
conftest.py's folder); conftest.py's `reference` and `contact_reference` fixtures hand out the same functions.
"""
import math
from types import SimpleNamespace

import numpy as np
from scipy.optimize import brentq, minimize_scalar


class HarmonicPitch:
    """Pitch curve of the harmonic law (docs/model.md §2.3 option 1, §2.4): C(u) = (R0 + s(u)) e_r(u),
    s = (h/2)(1 - cos z u). All methods accept numpy arrays (and complex arguments, for complex-step
    differentiation)."""

    def __init__(self, base_radius, stroke, lobes):
        self.base_radius = base_radius
        self.stroke = stroke
        self.lobes = lobes

    def radius(self, u):
        """r, r', r'', r''' of r = R0 + (h/2)(1 - cos z u)."""
        a, z = 0.5 * self.stroke, self.lobes
        c, s = np.cos(z * u), np.sin(z * u)
        return self.base_radius + a * (1.0 - c), a * z * s, a * z * z * c, -a * z ** 3 * s

    def point(self, u):
        r = self.radius(u)[0]
        return np.array([r * np.cos(u), r * np.sin(u)])

    def derivative(self, u):
        """C'(u) = r' e_r + r e_theta."""
        r, r1 = self.radius(u)[:2]
        c, s = np.cos(u), np.sin(u)
        return np.array([r1 * c - r * s, r1 * s + r * c])

    def second_derivative(self, u):
        """C''(u) = (r'' - r) e_r + 2 r' e_theta."""
        r, r1, r2 = self.radius(u)[:3]
        c, s = np.cos(u), np.sin(u)
        return np.array([(r2 - r) * c - 2 * r1 * s, (r2 - r) * s + 2 * r1 * c])

    def normal(self, u):
        """Unit outward normal n = (r e_r - r' e_theta)/sqrt(r^2 + r'^2)."""
        r, r1 = self.radius(u)[:2]
        c, s = np.cos(u), np.sin(u)
        norm = np.sqrt(r * r + r1 * r1)
        return np.array([(r * c + r1 * s) / norm, (r * s - r1 * c) / norm])

    def curvature(self, u):
        """Signed curvature kappa_C = (r^2 + 2 r'^2 - r r'')/(r^2 + r'^2)^1.5."""
        r, r1, r2 = self.radius(u)[:3]
        return (r * r + 2 * r1 * r1 - r * r2) / (r * r + r1 * r1) ** 1.5

    def stator(self, u, offset):
        """S(u) = C(u) + d n(u)."""
        return self.point(u) + offset * self.normal(u)

    def stator_derivative(self, u, offset, step=1e-30):
        """S'(u) by complex-step differentiation of S (exact to rounding, independent of the S' formula)."""
        return np.imag(self.stator(np.asarray(u, dtype=float) + 1j * step, offset)) / step

    def residual(self, u, tx, ty):
        """f(u) = (T - C(u)).C'(u) (docs/model.md §2.6)."""
        c = self.point(u)
        d = self.derivative(u)
        return (tx - c[0]) * d[0] + (ty - c[1]) * d[1]

    def closest(self, tx, ty, samples=20000):
        """u* of the point of C closest to T: global grid search over one revolution, then a bracketed root of
        f(u) = (T - C).C' on the neighbouring grid cells (brentq, to rounding). Returns u* in [-pi, 3 pi)."""
        u = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
        c = self.point(u)
        i = int(np.argmin((tx - c[0]) ** 2 + (ty - c[1]) ** 2))
        du = 2.0 * math.pi / samples
        a, b = u[i] - 2.0 * du, u[i] + 2.0 * du
        return brentq(lambda v: self.residual(v, tx, ty), a, b, xtol=1e-15, rtol=8.9e-16, maxiter=200)


# ------------------------------------------------------------------------------------------------------------
# References of the flow paths (docs/model.md §7.4): CoolProp's isentropic expansion and PDSim's leakage correlation

class IsentropicExpansion:
    """Isentropic expansion from (T0, rho0) with CoolProp's equilibrium flashes (independent of the module)."""

    def __init__(self, fluid_name, temperature, density):
        import CoolProp as CP
        self.state = CP.AbstractState("HEOS", fluid_name)
        self.state.update(CP.DmassT_INPUTS, density, temperature)
        self.pressure = self.state.p()
        self.enthalpy = self.state.hmass()
        self.entropy = self.state.smass()
        self._choked = None

    def expand(self, pressure):
        """(G, T) at p on the isentrope."""
        import CoolProp as CP
        self.state.update(CP.PSmass_INPUTS, pressure, self.entropy)
        return self.state.rhomass() * math.sqrt(max(0.0, 2.0 * (self.enthalpy - self.state.hmass()))), self.state.T()

    def two_phase(self, pressure):
        """True if the isentrope is inside the dome at p (CoolProp's phase determination)."""
        import CoolProp as CP
        self.state.update(CP.PSmass_INPUTS, pressure, self.entropy)
        return self.state.phase() == CP.iphase_twophase

    def choked(self):
        """(p*, G*): G maximised over p in [0.3 p0, 0.99 p0] (pr* is 0.45-0.62 for these fluids)."""
        if self._choked is None:
            result = minimize_scalar(lambda ratio: -self.expand(ratio * self.pressure)[0], bounds=(0.3, 0.99),
                                     method="bounded", options={"xatol": 1e-9})
            self._choked = (result.x * self.pressure, -result.fun)
        return self._choked

    def flux(self, pressure_down):
        """(G, throat T, throat p) for the expansion to p_down."""
        critical, choked_flux = self.choked()
        if pressure_down <= critical:
            return choked_flux, self.expand(critical)[1], critical
        flux, temperature = self.expand(pressure_down)
        return flux, temperature, pressure_down


# PDSim/flow/flow_models.pyx, as PDSim writes it (older versions keep exactly this list)
A_RADIAL = [25932.1070099, 0.914825434095, -177.588568125, -0.237052788124, -172347.610527, -12.0687599808,
            -0.0128861161041, -151.202604262, -0.999674457769, 0.0161435039267, 0.825533456725]
RE_STAR_RADIAL = 5243.58194594


def pdsim_mdot_ratio(delta, t, Re):
    """PDSim's mdot_ratio for Type == TYPE_RADIAL (mdot_friction = mdot_nozzle / mdot_ratio); 1 for Re <= 1e-12."""
    if not Re > 1e-12:
        return 1.0
    a = A_RADIAL
    xi = 1.0 / (1.0 + math.exp(-0.01 * (Re - RE_STAR_RADIAL)))
    Lstar = t / 0.005
    delta_star = delta / 10e-6
    return (a[0] * pow(Lstar, a[1]) / (a[2] * delta_star + a[3])
            * (xi * (a[4] * pow(Re, a[5]) + a[6]) + (1 - xi) * (a[7] * pow(Re, a[8]) + a[9])) + a[10])


def speed_law_reference(t, shape, omega_ss, duration=0.4, theta0=0.0):
    """(theta, omega, theta_ddot) of docs/model.md §3.2: constant speed, or the cycloidal ramp from rest over t_r."""
    if shape == "constant":
        return theta0 + omega_ss * t, omega_ss, 0.0
    tr = duration
    if t < tr:
        omega = omega_ss * (t / tr - math.sin(2 * math.pi * t / tr) / (2 * math.pi))
        theta = theta0 + omega_ss * (t * t / (2 * tr) + tr * (math.cos(2 * math.pi * t / tr) - 1) / (4 * math.pi ** 2))
        return theta, omega, omega_ss * (1 - math.cos(2 * math.pi * t / tr)) / tr
    return theta0 + omega_ss * (tr / 2 + t - tr), omega_ss, 0.0


def effective_modulus_reference(youngs_modulus, poisson_ratio):
    """E* of docs/model.md §5.2 for two bodies of the same material: 1/E* = 2 (1 - nu^2)/E."""
    return 1.0 / (2.0 * (1.0 - poisson_ratio ** 2) / youngs_modulus)


# ------------------------------------------------------------------------------------------------------------
# Reference contact detection and generalized forces (docs/model.md §4, §5, §6.2), plain numpy, for the T4/T7/T8 checks.


def rot(angle):
    return np.array([math.cos(angle), math.sin(angle)])


def perp(v):
    """v rotated by +90 degrees."""
    return np.array([-v[1], v[0]])


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


class VaneGeometry:
    """The geometric constants the formulas of docs/model.md need, taken from a parameter set (not from `Machine`)."""

    def __init__(self, params, tip_centre):
        self.t = params.vane_thickness
        self.rho = 0.5 * params.vane_thickness
        self.w = params.vane_thickness + params.slot_clearance
        self.rotor_radius = params.rotor_radius
        self.mouth = math.sqrt(params.rotor_radius ** 2 - (0.5 * self.w) ** 2)
        self.xi_t = tip_centre                         # xi_T = -xi_G (checked against docs/model.md in T2)
        self.xi_b = tip_centre - (params.vane_length - self.rho)
        self.edge = params.edge_radius
        self.r_sb = params.slot_bottom_radius
        self.cs = params.stator_clearance
        self.d = self.rho + params.stator_clearance
        self.pitch = HarmonicPitch(params.rotor_radius - self.rho, params.stroke, params.lobes)


def reference_slot_mouth(side, g, phi, theta, v):
    """docs/model.md §4.2 for region c1 (side +1) / c2 (side -1): the deepest valid candidate among A, B, C.
    Returns dict(delta, n, P, radius (R*), kind) or None if no candidate is valid."""
    er, et = rot(theta), perp(rot(theta))
    exi, eeta = rot(phi), perp(rot(phi))
    edge = v.mouth * er + side * 0.5 * v.w * et
    tip = g + v.xi_t * exi
    xi_e, eta_e = np.dot(edge - g, exi), np.dot(edge - g, eeta)
    candidates = []
    if xi_e <= v.xi_t:
        candidates.append(dict(delta=v.t / 2 - side * eta_e, n=-side * eeta, P=edge, radius=v.edge, kind="A"))
    elif side * eta_e > 0:
        dist = np.linalg.norm(tip - edge)
        candidates.append(dict(delta=v.rho - dist, n=(tip - edge) / dist, P=edge,
                               radius=v.rho * v.edge / (v.rho + v.edge), kind="B"))
    if np.dot(tip, er) < v.mouth:
        wall = side * et
        if np.dot(wall, exi) >= 0:
            support, radius = tip + v.rho * wall, v.rho
        else:
            support, radius = tip + side * 0.5 * v.t * eeta, v.edge
        if np.dot(support, er) <= v.mouth:
            candidates.append(dict(delta=side * np.dot(support, et) - v.w / 2, n=-wall, P=support, radius=radius,
                                   kind="C"))
    if not candidates:
        return None
    return max(candidates, key=lambda c: c["delta"])


def reference_slot_bottom(side, g, phi, theta, v):
    """docs/model.md §4.3 for region c3 (side +1) / c4 (side -1): corner B vs slot wall (half-plane)."""
    et = perp(rot(theta))
    corner = g + v.xi_b * rot(phi) + side * 0.5 * v.t * perp(rot(phi))
    return dict(delta=side * np.dot(corner, et) - v.w / 2, n=-side * et, P=corner, radius=v.edge, kind="corner")


def reference_slot_floor(side, g, phi, theta, v):
    """docs/model.md §4.4b for region c7 (side +1) / c8 (side -1): corner B vs the flat slot bottom at r_sb."""
    er = rot(theta)
    corner = g + v.xi_b * rot(phi) + side * 0.5 * v.t * perp(rot(phi))
    return dict(delta=v.r_sb - np.dot(corner, er), n=er, P=corner, radius=v.edge, kind="corner")


def reference_tip(g, phi, v):
    """docs/model.md §2.6/§4.4: tip circle vs stator at the closest point u* (reference brute force + root)."""
    tip = g + v.xi_t * rot(phi)
    u = v.pitch.closest(tip[0], tip[1])
    c, n = v.pitch.point(u), v.pitch.normal(u)
    kappa_c = v.pitch.curvature(u)
    kappa_s = kappa_c / (1 + v.d * kappa_c)
    psi = math.atan2(np.dot(n, perp(rot(phi))), np.dot(n, rot(phi)))
    return dict(delta=np.dot(tip - c, n) - v.cs, n=-n, P=tip + v.rho * n, radius=1 / (1 / v.rho - kappa_s),
                kind="tip", psi=psi, u=u, stator=c + v.d * n)


def reference_contacts(g, phi, theta, v):
    """The eight regions c1..c8 (None where there is no candidate; the tip is c5 if psi_c > 0 else c6)."""
    tip = reference_tip(g, phi, v)
    regions = [reference_slot_mouth(1, g, phi, theta, v), reference_slot_mouth(-1, g, phi, theta, v),
               reference_slot_bottom(1, g, phi, theta, v), reference_slot_bottom(-1, g, phi, theta, v),
               None, None, reference_slot_floor(1, g, phi, theta, v), reference_slot_floor(-1, g, phi, theta, v)]
    regions[4 if tip["psi"] > 0 else 5] = tip
    return regions, tip


def reference_friction_coefficient(slip, params):
    """docs/model.md §5.3: Threlfall mu (1 - exp(-3|v_t|/v_0)) or Ambrosio's piecewise-linear c_d."""
    mu, v0 = params.friction_coefficient, params.friction_velocity
    if params.friction_model == "threlfall":
        return mu * (1 - math.exp(-3 * slip / v0))
    v1 = params.friction_velocity_full
    if slip < v0:
        return 0.0
    if slip > v1:
        return mu
    return mu * (slip - v0) / (v1 - v0)


def reference_forces(params, tip_centre, state, theta, omega, onset, pressures):
    """Applied generalized forces of docs/model.md §5.4 and §6.2 on stator (Q1, moment about O), rotor (Q2, about O) and
    vane (Q3, about G), plus the powers of docs/model.md §6.4 and per-region details.

    state = (x3, y3, phi3, vx3, vy3, phi_dot3); onset[k] = stored approach velocity of slot k (0 = none;
    slots 0-3 for c1-c4, 4 for the tip, 5-6 for c7-c8); pressures = (p_L, p_T, p_b).
    """
    v = VaneGeometry(params, tip_centre)
    e_star = effective_modulus_reference(params.youngs_modulus, params.poisson_ratio)
    g = np.array(state[:2])
    phi = state[2]
    vel = np.array(state[3:5])
    phi_dot = state[5]
    regions, tip = reference_contacts(g, phi, theta, v)
    q1, q2, q3 = np.zeros(3), np.zeros(3), np.zeros(3)
    friction_power = damping_power = 0.0
    force_scale = 0.0          # sum of the magnitudes of all applied forces (to make tolerances relative)
    details = []
    for k, c in enumerate(regions):
        if c is None or c["delta"] <= 0:
            details.append(None)
            continue
        p, n = c["P"], c["n"]
        v_rel = vel + phi_dot * perp(p - g)
        on_rotor = k not in (4, 5)
        if on_rotor:
            v_rel = v_rel - omega * perp(p)
        rate = -np.dot(v_rel, n)
        stored = onset[k if k < 4 else (4 if k < 6 else k - 1)]
        approach = stored if stored > 0 else max(abs(rate), params.onset_velocity_floor)
        stiffness = 4.0 / 3.0 * e_star * math.sqrt(c["radius"])
        elastic = stiffness * c["delta"] ** 1.5
        normal = max(elastic * (1 + 0.75 * (1 - params.restitution ** 2) * rate / approach), 0.0)
        slip_vector = v_rel - np.dot(v_rel, n) * n
        slip = np.linalg.norm(slip_vector)
        force = normal * n
        if slip > 0:
            mu = reference_friction_coefficient(slip, params)
            force = force - mu * normal * slip_vector / slip
            friction_power += mu * normal * slip
        damping_power += (normal - elastic) * rate
        force_scale += np.linalg.norm(force)
        q3 += [force[0], force[1], cross(p - g, force)]
        target = q2 if on_rotor else q1
        target += [-force[0], -force[1], cross(p, -force)]
        details.append(dict(region=k, normal=normal, force=force, P=p, elastic=elastic))
    # gas on the vane (docs/model.md §6.2)
    p_l, p_t, p_b = pressures
    length = params.axial_length
    exi, eeta = rot(phi), perp(rot(phi))
    er = rot(theta)
    et = perp(er)
    gas_power = 0.0
    gas = np.zeros(3)

    def apply(force, point):
        nonlocal gas_power, force_scale
        force_scale += np.linalg.norm(force)
        gas[:2] += force
        gas[2] += cross(point - g, force)
        gas_power += np.dot(force, vel + phi_dot * perp(point - g))

    for side, pressure in ((1, p_l), (-1, p_t)):
        edge = v.mouth * er + side * 0.5 * v.w * et
        xi_e = np.dot(edge - g, exi)
        exposed = v.xi_t - xi_e
        if exposed > 0:
            apply(-side * pressure * length * exposed * eeta, g + 0.5 * (xi_e + v.xi_t) * exi + side * v.t / 2 * eeta)
    psi = tip["psi"]
    tip_point = g + v.xi_t * exi
    for (a, b), pressure in (((psi, math.pi / 2), p_l), ((-math.pi / 2, psi), p_t)):
        apply(-pressure * length * v.rho * ((math.sin(b) - math.sin(a)) * exi + (math.cos(a) - math.cos(b)) * eeta),
              tip_point)
    apply(p_b * v.t * length * exi, g + v.xi_b * exi)
    q3 += gas
    # gas on the rotor slot walls above a recessed tip junction
    rotor_gas = 0.0
    for side, pressure in ((1, p_l), (-1, p_t)):
        junction = tip_point + side * v.t / 2 * eeta
        r_j = np.dot(junction, er)
        if r_j < v.mouth:
            rotor_gas += side * pressure * length * (v.mouth ** 2 - r_j ** 2) / 2
    # back chamber (an extension of docs/model.md §6.2, adopted in mechanics/gas/gas_loads.py): p_b also wets the two
    # slot walls from the slot bottom up to the vane's bottom corners B+-. A wall element at radius r on the sigma
    # side is pushed in +sigma e_theta with p_b L dr, moment r p_b L dr about O; the bottom face of the slot is
    # radial-symmetric (no moment). Sum: p_b L (r_B+^2 - r_B-^2)/2.
    corners = [np.dot(g + v.xi_b * exi + side * 0.5 * v.t * eeta, er) for side in (1, -1)]
    rotor_gas += 0.5 * p_b * length * (corners[0] ** 2 - corners[1] ** 2)
    q2[2] += rotor_gas
    gas_power += rotor_gas * omega
    stator_gas = 0.5 * length * (p_l - p_t) * (np.dot(tip["stator"], tip["stator"])
                                               - (params.rotor_radius + params.stator_clearance) ** 2)
    return SimpleNamespace(q1=q1, q2=q2, q3=q3, friction_power=friction_power, damping_power=damping_power,
                           gas_power=gas_power, stator_gas_moment=stator_gas, details=details, tip=tip,
                           regions=regions, force_scale=force_scale)
