"""The flow paths of the real-gas chambers (issue 14 items 2 and 3, docs/model.md §7.4) against independent
calculations.

References: CoolProp's own isentropic expansion (reference_formulas.IsentropicExpansion: PS flashes, the choked
flux by numerical maximisation), the ideal-gas nozzle formula written here, PDSim's leakage correlation
(reference_formulas.pdsim_mdot_ratio), the slot and tip gaps of the reference contact detection (reference_formulas)
and the friction-equivalent lengths by quadrature of delta^3/h^3 over the independent harmonic stator
(reference_formulas.HarmonicPitch).
Then: sign and symmetry, closed gaps, the metastable-throat status, mass and energy closure of a run with every path
open, and the default model's per-revolution figures.
"""
import math

import CoolProp
import numpy as np
import pytest
from scipy.integrate import quad

from reference_formulas import (HarmonicPitch, IsentropicExpansion, VaneGeometry, pdsim_mdot_ratio, perp,
                                reference_slot_bottom, reference_slot_mouth, reference_tip, rot)

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.geometry.stator import valley_seal_length
from rotary_vane.mechanics.loop.layout import GAS_BLOCK, GAS_STATE_INVALID
from rotary_vane.mechanics.performance import revolutions
from rotary_vane.thermo.chamber_model import (CONSTANT_FIELDS, LEADING_MASS, LEADING_TEMPERATURE, PATH_FIELDS,
                                              TRAILING_MASS, TRAILING_TEMPERATURE, ChamberInputs,
                                              boundary_nodes, chamber_constants, chamber_flow_work, chamber_rates,
                                              path_value_names)
from rotary_vane.thermo.flow_paths import (BACK, FIXED_GAP, FLOW_PATHS, LEADING, PATH, SUCTION, TRAILING, FlowNode,
                                           FlowPath, path_flows, set_node)
from rotary_vane.thermo.property_table import table_from_arrays
from rotary_vane.thermo.leakage import (LEAKAGE_LAWS, friction_length, harmonic_valley_seal_radius,
                                        signed_real_gas_leakage_flow, valley_seal_radius)
from rotary_vane.thermo.real_gas_nozzle import ARRAY_FIELDS, nozzle_table_from_arrays

OPERATING = dict(pressure_model="real_gas", slot_clearance=5e-5, stator_clearance=5e-5)
EVERY_PATH_OPEN = dict(OPERATING, slot_leak_law="nozzle")
ACCURACY = 5e-3                                   # issue 14: within 0.5 % of CoolProp
MID_LOBE = 1.0                                    # rotor angle [rad]: vane past the suction port (10 deg), mid-lobe


def coolprop_state(fluid, **inputs):
    """A CoolProp HEOS state from (T, P), (P, S) or (Dmass, T) given by name."""
    state = CoolProp.AbstractState("HEOS", fluid)
    pairs = {("P", "T"): CoolProp.PT_INPUTS, ("P", "S"): CoolProp.PSmass_INPUTS, ("D", "T"): CoolProp.DmassT_INPUTS}
    key = tuple(sorted(inputs))
    state.update(pairs[key], *(inputs[name] for name in key))
    return state


def back_chamber_state(params):
    """(T, rho) of the back chamber: p_d on the suction isentrope (docs/model.md §7.4)."""
    suction = coolprop_state(params.fluid, P=params.suction_pressure, T=params.suction_temperature)
    back = coolprop_state(params.fluid, P=params.discharge_pressure, S=suction.smass())
    return back.T(), back.rhomass()


def flux(fluid, temperature, density, pressure_down):
    """CoolProp's isentropic nozzle mass flux [kg/(s m^2)] from (T, rho) to p_down (0 if p_down >= p_up)."""
    expansion = IsentropicExpansion(fluid, temperature, density)
    return expansion.flux(pressure_down)[0] if pressure_down < expansion.pressure else 0.0


def signed_flux(fluid, a, b):
    """CoolProp's flux from node a = (T, rho, p) towards node b, negative (b's flux) when b is upstream."""
    if a[2] >= b[2]:
        return flux(fluid, a[0], a[1], b[2])
    return -flux(fluid, b[0], b[1], a[2])


def viscosity(fluid, temperature, density):
    return coolprop_state(fluid, D=density, T=temperature).viscosity()


def posed_state(sim, lateral=0.0, inward=0.0, tilt=0.0, leading=None, trailing=None):
    """The run's initial state with the vane moved along e_theta by `lateral`, towards the rotor axis by `inward`
    and tilted by `tilt` about its centre of mass, and the chambers filled at (T, p) `leading` / `trailing` (the
    volumes of the new pose). Returns (y, outputs at y)."""
    y = sim.state.copy()
    theta = y[2]
    y[:2] += lateral * perp(rot(theta)) - inward * rot(theta)
    y[2] += tilt
    volumes = sim.evaluate(0.0, y)[2]
    for state, temperature_index, mass_index, volume in ((leading, LEADING_TEMPERATURE, LEADING_MASS,
                                                         volumes["leading_volume"]),
                                                        (trailing, TRAILING_TEMPERATURE, TRAILING_MASS,
                                                         volumes["trailing_volume"])):
        if state is not None:
            y[GAS_BLOCK + temperature_index] = state[0]
            y[GAS_BLOCK + mass_index] = coolprop_state(sim.params.fluid, P=state[1], T=state[0]).rhomass() * volume
    status, _, outputs = sim.evaluate(0.0, y)
    assert status == 0
    return y, outputs


def chamber_nodes(sim, y, outputs):
    """(T, rho, p) of the leading and trailing chamber of an evaluated state."""
    return tuple((y[GAS_BLOCK + t], y[GAS_BLOCK + m] / outputs[f"{name}_volume"], outputs[f"{name}_pressure"])
                 for name, t, m in (("leading", LEADING_TEMPERATURE, LEADING_MASS),
                                    ("trailing", TRAILING_TEMPERATURE, TRAILING_MASS)))


def slot_gaps(params, m, y):
    """Per side (+1 leading, -1 trailing): (narrowest gap, friction-equivalent length by quadrature) of the side
    face against the slot wall, from the reference contact detection (the gap is linear between the bottom corner
    and the mouth along the engaged length)."""
    v = VaneGeometry(params, m.tip_centre)
    g, phi, theta = y[:2], y[2], MID_LOBE
    result = {}
    for side in (1, -1):
        bottom = -reference_slot_bottom(side, g, phi, theta, v)["delta"]
        mouth = -reference_slot_mouth(side, g, phi, theta, v)["delta"]
        edge = v.mouth * rot(theta) + side * 0.5 * v.w * perp(rot(theta))
        engaged = min(np.dot(edge - g, rot(phi)), v.xi_t) - v.xi_b
        narrowest = min(bottom, mouth)
        length = quad(lambda x: (narrowest / (bottom + (mouth - bottom) * x / engaged)) ** 3, 0.0, engaged,
                      epsrel=1e-12)[0]
        result[side] = (narrowest, length)
    return result


def harmonic_valley_length(params):
    """delta^3 int ds/g^3 over the independent harmonic stator, g = |S| - R_r the radial gap (docs/model.md §7.4)."""
    pitch = HarmonicPitch(params.base_radius, params.stroke, params.lobes)
    gap = params.stator_clearance

    def weight(u):
        return (gap / (np.linalg.norm(pitch.stator(u, params.envelope_offset)) - params.rotor_radius)) ** 3 * \
            np.linalg.norm(pitch.stator_derivative(u, params.envelope_offset))
    return 2.0 * quad(weight, 0.0, math.pi / params.lobes, points=[1e-3, 1e-2, 0.1], limit=400, epsrel=1e-11)[0]


def friction_flow(fluid, gap, length, width, upstream, pressure_down):
    """PDSim's friction-corrected leak (clamped at the nozzle, docs/model.md §7.4) with CoolProp's flux and
    viscosity: delta W G / max(1, phi(delta, L, Re)), Re = G 2 delta / mu."""
    g = flux(fluid, upstream[0], upstream[1], pressure_down)
    reynolds = g * 2.0 * gap / viscosity(fluid, upstream[0], upstream[1])
    return gap * width * g / max(1.0, pdsim_mdot_ratio(gap, length, reynolds))


@pytest.fixture(scope="module")
def every_path():
    """A run with every path open, at mid-lobe: leading chamber above p_d (valve open, choked valley leak),
    trailing above p_s (reverse suction port, start-valley leak), vane 10 um off-centre, tilted by 3e-4 rad and
    20 um below the stator (tip gap)."""
    sim = Simulation(CompressorParameters(**EVERY_PATH_OPEN), constant_speed(1500.0), initial_angle=MID_LOBE)
    y, outputs = posed_state(sim, lateral=10e-6, inward=20e-6, tilt=3e-4, leading=(370.0, 1.5e6),
                             trailing=(300.0, 0.45e6))
    return sim, y, outputs


def test_every_path_is_coolprops_isentropic_nozzle(every_path):
    """Each path's flow = C_d A G with G from CoolProp's isentropic expansion of the upstream state (choked where
    the ratio is below critical), within 0.5 %; areas from the parameters and the reference gaps."""
    sim, y, outputs = every_path
    p = sim.params
    leading, trailing = chamber_nodes(sim, y, outputs)
    suction = (p.suction_temperature, coolprop_state(p.fluid, P=p.suction_pressure, T=p.suction_temperature)
               .rhomass(), p.suction_pressure)
    back = (*back_chamber_state(p), p.discharge_pressure)
    gaps = slot_gaps(p, sim.machine, y)
    lift = -outputs["penetration_5"] if math.isfinite(outputs["penetration_5"]) else -outputs["penetration_6"]
    tip = reference_tip(y[:2], y[2], VaneGeometry(p, sim.machine.tip_centre))
    assert lift == pytest.approx(-tip["delta"], rel=1e-6) and lift > 10e-6
    width = p.axial_length
    expected = dict(
        suction_mass_flow=p.suction_port_coefficient * p.suction_port_area * signed_flux(p.fluid, suction, trailing),
        discharge_mass_flow=p.discharge_port_coefficient * p.discharge_port_area
        * flux(p.fluid, leading[0], leading[1], p.discharge_pressure),
        end_valley_leak_mass_flow=p.end_valley_leak_coefficient * p.stator_clearance * width
        * flux(p.fluid, leading[0], leading[1], suction[2]),
        start_valley_leak_mass_flow=p.start_valley_leak_coefficient * p.stator_clearance * width
        * signed_flux(p.fluid, trailing, suction),
        tip_leak_mass_flow=p.tip_leak_coefficient * lift * width * signed_flux(p.fluid, leading, trailing),
        slot_leak_leading_mass_flow=p.slot_leak_coefficient * gaps[1][0] * width * signed_flux(p.fluid, back, leading),
        slot_leak_trailing_mass_flow=p.slot_leak_coefficient * gaps[-1][0] * width
        * signed_flux(p.fluid, back, trailing))
    assert leading[2] > p.discharge_pressure and trailing[2] > p.suction_pressure
    for name, value in expected.items():
        assert value != 0.0 and outputs[name] == pytest.approx(value, rel=ACCURACY), name
    assert outputs["metastable_flow_paths"] == 0


@pytest.mark.parametrize("path", ["end_valley", "start_valley", "tip", "slot"])
def test_friction_corrected_law_is_pdsims_with_the_gaps_seal_length(every_path, path):
    """The friction-corrected law on one path: delta W G / max(1, phi) with PDSim's phi at the path's
    friction-equivalent length: the valley seal by quadrature over the reference stator, the tip gap a line seal of
    the tip and the stator curvatures ((3 pi/8) sqrt(2 R delta)), the slot face by quadrature of its linear gap."""
    sim, y, _ = every_path
    p = sim.params.replace(**{f"{path}_leak_law": "friction_corrected"})
    friction = Simulation(p, constant_speed(1500.0), initial_angle=MID_LOBE)
    status, _, outputs = friction.evaluate(0.0, y)
    assert status == 0
    leading, trailing = chamber_nodes(friction, y, outputs)
    width = p.axial_length
    if path in ("end_valley", "start_valley"):
        chamber = leading if path == "end_valley" else trailing
        expected = friction_flow(p.fluid, p.stator_clearance, harmonic_valley_length(p), width, chamber,
                                 p.suction_pressure)
    elif path == "tip":
        tip = reference_tip(y[:2], y[2], VaneGeometry(p, friction.machine.tip_centre))
        lift = -tip["delta"]
        expected = friction_flow(p.fluid, lift, 3 * math.pi / 8 * math.sqrt(2 * tip["radius"] * lift), width,
                                 leading, trailing[2])
    else:
        gap, length = slot_gaps(p, friction.machine, y)[1]            # leading above p_d: the leak goes back
        assert leading[2] > p.discharge_pressure
        expected = -friction_flow(p.fluid, gap, length, width, leading, p.discharge_pressure)
    name = "slot_leak_leading_mass_flow" if path == "slot" else f"{path}_leak_mass_flow"
    assert outputs[name] == pytest.approx(expected, rel=ACCURACY)


def test_ideal_gas_limit():
    """Air at 1 -> 3 bar is nearly ideal: the end-valley leak is the ideal-gas isentropic nozzle (k = c_p0/c_v0 at
    the upstream temperature, choked) within 0.5 %."""
    common = dict(OPERATING, fluid="Air", suction_pressure=1.0e5, suction_temperature=293.15,
                  discharge_pressure=3.0e5)
    sim = Simulation(CompressorParameters(**common), constant_speed(1500.0), initial_angle=MID_LOBE)
    y, outputs = posed_state(sim, leading=(360.0, 2.5e5))
    temperature, _, pressure = chamber_nodes(sim, y, outputs)[0]
    state = coolprop_state("Air", P=pressure, T=temperature)
    gas_constant = CoolProp.CoolProp.PropsSI("GAS_CONSTANT", "Air") / state.molar_mass()
    cp0 = state.cp0mass()
    k = cp0 / (cp0 - gas_constant)
    ratio = max(sim.params.suction_pressure / pressure, (2 / (k + 1)) ** (k / (k - 1)))
    ideal = pressure / math.sqrt(gas_constant * temperature) * math.sqrt(
        2 * k / (k - 1) * (ratio ** (2 / k) - ratio ** ((k + 1) / k)))
    expected = sim.params.end_valley_leak_coefficient * sim.params.stator_clearance * sim.params.axial_length * ideal
    assert outputs["end_valley_leak_mass_flow"] == pytest.approx(expected, rel=ACCURACY)


def test_valley_seal_length_against_the_curvature_closed_forms():
    """valley_seal_length: the quadrature over the reference stator (harmonic law), and the closed forms of the
    curvatures at the valley (docs/model.md §7.4): (3 pi/8) sqrt(2 R c) for the harmonic law, the concentric
    dwell (R_r + c) beta0 plus two flanks of the curvature just beyond it for harmonic_dwell. The closed forms keep
    the parabolic term of the gap only: within 1 % up to c = 0.05 mm (1.7 % short at 0.2 mm, where the seal spans
    0.13 rad and the quartic term of the harmonic law counts)."""
    for clearance in (0.02e-3, 0.05e-3):
        p = CompressorParameters(stator_clearance=clearance)
        closed = friction_length(clearance, harmonic_valley_seal_radius(p.rotor_radius, p.tip_radius, p.stroke,
                                                                        p.lobes, clearance))
        assert valley_seal_length(p) == pytest.approx(harmonic_valley_length(p), rel=1e-8)
        assert valley_seal_length(p) == pytest.approx(closed, rel=0.01)
        dwell = p.replace(displacement_law="harmonic_dwell", bottom_dwell=0.2, top_dwell=0.1)
        rise = 0.5 * (2 * math.pi / dwell.lobes - dwell.bottom_dwell - dwell.top_dwell)
        flank = valley_seal_radius(p.rotor_radius, p.tip_radius, clearance, 0.5 * p.stroke * (math.pi / rise) ** 2)
        closed = friction_length(clearance, flank, flank, (p.rotor_radius + clearance) * dwell.bottom_dwell)
        assert valley_seal_length(dwell) == pytest.approx(closed, rel=0.01)
    wide = CompressorParameters(stator_clearance=0.2e-3)
    assert valley_seal_length(wide) == pytest.approx(harmonic_valley_length(wide), rel=1e-8)
    assert valley_seal_length(CompressorParameters(stator_clearance=0.0)) == 0.0


def test_closed_gaps_and_sealed_paths_pass_nothing():
    """c_S = 0 closes both valley seals, c_R = 0 the slot faces (to the rounding of the contact geometry), a tip on
    the stator the tip gap, and "sealed" closes an open gap; the other paths still flow."""
    closed = Simulation(CompressorParameters(**dict(EVERY_PATH_OPEN, stator_clearance=0.0, slot_clearance=0.0)),
                        constant_speed(1500.0), initial_angle=MID_LOBE)
    _, outputs = posed_state(closed, leading=(370.0, 1.5e6), trailing=(300.0, 0.45e6))
    for name in ("end_valley_leak_mass_flow", "start_valley_leak_mass_flow", "tip_leak_mass_flow"):
        assert outputs[name] == 0.0, name
    for name in ("slot_leak_leading_mass_flow", "slot_leak_trailing_mass_flow"):     # gaps of rounding size
        assert abs(outputs[name]) < 1e-12, name
    assert outputs["discharge_mass_flow"] > 0.0 and outputs["suction_mass_flow"] < 0.0
    sealed = Simulation(CompressorParameters(**dict(EVERY_PATH_OPEN, end_valley_leak_law="sealed",
                                                    start_valley_leak_law="sealed", slot_leak_law="sealed",
                                                    tip_leak_law="sealed")),
                        constant_speed(1500.0), initial_angle=MID_LOBE)
    _, outputs = posed_state(sealed, lateral=10e-6, inward=20e-6, leading=(370.0, 1.5e6), trailing=(300.0, 0.45e6))
    for name in ("end_valley_leak_mass_flow", "start_valley_leak_mass_flow", "tip_leak_mass_flow",
                 "slot_leak_leading_mass_flow", "slot_leak_trailing_mass_flow"):
        assert outputs[name] == 0.0, name


def chamber_flows(inputs, c, leading, trailing, nozzles):
    """(flow of every path by name, refused, metastable) of the flow network between the two chamber nodes and the
    run's boundary nodes."""
    suction, back = boundary_nodes(c, 0.0)
    work = chamber_flow_work()[0]
    for node, state in ((SUCTION, suction), (LEADING, leading), (TRAILING, trailing), (BACK, back)):
        set_node(work, node, state)
    status = path_flows(inputs, c, work, nozzles)
    return dict(zip(PATH._fields, work["mass_flow"])), status.refused, status.metastable


def test_flows_are_antisymmetric_in_their_two_sides(every_path):
    """Swapping the two chambers' states reverses the tip flow exactly and exchanges the end- and start-valley
    leaks (same law and coefficient); swapping the two side gaps exchanges the slot flows."""
    sim, y, outputs = every_path
    c = sim.gas.chambers[0]
    nozzles = nozzle_table_from_arrays(*sim.gas.nozzles)
    leading, trailing = ((*node, 0.0) for node in chamber_nodes(sim, y, outputs))
    inputs = ChamberInputs(1e-6, 1e-6, 0.0, 0.0, MID_LOBE, 20e-6, 1e-3, 10e-6, 5e-3, 30e-6, 5e-3)
    swapped = inputs._replace(slot_gap_leading=inputs.slot_gap_trailing, slot_gap_trailing=inputs.slot_gap_leading)
    forward, refused_forward, _ = chamber_flows(inputs, c, FlowNode(*leading), FlowNode(*trailing), nozzles)
    backward, refused_backward, _ = chamber_flows(swapped, c, FlowNode(*trailing), FlowNode(*leading), nozzles)
    assert forward["tip_leak"] > 0.0 and backward["tip_leak"] == -forward["tip_leak"]
    assert backward["end_valley_leak"] == forward["start_valley_leak"]
    assert backward["start_valley_leak"] == forward["end_valley_leak"]
    assert backward["slot_leak_leading"] == forward["slot_leak_trailing"]
    assert backward["slot_leak_trailing"] == forward["slot_leak_leading"]
    assert refused_forward == refused_backward == 0


def test_metastable_throat_is_accepted_and_counted_a_refused_inlet_invalidates_the_state(every_path):
    """docs/model.md §7.4: gas 2 K above its dew point at p_d expands into the dome on its way to p_s; the
    end-valley leak is the gas-branch continuation (finite, positive) and counts as one metastable path, not as a
    refusal. An upstream state the nozzle table refuses gives a NaN flow and a refusal, and a chamber state that
    only the nozzle table refuses (here: every cell marked inaccurate) makes the state invalid for the loop."""
    sim, y, outputs = every_path
    p = sim.params
    c = sim.gas.chambers[0]
    nozzles = nozzle_table_from_arrays(*sim.gas.nozzles)
    dew_temperature = CoolProp.CoolProp.PropsSI("T", "P", p.discharge_pressure, "Q", 1, p.fluid)
    near = coolprop_state(p.fluid, P=p.discharge_pressure, T=dew_temperature + 2.0)
    trailing = (*chamber_nodes(sim, y, outputs)[1], 0.0)
    inputs = ChamberInputs(1e-6, 1e-6, 0.0, 0.0, MID_LOBE, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    flows, refused, metastable = chamber_flows(inputs, c, FlowNode(near.T(), near.rhomass(), near.p(), 0.0),
                                               FlowNode(*trailing), nozzles)
    assert metastable == 1 and refused == 0 and flows["end_valley_leak"] > 0.0
    cold, refused, _ = chamber_flows(inputs, c, FlowNode(100.0, 1.0, 2e6, 0.0), FlowNode(*trailing), nozzles)
    assert refused == 2 and math.isnan(cold["end_valley_leak"]) and math.isnan(cold["discharge"])   # seal, valve
    refusing = Simulation(sim.params, constant_speed(1500.0), initial_angle=MID_LOBE)
    assert refusing.evaluate(0.0, y)[0] == 0
    refusing.gas.nozzles[1 + ARRAY_FIELDS.index("accurate_cell")][:] = False   # after the header
    assert refusing.evaluate(0.0, y)[0] == GAS_STATE_INVALID


@pytest.fixture(scope="module")
def every_path_run():
    """Three revolutions with every path open and two of them friction-corrected."""
    params = CompressorParameters(**dict(EVERY_PATH_OPEN, tip_leak_law="friction_corrected",
                                         start_valley_leak_law="friction_corrected"))
    sim = Simulation(params, constant_speed(1500.0))
    sim.advance(3 * 0.04)
    return sim


def test_mass_and_energy_close_with_every_path_open(every_path_run):
    """Per revolution the chamber mass balance closes to rounding (|residual| < 1e-12 of the delivered mass, as
    before the new paths) and the energy balance to 1e-4 of the compression work (tests/mechanics/test_real_gas.py), with
    the start-valley and slot paths carrying flow (the tip stays on the stator in this run)."""
    sim = every_path_run
    history = sim.history
    for name in ("start_valley_leak_mass_flow", "slot_leak_leading_mass_flow",
                 "slot_leak_trailing_mass_flow", "end_valley_leak_mass_flow"):
        assert np.max(np.abs(history[name])) > 1e-6, name
    for rev in revolutions(sim):
        assert abs(rev.gas_mass_residual) < 1e-12
        assert abs(rev.gas_energy_residual) < 1e-4
        assert rev.back_chamber_mass_flow > 0.0


def test_default_model_runs_and_reports_its_figures():
    """z = 3, 1500 rpm, c = 0.05 mm, default leak laws: four revolutions run; the figures are printed (see the
    report of issue 14); the discharge temperature is above the isentropic one (leakage re-heats the gas), the last
    two revolutions agree within 0.1 %, and the mass balance closes to rounding."""
    sim = Simulation(CompressorParameters(**OPERATING), constant_speed(1500.0))
    sim.advance(4 * 0.04)
    figures = revolutions(sim)
    for rev in figures:
        print(f"P_in {rev.input_power:.2f} W, eta_m {100 * rev.mechanical_efficiency:.3f} %, "
              f"m_dot_d {1e3 * rev.discharge_mass_flow:.4f} g/s, T_d {rev.discharge_temperature:.2f} K")
    isentropic = back_chamber_state(sim.params)[0]
    last, previous = figures[-1], figures[-2]
    assert last.discharge_temperature > isentropic
    for name in ("input_power", "mechanical_efficiency", "discharge_mass_flow", "discharge_temperature"):
        assert getattr(last, name) == pytest.approx(getattr(previous, name), rel=1e-3), name
    assert abs(last.gas_mass_residual) < 1e-12


def test_level_half_honours_a_sealed_valley_and_refuses_the_friction_law():
    """Level 0.5 has the end-valley seal only: "sealed" gives the table of a leak coefficient 0, the coefficient is
    the end valley's, and the friction-corrected law, which needs the fluid's viscosity, is refused before any
    work."""
    level_half = dict(pressure_model="ideal_gas_table", stator_clearance=0.1e-3)
    sealed = Simulation(CompressorParameters(**level_half, end_valley_leak_law="sealed"))
    closed = Simulation(CompressorParameters(**level_half, end_valley_leak_coefficient=0.0))
    leaking = Simulation(CompressorParameters(**level_half))
    assert np.array_equal(sealed.gas.pressure_table, closed.gas.pressure_table)
    assert np.max(np.abs(leaking.gas.pressure_table - closed.gas.pressure_table)) > 1e4
    with pytest.raises(ValueError, match="end_valley_leak_law.*friction_corrected.*real_gas"):
        CompressorParameters(pressure_model="ideal_gas_table", end_valley_leak_law="friction_corrected")
    with pytest.raises(ValueError, match="slot_leak_law.*oil.*nozzle, friction_corrected, sealed"):
        CompressorParameters(slot_leak_law="oil")


def extended_constants(c, paths, **new_values):
    """chamber_constants for the path table `paths` with the values of the run's record `c` (its scalars, and the
    values its path arrays hold under the names the rows of FLOW_PATHS give them) and `new_values`."""
    values = {name: float(c[name]) for name in CONSTANT_FIELDS}
    for p, path in enumerate(FLOW_PATHS):
        for field in PATH_FIELDS:
            if getattr(path, field) in path_value_names((path,)):
                values[getattr(path, field)] = float(c[f"path_{field}"][p])
    return chamber_constants(paths, **values, **new_values)[0]


def test_adding_a_flow_path_is_one_row(every_path):
    """docs/model.md §14.5: a new row (a bypass L -> T through a fixed gap with the tip's law and coefficient) is
    all a path needs. Closed, the rates are those of the shipped network to the bit and the path is in the flows
    with no flow; open, its flow is the leakage law's (thermo.leakage, evaluated on its own) and it leaves L and
    enters T, every other rate unchanged."""
    sim, y, outputs = every_path
    c = sim.gas.chambers[0]
    table = table_from_arrays(*sim.gas.properties)
    nozzles = nozzle_table_from_arrays(*sim.gas.nozzles)
    dead = sim.params.dead_volume
    inputs = ChamberInputs(outputs["leading_volume"] - dead, outputs["trailing_volume"] - dead, 0.0, 0.0, MID_LOBE,
                           20e-6, 1e-3, 10e-6, 5e-3, 30e-6, 5e-3)
    bypass = FlowPath("bypass", LEADING, TRAILING, FIXED_GAP, "bypass_gap", "bypass_length", "axial_length",
                      "tip_law", "tip_coefficient", "")
    paths = (*FLOW_PATHS, bypass)
    shipped, flows = np.zeros(y.size), chamber_flow_work()[0]
    chamber_rates(0.0, y, GAS_BLOCK, inputs, c, table, nozzles, shipped, flows)
    closed, closed_flows = np.zeros(y.size), chamber_flow_work(paths)[0]
    chamber_rates(0.0, y, GAS_BLOCK, inputs, extended_constants(c, paths, bypass_gap=0.0, bypass_length=0.0), table,
                  nozzles, closed, closed_flows)
    assert np.array_equal(closed, shipped)
    assert len(closed_flows["mass_flow"]) == len(flows["mass_flow"]) + 1 and closed_flows["mass_flow"][-1] == 0.0
    assert np.array_equal(closed_flows["mass_flow"][:-1], flows["mass_flow"])
    gap, length = 15e-6, 2e-3
    opened, open_flows = np.zeros(y.size), chamber_flow_work(paths)[0]
    chamber_rates(0.0, y, GAS_BLOCK, inputs, extended_constants(c, paths, bypass_gap=gap, bypass_length=length), table,
                  nozzles, opened, open_flows)
    (t_l, rho_l, p_l), (t_t, rho_t, p_t) = chamber_nodes(sim, y, outputs)
    expected, status = signed_real_gas_leakage_flow(
        LEAKAGE_LAWS.code(sim.params.tip_leak_law, "tip_leak_law"), sim.params.tip_leak_coefficient, gap, length,
        sim.params.axial_length, t_l, rho_l, p_l, t_t, rho_t, p_t, nozzles)
    assert status == 0 and expected > 0.0
    assert open_flows["mass_flow"][-1] == pytest.approx(expected, rel=1e-12)
    changed = {GAS_BLOCK + i for i in (LEADING_TEMPERATURE, LEADING_MASS, TRAILING_TEMPERATURE, TRAILING_MASS)}
    unchanged = [i for i in range(y.size) if i not in changed]
    assert np.array_equal(opened[unchanged], shipped[unchanged])
    assert opened[GAS_BLOCK + LEADING_MASS] == pytest.approx(shipped[GAS_BLOCK + LEADING_MASS] - expected, rel=1e-12)
    assert opened[GAS_BLOCK + TRAILING_MASS] == pytest.approx(shipped[GAS_BLOCK + TRAILING_MASS] + expected,
                                                              rel=1e-12)
