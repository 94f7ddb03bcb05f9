"""Every quantity the time loop reports, declared once (docs/model.md §8.4, §12).

`STEP_OUTPUTS` lists the columns of one output row, the values the kernel writes at each accepted step: the
history's columns, the CSV columns of the studies and, where `fmu` names it, an FMU output (its value at the end
of the communication step). `FIGURES` lists the per-window figures (a lobe, a revolution) computed from the
kernel's window records (mechanics.loop.windows, mechanics.performance); those with an `fmu` name are FMU outputs over
the last completed revolution. From these two lists follow the kernel's index layout `O` (numba reads it as a
constant: `out[O.driving_torque]`), the FMU variables (fmu_src.compressor), and the output tables of the README
and docs/model.md (docs/make_tables.py). Adding an output is one declaration here plus the line of the kernel
that computes it.

A declaration with `per_region=True` stands for one column per contact region, `<name>_1` ... `<name>_<n>`, and its
layout entry is the index of the first (`out[O.normal_force + region]`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from ..contact.regions import REGION_COUNT, REGION_LABELS, SLOT_REGIONS, TIP_REGIONS, labels_of

STEP = "step"
REVOLUTION = "revolution"
ALL_MODELS = ("polytropic", "ideal_gas_table", "real_gas")
REAL_GAS = ("real_gas",)


@dataclass(frozen=True)
class Output:
    """One reported quantity: name (history column), SI unit, description, which pressure models fill it (NaN
    under the others), and the FMU output variable it becomes (None: library and CSV only)."""
    name: str
    unit: str
    description: str
    models: tuple = ALL_MODELS
    fmu: str | None = None
    per_region: bool = False

    def columns(self) -> tuple[str, ...]:
        """The history columns of this declaration."""
        if self.per_region:
            return tuple(f"{self.name}_{k}" for k in range(1, REGION_COUNT + 1))
        return (self.name,)


def _region_text(description: str) -> str:
    return f"{description} (one column per contact region {REGION_LABELS[0]}-{REGION_LABELS[-1]})"


STEP_OUTPUTS = (
    Output("time", "s", "model time of the accepted step"),
    Output("rotor_angle", "rad", "rotor angle theta"),
    Output("rotor_speed", "rad/s", "rotor angular speed omega"),
    Output("rotor_acceleration", "rad/s2", "rotor angular acceleration"),
    Output("vane_displacement", "m", "vane radial displacement s_r (docs/model.md §3.4)", fmu="vane_displacement"),
    Output("vane_radial_velocity", "m/s", "vane radial velocity v_r (docs/model.md §3.4)", fmu="vane_velocity"),
    Output("vane_radial_acceleration", "m/s2", "vane radial acceleration a_r (docs/model.md §3.4)",
           fmu="vane_acceleration"),
    Output("vane_tangential_velocity", "m/s", "vane tangential velocity v_theta (docs/model.md §3.4)",
           fmu="vane_tangential_velocity"),
    Output("vane_tangential_acceleration", "m/s2", "vane tangential acceleration a_theta (docs/model.md §3.4)",
           fmu="vane_tangential_acceleration"),
    Output("vane_tilt", "rad", "vane tilt phi3 - theta", fmu="vane_tilt"),
    Output("normal_force", "N", _region_text("normal contact force F_n"), fmu="contact_force", per_region=True),
    Output("friction_force", "N", _region_text("friction force mu_eff F_n"), per_region=True),
    Output("penetration", "m", _region_text("signed penetration delta (> 0 in contact; NaN: no candidate)"),
           per_region=True),
    Output("penetration_rate", "m/s", _region_text("penetration rate"), per_region=True),
    Output("contact_mode", "1", "bit mask of the regions in contact (bit k-1 for region ck)"),
    Output("mouth_candidate_1", "1", "slot-mouth candidate type of c1 (docs/model.md §4.2: 0 none, 1 edge on "
                                     "face, 2 edge on tip arc, 3 tip on wall)"),
    Output("mouth_candidate_2", "1", "slot-mouth candidate type of c2"),
    Output("stator_force_x", "N", "contact force of the vane on the stator, x"),
    Output("stator_force_y", "N", "contact force of the vane on the stator, y"),
    Output("stator_contact_moment", "N.m", "stator reaction moment of the contact forces lambda3"),
    Output("stator_gas_moment", "N.m", "moment of the chamber pressures on the stator (docs/model.md §6.2)"),
    Output("stator_reaction_moment", "N.m", "stator reaction moment: contact + gas", fmu="stator_reaction_moment"),
    Output("gap_moment", "N.m", "pressure moment on the gaps no body carries (docs/model.md §6.2, a diagnostic)"),
    Output("rotor_force_x", "N", "contact force of the vane on the rotor, x"),
    Output("rotor_force_y", "N", "contact force of the vane on the rotor, y"),
    Output("driving_torque", "N.m", "driving torque on the rotor T_d = -lambda6", fmu="shaft_torque"),
    Output("input_power", "W", "shaft input power T_d omega"),
    Output("output_power", "W", "gas power on the vane and the rotor -P_gas"),
    Output("friction_power", "W", "friction power, all contacts"),
    Output("damping_power", "W", "contact damping power, all contacts"),
    Output("indicated_power", "W", "p dV power on the gas of all chambers, -sum p dV/dt over the leading, trailing "
                                   "and back chambers (docs/model.md §6.4)"),
    Output("gap_power", "W", "power of the chamber pressures on the sweep of the open gaps (output power minus "
                             "indicated power, docs/model.md §6.4)"),
    Output("leading_pressure", "Pa", "leading-chamber pressure", fmu="leading_chamber_pressure"),
    Output("trailing_pressure", "Pa", "trailing-chamber pressure", fmu="trailing_chamber_pressure"),
    Output("kinetic_energy", "J", "kinetic energy of the vane"),
    Output("contact_energy", "J", "elastic energy stored in the contacts"),
    Output("contact_law_excess", "m", "largest penetration beyond a force law's validity limit (docs/model.md §5.2)"),
    Output("contact_angle", "rad", "tip contact angle psi_c (docs/model.md §2.6)"),
    Output("closest_parameter_offset", "rad", "u* minus the polar angle of the tip centre (warm start)"),
    Output("lobe_count", "1", "valley crossings so far"),
    Output("work_in", "J", "cumulative shaft work W_in"),
    Output("work_out", "J", "cumulative gas work on the vane and the rotor W_out"),
    Output("work_friction", "J", "cumulative friction work"),
    Output("work_damping", "J", "cumulative contact damping work"),
    Output("work_elastic", "J", "cumulative work of the elastic contact forces, integral of sum F_el delta_dot "
                                "(docs/model.md §6.4)"),
    Output("work_indicated", "J", "cumulative indicated work on the gas of all chambers W_ind, integral of "
                                  "indicated_power (docs/model.md §6.4)"),
    Output("work_gap", "J", "cumulative work on the sweep of the open gaps W_gap, integral of gap_power "
                            "(docs/model.md §6.4)"),
    Output("leading_volume", "m3", "leading-chamber volume with the dead volume (docs/model.md §7.2)"),
    Output("trailing_volume", "m3", "trailing-chamber volume with the dead volume (docs/model.md §7.2)"),
    Output("back_volume", "m3", "back-chamber volume: the slot below the vane's bottom face (docs/model.md §7.2)"),
    Output("leading_temperature", "K", "leading-chamber temperature", REAL_GAS),
    Output("trailing_temperature", "K", "trailing-chamber temperature", REAL_GAS),
    Output("leading_quality", "1", "leading-chamber vapour quality (1 for a gas; below 1 an equilibrium mixture "
                                   "inside the dome, docs/model.md §7.3.1)", REAL_GAS, fmu="leading_chamber_quality"),
    Output("trailing_quality", "1", "trailing-chamber vapour quality (as leading_quality)", REAL_GAS,
           fmu="trailing_chamber_quality"),
    Output("chamber_mass", "kg", "gas mass in the two chambers", REAL_GAS),
    Output("chamber_internal_energy", "J", "internal energy of the gas in the two chambers", REAL_GAS),
    Output("suction_mass_flow", "kg/s", "mass flow through the suction port into both chambers", REAL_GAS),
    Output("discharge_mass_flow", "kg/s", "mass flow through the discharge valve", REAL_GAS),
    Output("tip_leak_mass_flow", "kg/s", "tip-gap leak, leading -> trailing chamber", REAL_GAS),
    Output("end_valley_leak_mass_flow", "kg/s", "end-valley seal leak, leading chamber -> idle lobe ahead "
           "(docs/model.md §7.4)", REAL_GAS),
    Output("start_valley_leak_mass_flow", "kg/s", "start-valley seal leak, trailing chamber -> idle lobe behind",
           REAL_GAS),
    Output("slot_leak_leading_mass_flow", "kg/s", "slot side-face leak, back chamber -> leading chamber", REAL_GAS),
    Output("slot_leak_trailing_mass_flow", "kg/s", "slot side-face leak, back chamber -> trailing chamber",
           REAL_GAS),
    Output("metastable_flow_paths", "1", "flow paths whose isentropic throat is the metastable gas-branch "
           "continuation within 1 K of the two-phase dome (nozzle status 8, docs/model.md §7.4)", REAL_GAS),
    Output("mass_suction", "kg", "cumulative net mass from the suction side", REAL_GAS),
    Output("mass_discharge", "kg", "cumulative mass through the discharge valve", REAL_GAS),
    Output("energy_suction", "J", "cumulative energy from the suction side", REAL_GAS),
    Output("energy_discharge", "J", "cumulative enthalpy through the discharge valve", REAL_GAS),
    Output("work_chambers", "J", "cumulative p dV work on the two chambers", REAL_GAS),
    Output("mass_back_chamber", "kg", "cumulative net mass from the back chamber (slot side faces)", REAL_GAS),
    Output("energy_back_chamber", "J", "cumulative energy from the back chamber (slot side faces)", REAL_GAS),
)


def _columns(declarations) -> tuple[str, ...]:
    return tuple(column for output in declarations for column in output.columns())


OUTPUT_NAMES = _columns(STEP_OUTPUTS)
OUTPUT_INDEX = {name: i for i, name in enumerate(OUTPUT_NAMES)}
OUTPUT_SIZE = len(OUTPUT_NAMES)
REAL_GAS_COLUMNS = tuple(c for output in STEP_OUTPUTS if output.models == REAL_GAS for c in output.columns())


def index_layout(declarations=STEP_OUTPUTS):
    """A named tuple of column indices, one field per declaration (per-region ones: the first column)."""
    names = [output.name for output in declarations]
    layout = NamedTuple("OutputLayout", [(name, int) for name in names])
    index, position = [], 0
    for output in declarations:
        index.append(position)
        position += len(output.columns())
    return layout(*index)


O = index_layout()


@dataclass(frozen=True)
class Figure:
    """One per-window figure (a lobe or a revolution, docs/model.md §6.4): name (WindowSummary attribute), SI
    unit, description, pressure models that define it, and the FMU output over the last completed revolution."""
    name: str
    unit: str
    description: str
    models: tuple = ALL_MODELS
    fmu: str | None = None


FIGURES = (
    Figure("input_power", "W", "mean shaft input power <P_in>", fmu="input_power"),
    Figure("output_power", "W", "mean gas power on the vane and the rotor <P_out> (docs/model.md §6.4)",
           fmu="output_power"),
    Figure("friction_power", "W", "mean friction power", fmu="friction_power"),
    Figure("damping_power", "W", "mean contact-damping power", fmu="damping_power"),
    Figure("mechanical_efficiency", "1", "output power / input power", fmu="mechanical_efficiency"),
    Figure("energy_residual", "1", "mechanical energy balance residual / shaft work (docs/model.md §6.4)"),
    Figure("indicated_power", "W", "mean p dV power on the gas of all chambers (docs/model.md §6.4)",
           fmu="indicated_power"),
    Figure("gap_power", "W", "mean power on the sweep of the open gaps (docs/model.md §6.4)", fmu="gap_power"),
    Figure("storage_power", "W", "change of the kinetic energy of vane and rotor and of the contact energy / "
                                 "duration"),
    Figure("contact_switch_power", "W", "power the contact laws exchange where a stiffness changes in a closed "
                                        "contact (a slot-mouth candidate switch, the stator curvature under the "
                                        "tip): elastic-force work minus the change of the stored contact energy, "
                                        "/ duration (docs/model.md §6.4)"),
    Figure("ledger_residual", "1", "energy ledger residual: (shaft work - indicated - gap - friction - damping - "
                                   "stored - stiffness switches) / shaft work (docs/model.md §6.4)",
           fmu="energy_ledger_residual"),
    Figure("driving_torque", "N.m", "mean driving torque: shaft work / angle turned"),
    Figure("stator_torque", "N.m", "time mean of the stator reaction moment"),
    Figure("gap_torque", "N.m", "time mean of the gap moment"),
    Figure("max_contact_force", "N", "largest normal force of any region", fmu="max_contact_force"),
    Figure("max_slot_force", "N", f"largest normal force of the regions on the rotor, {labels_of(SLOT_REGIONS)} (slot "
           "wear)", fmu="max_slot_force"),
    Figure("max_tip_force", "N", f"largest normal force of the regions on the stator, {labels_of(TIP_REGIONS)} (tip "
           "wear)", fmu="max_tip_force"),
    Figure("mode_count", "1", "distinct contact modes, a mode being the set of touching regions (docs/model.md "
                              "§4.6)", fmu="revolution_mode_count"),
    Figure("mode_count_extended", "1", "distinct contact modes, a mode being the set of touching regions and the "
                                       "slot-mouth candidate type of c1 and c2 (docs/model.md §4.6)",
           fmu="revolution_mode_count_extended"),
    Figure("max_tilt", "rad", "largest |vane tilt|"),
    Figure("suction_mass_flow", "kg/s", "mean net mass flow drawn from the suction side", REAL_GAS,
           fmu="suction_mass_flow"),
    Figure("discharge_mass_flow", "kg/s", "mean mass flow through the discharge valve", REAL_GAS,
           fmu="discharge_mass_flow"),
    Figure("back_chamber_mass_flow", "kg/s", "mean net mass flow from the back chamber through the slot side faces "
           "(the net delivery is discharge_mass_flow minus it)", REAL_GAS),
    Figure("discharge_enthalpy", "J/kg", "mass-weighted enthalpy of the discharged gas", REAL_GAS),
    Figure("gas_mass_residual", "1", "chamber mass balance residual / delivered mass", REAL_GAS),
    Figure("gas_energy_residual", "1", "chamber energy balance residual / chamber work", REAL_GAS),
    Figure("discharge_temperature", "K", "mixed temperature of the discharged gas at discharge pressure (NaN if "
           "none was delivered)", REAL_GAS, fmu="discharge_temperature"),
    Figure("volumetric_efficiency", "1", "delivered mass / (suction density x lobe volume x lobes)", REAL_GAS,
           fmu="volumetric_efficiency"),
    Figure("isentropic_efficiency", "1", "discharge mass flow x (h_2s - h_1) / input power", REAL_GAS,
           fmu="isentropic_efficiency"),
)
FIGURE_NAMES = tuple(figure.name for figure in FIGURES)


def markdown_table(declarations=STEP_OUTPUTS, figures=FIGURES) -> str:
    """The output tables of the README and docs/model.md: per-step columns, then per-window figures."""
    lines = ["| output | unit | per | pressure models | FMU variable | description |", "|---|---|---|---|---|---|"]
    last = REGION_COUNT
    rows = [(", ".join(f"`{c}`" for c in (o.columns() if not o.per_region else (f"{o.name}_1..{last}",))), o.unit,
             STEP, o.models, o.fmu and (f"`{o.fmu}_1..{last}`" if o.per_region else f"`{o.fmu}`"), o.description)
            for o in declarations]
    rows += [(f"`{f.name}`", f.unit, REVOLUTION, f.models, f.fmu and f"`{f.fmu}`", f.description) for f in figures]
    for name, unit, per, models, fmu, description in rows:
        scope = "all" if models == ALL_MODELS else ", ".join(models)
        lines.append(f"| {name} | {unit} | {per} | {scope} | {fmu or '-'} | {description.replace('|', '/')} |")
    return "\n".join(lines)


@dataclass(frozen=True)
class FmuOutput:
    """An FMU output variable and where its value comes from: a column of the output row at the end of the step
    (per=STEP) or a figure of the last completed revolution (per=REVOLUTION)."""
    name: str
    unit: str
    description: str
    per: str
    source: str             # history column or figure name
    models: tuple


def fmu_outputs(declarations=STEP_OUTPUTS, figures=FIGURES) -> tuple[FmuOutput, ...]:
    """The FMU outputs declared above, in declaration order: end-of-step values, then per-revolution figures."""
    step = []
    for output in declarations:
        if output.fmu is None:
            continue
        names = ([f"{output.fmu}_{k}" for k in range(1, REGION_COUNT + 1)] if output.per_region else [output.fmu])
        for name, column in zip(names, output.columns()):
            suffix = f" of region c{column.rsplit('_', 1)[1]}" if output.per_region else ""
            step.append(FmuOutput(name, output.unit, f"{output.description}{suffix} at the end of the step", STEP,
                                  column, output.models))
    revolution = [FmuOutput(f.fmu, f.unit, f"{f.description} over the last completed revolution", REVOLUTION,
                            f.name, f.models) for f in figures if f.fmu is not None]
    return tuple(step + revolution)
