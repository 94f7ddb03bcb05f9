"""Print the equivalent discharge coefficient table of the leakage laws (docs/flow_paths_draft.md; docs/model.md §7.4).

Run from anywhere:  python docs/flow_paths_table.py

The default machine (docs/model.md §9: R_r = 30 mm, tip radius 2 mm, harmonic law, h = 5 mm, z = 3), R134a between
p_s = 0.2928 MPa (T_s = 283.15 K) and p_d = 1.3179 MPa. The upstream gas lies on the suction isentrope (CoolProp),
k = c_p0/(c_p0 - R) at T_s and R = 8314.462/M as Level 1 uses them, mu from CoolProp at the upstream state.
For each stator clearance c the valley seal radius, its friction-equivalent length L_eq, the Reynolds number of
the ideal-gas nozzle flux, PDSim's unclamped ratio phi and the equivalent C_d of
  - "friction_corrected" (1/max(1, phi)),
  - the Fanno-channel reference over L_eq, and over the length where the gap is below 3 c,
for three pressure differences: the valley leak from the discharge state to suction (choked), from mid-compression
to suction, and a small difference near discharge (pr = 0.9). The tip gap (vane tip against the stator) closes
the table.
"""
from __future__ import annotations

import math

from rotary_vane.thermo.fluid import Fluid, coolprop
from rotary_vane.thermo.leakage import (equivalent_discharge_coefficient, equivalent_gap_radius,
                                        fanno_equivalent_discharge_coefficient, friction_length,
                                        gap_region_length, gap_reynolds_number, harmonic_valley_seal_radius,
                                        pdsim_friction_ratio)
from rotary_vane.thermo.nozzle import isentropic_nozzle_mass_flow

SUCTION_PRESSURE, SUCTION_TEMPERATURE, DISCHARGE_PRESSURE = 0.2928e6, 283.15, 1.3179e6
ROTOR_RADIUS, TIP_RADIUS, STROKE, LOBES = 0.030, 0.002, 0.005, 3
CLEARANCES = (0.02e-3, 0.05e-3, 0.1e-3, 0.2e-3)
CASES = (("p_d -> p_s (pr 0.22, choked)", DISCHARGE_PRESSURE, SUCTION_PRESSURE),
         ("0.6 MPa -> p_s (pr 0.49, choked)", 0.6e6, SUCTION_PRESSURE),
         ("p_d -> 0.9 p_d (pr 0.90)", DISCHARGE_PRESSURE, 0.9 * DISCHARGE_PRESSURE))


def upstream_state(fluid: Fluid, pressure):
    """(T, mu) on the suction isentrope at p."""
    entropy = fluid.properties(SUCTION_TEMPERATURE, fluid.density(SUCTION_TEMPERATURE, SUCTION_PRESSURE)).entropy
    temperature = fluid.state_at_pressure_entropy(pressure, entropy).temperature
    state = coolprop().AbstractState("HEOS", fluid.name)
    state.update(coolprop().PT_INPUTS, pressure, temperature)
    return temperature, state.viscosity()


def rows(fluid: Fluid, gap_radius_of, label):
    k, gas_constant = fluid.ideal_gas_exponent(SUCTION_TEMPERATURE), fluid.gas_constant
    lines = []
    for case, pressure, downstream in CASES:
        temperature, viscosity = upstream_state(fluid, pressure)
        flux = isentropic_nozzle_mass_flow(1.0, 1.0, pressure, temperature, downstream, k, gas_constant)
        for clearance in CLEARANCES:
            radius = gap_radius_of(clearance)
            length = friction_length(clearance, radius)
            reynolds = gap_reynolds_number(flux, clearance, viscosity)
            arguments = (pressure, temperature, downstream, k, gas_constant, viscosity)
            lines.append(
                f"| {label} | {case} | {1e3 * clearance:.2f} | {1e3 * radius:.2f} | {1e3 * length:.2f} | "
                f"{length / (2 * clearance):.1f} | {reynolds:.2g} | "
                f"{pdsim_friction_ratio(clearance, length, reynolds):.3f} | "
                f"{equivalent_discharge_coefficient(clearance, length, *arguments):.3f} | "
                f"{fanno_equivalent_discharge_coefficient(clearance, length, *arguments):.3f} | "
                f"{fanno_equivalent_discharge_coefficient(clearance, gap_region_length(clearance, radius, 3.0), *arguments):.3f} |")
    return lines


def main() -> None:
    fluid = Fluid("R134a")
    print("| gap | pressures | c [mm] | R [mm] | L_eq [mm] | L_eq/D_h | Re | PDSim phi (unclamped) | "
          "C_d,eq friction_corrected | C_d,eq Fanno over L_eq | C_d,eq Fanno over h <= 3c |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    valley = rows(fluid, lambda c: harmonic_valley_seal_radius(ROTOR_RADIUS, TIP_RADIUS, STROKE, LOBES, c), "valley")
    # tip gap: the vane tip (convex, radius t/2) against the concave stator, whose radius of curvature 1/kappa_C + d
    # is at least 19.62 + 2 mm for z = 3 (docs/model.md §2.5): R between 2.0 and 2.2 mm; the table takes 2.2 mm.
    tip = rows(fluid, lambda c: equivalent_gap_radius(TIP_RADIUS, 19.62e-3 + TIP_RADIUS), "tip")
    print("\n".join(valley + [line for line in tip if "choked)" in line and "p_d" in line]))


if __name__ == "__main__":
    main()
