"""Print the equivalent discharge coefficient table of the leakage laws (docs/model.md §7.4.4).

Run from anywhere:  python docs/flow_paths_table.py

The default machine (docs/model.md §9: R_r = 30 mm, tip radius 2 mm, harmonic law, h = 5 mm, z = 3), R134a between
p_s = 0.2928 MPa (T_s = 283.15 K) and p_d = 1.3179 MPa. The upstream gas lies on the suction isentrope (CoolProp),
k = c_p0/(c_p0 - R) at T_s and R = 8314.462/M, mu from CoolProp at the upstream state. For each clearance c: the
gap's radius (valley and tip seals), its friction-equivalent length L_eq as the time loop takes it, the Reynolds
number of the ideal-gas nozzle flux, PDSim's unclamped ratio phi and the equivalent C_d of
  - "friction_corrected" (1/max(1, phi)),
  - the Fanno-channel reference over L_eq, and, for the curved seals, over the length where the gap is below 3 c,
for three pressure differences on the valley seal: from the discharge state to suction (choked), from
mid-compression to suction, and a small difference near discharge (pr = 0.9). Then the tip gap and a slot side face
(the vane centred in a slot of clearance c, gap c/2, at mid-stroke), both from the discharge state to suction.
"""
from __future__ import annotations

import math

from rotary_vane.mechanics.geometry.displacement import displacement
from rotary_vane.mechanics.geometry.stator import law_arguments, valley_seal_length
from rotary_vane.mechanics.loop.machine import machine_from_parameters
from rotary_vane.mechanics.parameters import CompressorParameters
from rotary_vane.thermo.fluid import Fluid, coolprop
from rotary_vane.thermo.leakage import (equivalent_discharge_coefficient, equivalent_gap_radius,
                                        fanno_equivalent_discharge_coefficient, friction_length,
                                        gap_region_length, gap_reynolds_number, harmonic_valley_seal_radius,
                                        pdsim_friction_ratio)
from rotary_vane.thermo.nozzle import isentropic_nozzle_mass_flow

PARAMETERS = CompressorParameters()
SUCTION_PRESSURE, SUCTION_TEMPERATURE, DISCHARGE_PRESSURE = (PARAMETERS.suction_pressure,
                                                             PARAMETERS.suction_temperature,
                                                             PARAMETERS.discharge_pressure)
CLEARANCES = (0.02e-3, 0.05e-3, 0.1e-3, 0.2e-3)
CHOKED = ("p_d -> p_s (pr 0.22, choked)", DISCHARGE_PRESSURE, SUCTION_PRESSURE)
CASES = (CHOKED, ("0.6 MPa -> p_s (pr 0.49, choked)", 0.6e6, SUCTION_PRESSURE),
         ("p_d -> 0.9 p_d (pr 0.90)", DISCHARGE_PRESSURE, 0.9 * DISCHARGE_PRESSURE))


def upstream_state(fluid: Fluid, pressure):
    """(T, mu) on the suction isentrope at p."""
    entropy = fluid.properties(SUCTION_TEMPERATURE, fluid.density(SUCTION_TEMPERATURE, SUCTION_PRESSURE)).entropy
    temperature = fluid.state_at_pressure_entropy(pressure, entropy).temperature
    state = coolprop().AbstractState("HEOS", fluid.name)
    state.update(coolprop().PT_INPUTS, pressure, temperature)
    return temperature, state.viscosity()


def valley(clearance):
    """(gap, radius at the valley, L_eq of the time loop) of the valley seal."""
    p = PARAMETERS.replace(stator_clearance=clearance)
    return clearance, harmonic_valley_seal_radius(p.rotor_radius, p.tip_radius, p.stroke, p.lobes, clearance), \
        valley_seal_length(p)


def tip(clearance):
    """The tip gap: the vane tip (convex, radius t/2) against the concave stator, whose radius of curvature
    1/kappa_C + d is at least 19.62 + 2 mm for z = 3 (docs/model.md §2.5): R between 2.0 and 2.2 mm; 2.2 mm here."""
    radius = equivalent_gap_radius(PARAMETERS.tip_radius, 19.62e-3 + PARAMETERS.tip_radius)
    return clearance, radius, friction_length(clearance, radius)


def slot_face(clearance):
    """A side face of the vane centred in a slot of clearance c (gap c/2) at mid-stroke: a parallel gap over the
    engaged length, from the bottom face to the slot mouth (docs/model.md §7.4.3)."""
    p = PARAMETERS.replace(slot_clearance=clearance)
    m = machine_from_parameters(p)
    tip_radius_position = p.base_radius + displacement(0.5 * math.pi / p.lobes, *law_arguments(p)[:5])[0]
    mouth_level = m.tip_centre - (tip_radius_position - p.mouth_radius)
    return 0.5 * clearance, math.nan, min(mouth_level, m.tip_centre) - m.bottom_face


def rows(fluid: Fluid, gap_of, label, cases):
    k, gas_constant = fluid.ideal_gas_exponent(SUCTION_TEMPERATURE), fluid.gas_constant
    lines = []
    for case, pressure, downstream in cases:
        temperature, viscosity = upstream_state(fluid, pressure)
        flux = isentropic_nozzle_mass_flow(1.0, 1.0, pressure, temperature, downstream, k, gas_constant)
        for clearance in CLEARANCES:
            gap, radius, length = gap_of(clearance)
            reynolds = gap_reynolds_number(flux, gap, viscosity)
            arguments = (pressure, temperature, downstream, k, gas_constant, viscosity)
            region = (f"{fanno_equivalent_discharge_coefficient(gap, gap_region_length(gap, radius, 3.0), *arguments):.3f}"
                      if math.isfinite(radius) else "-")
            lines.append(
                f"| {label} | {case} | {1e3 * clearance:.2f} | {f'{1e3 * radius:.2f}' if radius == radius else '-'} | "
                f"{1e3 * length:.2f} | "
                f"{length / (2 * gap):.1f} | {reynolds:.2g} | {pdsim_friction_ratio(gap, length, reynolds):.3f} | "
                f"{equivalent_discharge_coefficient(gap, length, *arguments):.3f} | "
                f"{fanno_equivalent_discharge_coefficient(gap, length, *arguments):.3f} | {region} |")
    return lines


def main() -> None:
    fluid = Fluid("R134a")
    print("| gap | pressures | c [mm] | R [mm] | L_eq [mm] | L_eq/D_h | Re | PDSim phi (unclamped) | "
          "C_d,eq friction_corrected | C_d,eq Fanno over L_eq | C_d,eq Fanno over h <= 3c |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows(fluid, valley, "valley", CASES) + rows(fluid, tip, "tip", (CHOKED,))
                    + rows(fluid, slot_face, "slot face", (CHOKED,))))


if __name__ == "__main__":
    main()
