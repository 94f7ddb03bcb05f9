"""Leakage laws of the clearance gaps and the geometry of a gap between curved surfaces (docs/model.md §7.4).

A leakage path is a gap of minimum height delta, flow length L (along the leakage direction) and width W (across
it, the axial length for the valley and tip gaps). Its mass flow uses the isentropic nozzle flux G of the
upstream state (ideal gas: thermo.nozzle; real gas: thermo.real_gas_nozzle) through the area delta W, and one of
the laws LEAKAGE_LAWS:

- "nozzle" (code LAW_NOZZLE): an isentropic nozzle with a discharge coefficient,  m_dot = C_d delta W G.
  With the ideal-gas flux this is exactly today's path (control_volume.signed_nozzle_flow with A = delta W).
- "sealed" (code LAW_SEALED): no flow (a path closed by an oil film, or switched off).
- "friction_corrected" (code LAW_FRICTION_CORRECTED): the hybrid leakage model of Bell, Groll, Braun and Horton
  (Int. J. Refrig. 36 (2013) 1965-1973) as PDSim implements it (`FrictionCorrectedIsentropicNozzle`,
  PDSim/flow/flow_models.pyx, type TYPE_RADIAL, the flow across a gap of constant height delta and length t):

      m_dot = delta W G / phi,     Re = G D_h / mu_up,  D_h = 2 delta,   L* = L / 5 mm,  delta* = delta / 10 um
      xi  = 1 / (1 + exp(-0.01 (Re - Re*))),  Re* = 5243.58194594
      phi = a0 L*^a1 / (a2 delta* + a3) [xi (a4 Re^a5 + a6) + (1 - xi)(a7 Re^a8 + a9)] + a10

  with PDSim's coefficients (RADIAL_COEFFICIENTS) and G the nozzle flux of the upstream state (PDSim uses the
  ideal-gas flux with C_d = 1; Re is formed with that flux and the upstream viscosity). One decision differs from
  PDSim: phi is clamped at 1 (FRICTION_RATIO_FLOOR). Outside the range the correlation was fitted on (short or wide
  gaps: phi -> a10 = 0.83 as L -> 0) it would give more flow than the isentropic nozzle, which friction cannot do;
  with the clamp the short-gap limit is the nozzle (C_d,eq = 1).

  PDSim's other correlation (TYPE_FLANK) is not offered: its length scale is the scroll's orbiting radius r_o, and
  the flank gap opens as r_o (1 - cos) along an involute whose radius of curvature does not enter the fit, so no
  radius of a rotor/stator seal maps onto it (a larger r_o seals less, a larger seal radius seals more).

Gaps between curved surfaces. Near its narrowest point the gap between a convex surface of radius R1 and a
concave one of radius R2 (R2 > R1) is h(x) = delta + x^2/(2 R) with 1/R = 1/R1 - 1/R2 (`equivalent_gap_radius`).
The flow length used with the friction law is the friction-equivalent length: the length of a gap of constant
height delta with the same viscous (Poiseuille, dp/dx ~ 1/h^3) and the same turbulent constant-friction-factor
(dp/dx ~ G_x^2/h ~ 1/h^3 at a given mass flow) pressure drop,

    L_eq = delta^3 int dx / h(x)^3 = (3 pi / 16) sqrt(2 delta) (sqrt(R_a) + sqrt(R_b)) + L_flat    (`friction_length`)

for a flat part L_flat (a bottom dwell) between two parabolic flanks of radii R_a, R_b; (3 pi / 8) sqrt(2 R delta)
for a symmetric line seal. The Reynolds number G 2 delta / mu does not depend on h at a given mass flow, so the
friction factor is the same along the gap and the equivalence holds in both regimes (it ignores compressibility,
which concentrates the loss at the throat). The stator's curvature at a valley follows from docs/model.md §2.4-§2.5
(`valley_seal_radius`): 37.86 mm for the default machine.

`fanno_channel_mass_flux` is an independent, slower reference (Python): isentropic acceleration into a channel of
constant height delta and length L, adiabatic flow with wall friction (Fanno) in it, ideal gas, the jet leaving at
the downstream pressure or choked at the exit. It is used for the documentation table and the tests.
"""
from __future__ import annotations

import math

import numpy as np

from .checks import checked_number, fail
from .choices import Choices
from .control_volume import LINEAR_FLOW_BAND, signed_nozzle_flow
from ..kernels.kernel import kernel
from .nozzle import isentropic_nozzle_mass_flow
from .property_table import STATUS_OK
from .real_gas_nozzle import nozzle_flux_between, table_viscosity

LEAKAGE_LAWS = Choices("nozzle", "friction_corrected", "sealed")
# LAW_SEALED: the path passes nothing (e.g. an oil-sealed slot, docs/model.md §7.4)
LAW_NOZZLE, LAW_FRICTION_CORRECTED, LAW_SEALED = LEAKAGE_LAWS.codes("nozzle", "friction_corrected", "sealed")

# PDSim/flow/flow_models.pyx (ibell/pdsim): ar_0 ... ar_10 and Re_star_radial of FrictionCorrectedIsentropicNozzle
RADIAL_COEFFICIENTS = (25932.1070099, 0.914825434095, -177.588568125, -0.237052788124, -172347.610527,
                       -12.0687599808, -0.0128861161041, -151.202604262, -0.999674457769, 0.0161435039267,
                       0.825533456725)
TRANSITION_REYNOLDS = 5243.58194594
LENGTH_SCALE = 0.005            # m: L* = L / 5 mm
GAP_SCALE = 10e-6               # m: delta* = delta / 10 um
FRICTION_RATIO_FLOOR = 1.0      # phi >= 1: friction never passes more than the isentropic nozzle
_A0, _A1, _A2, _A3, _A4, _A5, _A6, _A7, _A8, _A9, _A10 = RADIAL_COEFFICIENTS


# ----------------------------------------------------------------------------------------------------------
# numba kernels

@kernel
def pdsim_friction_ratio(gap_height, flow_length, reynolds_number):
    """PDSim's mdot_ratio of FrictionCorrectedIsentropicNozzle, TYPE_RADIAL, as PDSim computes it (not clamped):
    the correlation of the module docstring; 1 for Re <= 1e-12."""
    if not reynolds_number > 1e-12:
        return 1.0
    weight = 1.0 / (1.0 + math.exp(-0.01 * (reynolds_number - TRANSITION_REYNOLDS)))
    length = flow_length / LENGTH_SCALE
    gap = gap_height / GAP_SCALE
    return (_A0 * length ** _A1 / (_A2 * gap + _A3)
            * (weight * (_A4 * reynolds_number ** _A5 + _A6)
               + (1.0 - weight) * (_A7 * reynolds_number ** _A8 + _A9))
            + _A10)


@kernel
def friction_flow_ratio(gap_height, flow_length, reynolds_number):
    """phi = m_dot_nozzle / m_dot_friction of the hybrid leakage model (module docstring; Bell et al. 2013, PDSim
    TYPE_RADIAL): `pdsim_friction_ratio` clamped at FRICTION_RATIO_FLOOR = 1. docs/model.md §7.4."""
    ratio = pdsim_friction_ratio(gap_height, flow_length, reynolds_number)
    return ratio if ratio > FRICTION_RATIO_FLOOR else FRICTION_RATIO_FLOOR


@kernel
def leakage_flux(law, discharge_coefficient, gap_height, flow_length, nozzle_flux, viscosity):
    """Mass flux through the gap area delta W [kg/(s m^2)] given the upstream isentropic nozzle flux G (C_d = 1)
    [kg/(s m^2)] and the upstream viscosity mu [Pa s] (docs/model.md §7.4):

        LAW_NOZZLE:              C_d G
        LAW_FRICTION_CORRECTED:  G / phi(delta, L, Re),   Re = G 2 delta / mu
        LAW_SEALED:              0
    """
    if law == LAW_FRICTION_CORRECTED:
        reynolds = nozzle_flux * 2.0 * gap_height / viscosity if viscosity > 0.0 else np.inf
        return nozzle_flux / friction_flow_ratio(gap_height, flow_length, reynolds)
    if law == LAW_SEALED:
        return 0.0
    return discharge_coefficient * nozzle_flux


@kernel
def signed_leakage_flow(law, discharge_coefficient, gap_height, flow_length, width, pressure_a, temperature_a,
                        pressure_b, temperature_b, heat_capacity_ratio, gas_constant, viscosity_a, viscosity_b):
    """Mass flow [kg/s] from side a to side b through a gap (ideal-gas nozzle flux, docs/model.md §7.4); negative
    from b to a. The upstream side's temperature and viscosity are used.

    LAW_NOZZLE is control_volume.signed_nozzle_flow with A = delta W, unchanged. LAW_FRICTION_CORRECTED uses the
    same sign convention and linear band: with eps = LINEAR_FLOW_BAND,
        |p_up - p_down| >= eps p_up:  m_dot = delta W G(p_up, T_up -> p_down) / phi
        |p_up - p_down| <  eps p_up:  m_dot = [the same at p_down = (1 - eps) p_up] (p_up - p_down)/(eps p_up)
    A gap of height <= 0 and LAW_SEALED pass nothing.
    """
    if law == LAW_SEALED:
        return 0.0
    area = gap_height * width
    if law != LAW_FRICTION_CORRECTED:
        return signed_nozzle_flow(discharge_coefficient, area, pressure_a, temperature_a, pressure_b, temperature_b,
                                  heat_capacity_ratio, gas_constant)
    forward = pressure_a >= pressure_b
    upstream = pressure_a if forward else pressure_b
    downstream = pressure_b if forward else pressure_a
    temperature = temperature_a if forward else temperature_b
    viscosity = viscosity_a if forward else viscosity_b
    band = LINEAR_FLOW_BAND * upstream
    difference = upstream - downstream
    inside = difference < band
    flux = isentropic_nozzle_mass_flow(1.0, 1.0, upstream, temperature, upstream - band if inside else downstream,
                                       heat_capacity_ratio, gas_constant)
    flow = area * leakage_flux(LAW_FRICTION_CORRECTED, 1.0, gap_height, flow_length, flux, viscosity) * (
        difference / band if inside else 1.0) if gap_height > 0.0 and width > 0.0 else 0.0
    return flow if forward else -flow


@kernel
def leakage_path_open(law, gap_height, width):
    """True unless the path is LAW_SEALED or its gap closed (delta <= 0 or W <= 0): then it passes nothing."""
    return law != LAW_SEALED and gap_height > 0.0 and width > 0.0


@kernel(inline=True)          # compiled into path_flows: thermo.real_gas_nozzle's kernel notes
def real_gas_leakage_flow(law, discharge_coefficient, gap_height, flow_length, width, flux, factor,
                          temperature_up, density_up, nozzle_table):
    """Mass flow [kg/s] through a gap between two sides whose real-gas nozzle flux G and signed factor are given
    (thermo.real_gas_nozzle.nozzle_flux_between, flow from side a to side b positive), the upstream state
    (T, rho) for the viscosity (docs/model.md §7.4):

        LAW_NOZZLE:              C_d delta W G factor
        LAW_FRICTION_CORRECTED:  delta W G / phi(delta, L, Re) factor,   Re = G 2 delta / mu_up
        LAW_SEALED, closed gap:  0

    Inside the linear band G is the band-edge flux, so the law is evaluated at the band edge and scaled."""
    if not leakage_path_open(law, gap_height, width):
        return 0.0
    area = gap_height * width
    if law == LAW_FRICTION_CORRECTED:
        return area * leakage_flux(law, 1.0, gap_height, flow_length, flux,
                                   table_viscosity(temperature_up, density_up, nozzle_table)[0]) * factor
    return discharge_coefficient * area * flux * factor


@kernel
def signed_real_gas_leakage_flow(law, discharge_coefficient, gap_height, flow_length, width, temperature_a,
                                 density_a, pressure_a, temperature_b, density_b, pressure_b, nozzle_table):
    """(m_dot [kg/s], status): mass flow from side a to side b through a gap with the real-gas nozzle flux and the
    upstream viscosity of `nozzle_table` (`real_gas_leakage_flow` of `nozzle_flux_between`; docs/model.md §7.4);
    negative from b to a; status that of the upstream state (real_gas_nozzle status codes). LAW_NOZZLE is
    signed_real_gas_nozzle_flow with A = delta W. A closed gap and LAW_SEALED pass nothing with status 0, whatever
    the states, and cost no table look-up."""
    if not leakage_path_open(law, gap_height, width):
        return 0.0, STATUS_OK
    flux, factor, status = nozzle_flux_between(temperature_a, density_a, pressure_a, temperature_b, density_b,
                                               pressure_b, nozzle_table)
    forward = factor >= 0.0
    return real_gas_leakage_flow(law, discharge_coefficient, gap_height, flow_length, width, flux, factor,
                                 temperature_a if forward else temperature_b, density_a if forward else density_b,
                                 nozzle_table), status


@kernel
def parabolic_flank_length(gap_height, radius):
    """Friction-equivalent length [m] of one flank h = delta + x^2/(2 R), x from 0 to infinity (docs/model.md §7.4):
    delta^3 int dx/h^3 = (3 pi / 16) sqrt(2 R delta). Two flanks make a line seal."""
    return 3.0 * math.pi / 16.0 * math.sqrt(2.0 * radius * gap_height)


@kernel
def tapered_gap_length(gap_a, gap_b, length):
    """Friction-equivalent length [m] of a gap whose height varies linearly from delta_a to delta_b over `length`
    (the vane's side face against the slot wall, docs/model.md §7.4), referred to its narrowest height
    delta = min(delta_a, delta_b):

        L_eq = delta^3 int dx/h^3 = length delta^3 (delta_a + delta_b) / (2 delta_a^2 delta_b^2)

    (= length for a parallel gap); `length` for a closed gap, which passes nothing anyway."""
    narrowest = min(gap_a, gap_b)
    if not narrowest > 0.0:
        return length
    return length * narrowest ** 3 * (gap_a + gap_b) / (2.0 * gap_a * gap_a * gap_b * gap_b)


# ----------------------------------------------------------------------------------------------------------
# Python: checks, geometry, documentation figures

def _positive(name, value, unit):
    return checked_number(name, value, f"a finite number > 0 {unit}", lambda x: x > 0.0)


def _non_negative(name, value, unit):
    return checked_number(name, value, f"a finite number >= 0 {unit}", lambda x: x >= 0.0)


def equivalent_gap_radius(convex_radius, concave_radius=math.inf):
    """R [m] of the gap h = delta + x^2/(2 R) between a convex surface of radius R1 and a concave one of radius
    R2 > R1 (math.inf: a plane) facing it: 1/R = 1/R1 - 1/R2 (docs/model.md §7.4)."""
    convex_radius = _positive("convex_radius", convex_radius, "m")
    concave_radius = checked_number("concave_radius", concave_radius, f"> convex_radius = {convex_radius!r} m or inf",
                             lambda x: x > convex_radius) if concave_radius != math.inf else math.inf
    return 1.0 / (1.0 / convex_radius - 1.0 / concave_radius)


def valley_seal_radius(rotor_radius, tip_radius, stator_clearance, displacement_curvature):
    """R [m] of the valley gap between the rotor and the stator (docs/model.md §2.4-§2.5, §7.4).

    At a valley r = R0 = R_r - rho, r' = 0 and r'' = s'' (the displacement law's second derivative there:
    (h/2) z^2 for the harmonic law, 0 inside a bottom dwell, (h/2)(pi/beta_r)^2 just beyond it), so the pitch
    curve's curvature is kappa_C = (R0 - s'')/R0^2, the stator's (the offset by d = rho + c_S)
    kappa_S = kappa_C/(1 + d kappa_C), positive when its centre of curvature lies towards the rotor's, and
    1/R = 1/R_r - kappa_S. A convex stator valley (kappa_C < 0, many lobes) gives R < R_r.
    """
    rotor_radius = _positive("rotor_radius", rotor_radius, "m")
    tip_radius = checked_number("tip_radius", tip_radius, f"a finite number in (0, rotor_radius = {rotor_radius!r}) m",
                         lambda x: 0.0 < x < rotor_radius)
    stator_clearance = _non_negative("stator_clearance", stator_clearance, "m")
    displacement_curvature = checked_number("displacement_curvature", displacement_curvature, "a finite number [m/rad^2]",
                                     lambda x: True)
    base = rotor_radius - tip_radius
    pitch_curvature = (base - displacement_curvature) / (base * base)
    offset = tip_radius + stator_clearance
    if not 1.0 + offset * pitch_curvature > 0.0:
        fail("displacement_curvature", displacement_curvature,
              "a value for which the stator is regular at the valley (1 + d kappa_C > 0, docs/model.md §2.5)")
    stator_curvature = pitch_curvature / (1.0 + offset * pitch_curvature)
    opening = 1.0 / rotor_radius - stator_curvature
    if not opening > 0.0:
        fail("displacement_curvature", displacement_curvature,
              "a value for which the gap opens away from the valley (stator curvature below 1/rotor_radius)")
    return 1.0 / opening


def harmonic_valley_seal_radius(rotor_radius, tip_radius, stroke, lobes, stator_clearance=0.0):
    """`valley_seal_radius` for the harmonic law s = (h/2)(1 - cos z theta): s'' = (h/2) z^2 at the valley."""
    stroke = _positive("stroke", stroke, "m")
    if isinstance(lobes, bool) or not isinstance(lobes, (int, np.integer)) or lobes < 1:
        fail("lobes", lobes, "an integer >= 1")
    return valley_seal_radius(rotor_radius, tip_radius, stator_clearance, 0.5 * stroke * lobes * lobes)


def friction_length(gap_height, radius_a, radius_b=None, flat_length=0.0):
    """Friction-equivalent flow length L_eq [m] of a gap of minimum height delta: a flat part of length L_flat
    between two parabolic flanks h = delta + x^2/(2 R_a), delta + x^2/(2 R_b) (docs/model.md §7.4):

        L_eq = delta^3 int dx/h^3 = L_flat + (3 pi / 16) sqrt(2 delta) (sqrt(R_a) + sqrt(R_b))

    radius_b defaults to radius_a (a symmetric line seal: (3 pi / 8) sqrt(2 R delta))."""
    gap_height = _positive("gap_height", gap_height, "m")
    radius_a = _positive("radius_a", radius_a, "m")
    radius_b = radius_a if radius_b is None else _positive("radius_b", radius_b, "m")
    flat_length = _non_negative("flat_length", flat_length, "m")
    return flat_length + parabolic_flank_length(gap_height, radius_a) + parabolic_flank_length(gap_height, radius_b)


def gap_region_length(gap_height, radius, factor=2.0):
    """Length [m] over which a symmetric parabolic gap h = delta + x^2/(2 R) stays below factor x delta:
    2 sqrt(2 R delta (factor - 1)) (for comparison with `friction_length`: 1.70 L_eq at factor 2)."""
    gap_height = _positive("gap_height", gap_height, "m")
    radius = _positive("radius", radius, "m")
    factor = checked_number("factor", factor, "a finite number > 1", lambda x: x > 1.0)
    return 2.0 * math.sqrt(2.0 * radius * gap_height * (factor - 1.0))


def gap_reynolds_number(nozzle_flux, gap_height, viscosity):
    """Re = G D_h / mu with D_h = 2 delta (PDSim's definition; the same all along the gap at a given mass flow)."""
    return _non_negative("nozzle_flux", nozzle_flux, "kg/(s m^2)") * 2.0 * _positive(
        "gap_height", gap_height, "m") / _positive("viscosity", viscosity, "Pa s")


def _check_flow_arguments(gap_height, flow_length, upstream_pressure, upstream_temperature, downstream_pressure,
                          heat_capacity_ratio, gas_constant, viscosity):
    return (_positive("gap_height", gap_height, "m"), _non_negative("flow_length", flow_length, "m"),
            _positive("upstream_pressure", upstream_pressure, "Pa"),
            _positive("upstream_temperature", upstream_temperature, "K"),
            checked_number("downstream_pressure", downstream_pressure,
                    f"a finite number in [0, upstream_pressure = {upstream_pressure!r}) Pa",
                    lambda x: 0.0 <= x < float(upstream_pressure)),
            checked_number("heat_capacity_ratio", heat_capacity_ratio, "a finite number > 1", lambda x: x > 1.0),
            _positive("gas_constant", gas_constant, "J/(kg K)"), _positive("viscosity", viscosity, "Pa s"))


def equivalent_discharge_coefficient(gap_height, flow_length, upstream_pressure, upstream_temperature,
                                     downstream_pressure, heat_capacity_ratio, gas_constant, viscosity,
                                     law="friction_corrected", discharge_coefficient=1.0):
    """C_d,eq = m_dot(law) / m_dot(isentropic ideal-gas nozzle, C_d = 1) through the same gap at the given
    conditions (docs/model.md §7.4): C_d for "nozzle", 1/phi(delta, L, Re) for "friction_corrected" (Re from the
    ideal-gas flux). Does not depend on the width."""
    code = LEAKAGE_LAWS.code(law, "law")
    (gap_height, flow_length, upstream_pressure, upstream_temperature, downstream_pressure, heat_capacity_ratio,
     gas_constant, viscosity) = _check_flow_arguments(gap_height, flow_length, upstream_pressure,
                                                      upstream_temperature, downstream_pressure,
                                                      heat_capacity_ratio, gas_constant, viscosity)
    discharge_coefficient = checked_number("discharge_coefficient", discharge_coefficient, "a finite number in (0, 1]",
                                    lambda x: 0.0 < x <= 1.0)
    flux = isentropic_nozzle_mass_flow(1.0, 1.0, upstream_pressure, upstream_temperature, downstream_pressure,
                                       heat_capacity_ratio, gas_constant)
    return leakage_flux(code, discharge_coefficient, gap_height, flow_length, flux, viscosity) / flux


# ----------------------------------------------------------------------------------------------------------
# reference: isentropic entrance + Fanno channel (Python, for documentation and tests)

def darcy_friction_factor(reynolds_number):
    """Darcy friction factor of a wide smooth channel, D_h = 2 delta: laminar 96/Re (plane Poiseuille), turbulent
    Blasius 0.3164 Re^-0.25, the larger of the two (they cross at Re = 2040)."""
    reynolds_number = _positive("reynolds_number", reynolds_number, "")
    return max(96.0 / reynolds_number, 0.3164 * reynolds_number ** -0.25)


def _fanno_length(mach, k):
    """f_D L*/D_h of Fanno flow: (1 - M^2)/(k M^2) + (k + 1)/(2 k) ln[(k + 1) M^2 / (2 + (k - 1) M^2)]."""
    m2 = mach * mach
    return (1.0 - m2) / (k * m2) + (k + 1.0) / (2.0 * k) * math.log((k + 1.0) * m2 / (2.0 + (k - 1.0) * m2))


def fanno_channel_mass_flux(gap_height, flow_length, upstream_pressure, upstream_temperature, downstream_pressure,
                            heat_capacity_ratio, gas_constant, viscosity, friction_factor=darcy_friction_factor):
    """G [kg/(s m^2)] through a channel of constant height delta and length L from a stagnation state (p0, T0) of
    an ideal gas (k, R) to p_down (docs/model.md §7.4 reference; module docstring):

    isentropic acceleration to the channel inlet Mach number M1, G = p0 sqrt(k/(R T0)) M1 (1 + (k-1)/2 M1^2)^
    (-(k+1)/(2(k-1))); Fanno flow along the channel with f_D(Re), Re = G 2 delta/mu:
    F(M2) = F(M1) - f_D L/(2 delta); exit pressure p2 = p1 (M1/M2) sqrt((2 + (k-1) M1^2)/(2 + (k-1) M2^2)); the jet
    leaves at p2 = p_down, or choked (M2 = 1) when p_down is below the exit pressure of the choked channel.
    L = 0 gives the isentropic nozzle.
    """
    from scipy.optimize import brentq
    (gap_height, flow_length, p0, t0, downstream, k, gas_constant, viscosity) = _check_flow_arguments(
        gap_height, flow_length, upstream_pressure, upstream_temperature, downstream_pressure,
        heat_capacity_ratio, gas_constant, viscosity)
    diameter = 2.0 * gap_height
    exponent = (k + 1.0) / (2.0 * (k - 1.0))

    def flux(mach):
        return p0 * math.sqrt(k / (gas_constant * t0)) * mach * (1.0 + 0.5 * (k - 1.0) * mach * mach) ** -exponent

    def friction(mach):
        return friction_factor(flux(mach) * diameter / viscosity) * flow_length / diameter

    def exit_state(mach):
        """(M2, p2) for inlet Mach number M1 (M2 = 1 if the channel chokes)."""
        inlet_pressure = p0 * (1.0 + 0.5 * (k - 1.0) * mach * mach) ** (-k / (k - 1.0))
        target = _fanno_length(mach, k) - friction(mach)
        if target <= 0.0:
            exit_mach = 1.0
        elif flow_length == 0.0:
            exit_mach = mach
        else:
            exit_mach = brentq(lambda m: _fanno_length(m, k) - target, mach, 1.0, xtol=1e-15, rtol=1e-14)
        return exit_mach, inlet_pressure * mach / exit_mach * math.sqrt(
            (2.0 + (k - 1.0) * mach * mach) / (2.0 + (k - 1.0) * exit_mach * exit_mach))

    # the inlet Mach number at which the channel chokes at its exit: F(M1) = f_D L / D_h
    if flow_length == 0.0:
        choking = 1.0
    else:
        choking = brentq(lambda m: _fanno_length(m, k) - friction(m), 1e-9, 1.0 - 1e-15, xtol=1e-15, rtol=1e-14)
    if downstream <= exit_state(choking)[1]:
        return flux(choking)
    mach = brentq(lambda m: exit_state(m)[1] - downstream, 1e-12, choking, xtol=1e-15, rtol=1e-14)
    return flux(mach)


def fanno_equivalent_discharge_coefficient(gap_height, flow_length, upstream_pressure, upstream_temperature,
                                           downstream_pressure, heat_capacity_ratio, gas_constant, viscosity):
    """C_d,eq of the Fanno-channel reference: `fanno_channel_mass_flux` over the ideal-gas nozzle flux (C_d = 1)."""
    flux = fanno_channel_mass_flux(gap_height, flow_length, upstream_pressure, upstream_temperature,
                                   downstream_pressure, heat_capacity_ratio, gas_constant, viscosity)
    return flux / isentropic_nozzle_mass_flow(1.0, 1.0, float(upstream_pressure), float(upstream_temperature),
                                              float(downstream_pressure), float(heat_capacity_ratio),
                                              float(gas_constant))
