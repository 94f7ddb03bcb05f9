"""The compressor's parameters, declared once (docs/model.md §9).

Each field of :class:`CompressorParameters` carries its SI unit, default (docs/model.md §9), allowed range and a
description in its metadata. The simulation validates against these declarations, and the FMU and the README's
parameter table are generated from them. Choices (the displacement law, the integrator, ...) are string fields
whose allowed values are listed in the metadata.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, field
from typing import Any

from ..thermo.choices import Choices
from ..thermo.fluid import UnknownFluidError
from ..thermo.leakage import LEAKAGE_LAWS
from ..thermo.operating_point import operating_point_for

from .contact.contact_laws import FRICTION_MODELS, STIFFNESS_MODELS
from .geometry.displacement import DISPLACEMENT_LAWS
from .geometry.stator import check_stator_regularity

# a choice is declared as a thermo.choices.Choices next to the kernel that branches on its code; these two are
# read by the time loop through mechanics.loop.machine
INTEGRATORS = Choices("dopri5", "abm4", "ark548")
PRESSURE_MODELS = Choices("polytropic", "ideal_gas_table", "real_gas")


def _number(default, unit, minimum, maximum, description, *, integer=False):
    """A numeric parameter with its unit, allowed closed range [minimum, maximum] and description."""
    return field(default=default, metadata=dict(
        unit=unit, min=minimum, max=maximum, integer=integer,
        description=description))


def _fluid(default, description):
    """A CoolProp fluid name (a free string, checked against CoolProp's list)."""
    return field(default=default, metadata=dict(unit="", fluid=True, description=description))


def _choice(default, choices, description):
    """A parameter that takes one of a fixed set of string values (a thermo.choices.Choices)."""
    return field(default=default, metadata=dict(unit="", choices=choices, description=description))


@dataclass(frozen=True)
class CompressorParameters:
    """All parameters of one compressor run, SI units, defaults of docs/model.md §9."""

    # geometry (docs/model.md §2)
    lobes: int = _number(3, "1", 2, 12, "number of stator lobes z (compression cycles per revolution)",
                         integer=True)
    displacement_law: str = _choice("harmonic", DISPLACEMENT_LAWS,
                                    "vane-tip-centre displacement law s(theta) of docs/model.md §2.3")
    stroke: float = _number(5.0e-3, "m", 0.1e-3, 20e-3, "vane stroke h = lobe height")
    bottom_dwell: float = _number(0.0, "rad", 0.0, 1.0, "bottom (valley) dwell angle beta0, harmonic_dwell law only")
    top_dwell: float = _number(0.0, "rad", 0.0, 1.0, "top dwell angle beta1, harmonic_dwell law only")
    rotor_radius: float = _number(30.0e-3, "m", 5e-3, 0.2, "rotor radius R_r")
    vane_thickness: float = _number(4.0e-3, "m", 0.5e-3, 20e-3, "vane thickness t (tip radius is t/2)")
    vane_length: float = _number(18.0e-3, "m", 2e-3, 0.2, "vane length l_v from bottom face to tip apex")
    axial_length: float = _number(55.0e-3, "m", 1e-3, 0.5, "axial length L of rotor, vane and stator")
    slot_bottom_radius: float = _number(9.5e-3, "m", 0.0, 0.2, "radius r_sb of the slot bottom")
    edge_radius: float = _number(1.0e-3, "m", 2e-4, 10e-3, "effective radius r_e of slot edges and vane corners")
    slot_clearance: float = _number(0.0, "m", 0.0, 1e-3, "total (diametral) vane-slot clearance c_R = w - t")
    stator_clearance: float = _number(0.0, "m", 0.0, 1e-3, "radial vane-stator clearance c_S (also the valley gap)")
    # materials and contact (docs/model.md §5)
    # no vane material is lighter than the polymers (PEEK 1300, phenolic 1400, carbon-graphite 1700 kg/m3); lighter
    # vanes made every time constant against the contacts shorter and stalled the sweep (docs/model.md §13.4)
    vane_density: float = _number(7850.0, "kg/m3", 1000.0, 25000.0, "vane material density")
    rotor_inertia: float = _number(5.5e-4, "kg.m2", 0.0, 10.0, "rotor moment of inertia J2 about its axis")
    youngs_modulus: float = _number(207e9, "Pa", 1e10, 1e12, "Young's modulus of all bodies")
    poisson_ratio: float = _number(0.30, "1", 0.0, 0.5, "Poisson's ratio of all bodies")
    restitution: float = _number(0.9, "1", 0.1, 1.0, "coefficient of restitution c_e of the Lankarani-Nikravesh law")
    # the numerical settings of the contact laws are declared where a revolution stays tractable (docs/model.md §13.4,
    # §11.5): below 0.1 mm/s the damping c_d = 0.75 (1 - c_e^2) F / v_floor and below 10 um/s the friction slope
    # 3 mu F / v_0 give the vane time constants of nanoseconds that held the sweep's explicit steps at 1e-9..1e-11 s,
    # and below 1 mm/s the steps of a revolution grow as 1/v_floor; a floor above 1 m/s (above the impact velocities
    # it should leave alone) takes the damping out of every impact
    onset_velocity_floor: float = _number(0.01, "m/s", 1e-3, 1.0, "floor v_floor on the stored impact velocity")
    stiffness_model: str = _choice("hertz_point", STIFFNESS_MODELS,
                                   "contact stiffness: Hertz point contact (option P) or Johnson line contact (L)")
    friction_model: str = _choice("threlfall", FRICTION_MODELS, "regularised Coulomb friction law of docs/model.md §5.3")
    friction_coefficient: float = _number(0.085, "1", 0.0, 0.5, "Coulomb friction coefficient mu, all contacts")
    friction_velocity: float = _number(1e-3, "m/s", 1e-5, 1.0, "regularisation velocity v_0 of the friction law")
    friction_velocity_full: float = _number(1e-3, "m/s", 1e-5, 1.0,
                                            "velocity v_1 of full sliding friction (ambrosio law only)")
    # gas (docs/model.md §6-§7)
    pressure_model: str = _choice("real_gas", PRESSURE_MODELS,
                                  "chamber gas: Level 0 polytropic table, Level 0.5 ideal-gas table, or Level 1 "
                                  "real-gas chambers coupled to the vane (docs/model.md §6.1, §7)")
    fluid: str = _fluid("R134a", "working fluid, any pure or pseudo-pure CoolProp fluid name (real_gas only)")
    suction_pressure: float = _number(0.2928e6, "Pa", 1e3, 20e6, "suction pressure p_s")
    suction_temperature: float = _number(283.15, "K", 150.0, 600.0, "suction temperature T_s")
    discharge_pressure: float = _number(1.3179e6, "Pa", 1e3, 40e6, "discharge (and back-chamber) pressure p_d")
    polytropic_exponent: float = _number(1.10, "1", 1.0, 2.0, "polytropic exponent n_p of the Level 0 model")
    suction_close_angle: float = _number(math.radians(10.0), "rad", 0.0, 1.0,
                                         "lobe phase phi_sc at which the leading chamber closes to suction")
    dead_volume: float = _number(0.05e-6, "m3", 1e-9, 1e-3, "dead volume V_dead of the leading chamber")
    suction_port_area: float = _number(30e-6, "m2", 1e-7, 1e-2, "suction port area A_s (real_gas only; the port "
                                       "spans lobe phases [0, suction_close_angle])")
    suction_port_coefficient: float = _number(0.7, "1", 0.1, 1.0, "discharge coefficient of the suction port")
    discharge_port_area: float = _number(20e-6, "m2", 1e-7, 1e-2, "discharge port area A_d")
    discharge_port_coefficient: float = _number(0.7, "1", 0.1, 1.0, "discharge coefficient of the discharge port")
    # leakage paths (docs/model.md §7.4): each with its law (real_gas; Level 0.5 has the end-valley seal only, as
    # "nozzle" or "sealed") and the discharge coefficient its "nozzle" law uses
    end_valley_leak_law: str = _choice("nozzle", LEAKAGE_LAWS, "leakage law of the end-valley seal c_S L, leading "
                                       "chamber <-> idle lobe ahead (docs/model.md §7.4)")
    end_valley_leak_coefficient: float = _number(0.65, "1", 0.0, 1.0, "discharge coefficient of the end-valley seal "
                                                 "under the nozzle law")
    start_valley_leak_law: str = _choice("nozzle", LEAKAGE_LAWS, "leakage law of the start-valley seal c_S L, "
                                         "trailing chamber <-> idle lobe behind (real_gas only)")
    start_valley_leak_coefficient: float = _number(0.65, "1", 0.0, 1.0, "discharge coefficient of the start-valley "
                                                   "seal under the nozzle law")
    tip_leak_law: str = _choice("nozzle", LEAKAGE_LAWS, "leakage law of the tip gap (lift-off x L), leading <-> "
                                "trailing chamber (real_gas only)")
    tip_leak_coefficient: float = _number(0.65, "1", 0.0, 1.0, "discharge coefficient of the tip gap under the "
                                          "nozzle law")
    slot_leak_law: str = _choice("sealed", LEAKAGE_LAWS, "leakage law of the gaps between the vane's side faces "
                                 "and the slot walls, back chamber <-> leading and trailing chamber (real_gas only; "
                                 "sealed: an oil-sealed slot)")
    slot_leak_coefficient: float = _number(0.65, "1", 0.0, 1.0, "discharge coefficient of the slot side-face gaps "
                                           "under the nozzle law")
    heat_capacity_ratio: float = _number(1.10, "1", 1.01, 2.0, "ideal-gas heat capacity ratio k (Level 0.5)")
    gas_constant: float = _number(81.5, "J/(kg.K)", 1.0, 5000.0, "specific gas constant R (Level 0.5)")
    # numerics (docs/model.md §8)
    integrator: str = _choice("dopri5", INTEGRATORS,
                              "time integrator: adaptive Dormand-Prince 5(4), the thesis's ABM4 PECE, or the "
                              "additive Runge-Kutta ARK5(4)8L[2]SA with the chamber states implicit")
    relative_tolerance: float = _number(3e-5, "1", 1e-10, 1e-3,
                                        "relative error tolerance rtol (docs/model.md §8.2: the default is the "
                                        "cheapest that keeps the per-revolution figures at their accuracy; the "
                                        "reference setting is 1e-6)")
    tolerance_scale: float = _number(1.0, "1", 1e-3, 10.0,
                                     "factor on all absolute tolerances of docs/model.md §8.2 (positions 1e-9 m, ...)")
    initial_step: float = _number(1e-6, "s", 1e-10, 2e-4, "first step size h_0")
    max_step: float = _number(2e-5, "s", 1e-8, 2e-4, "largest step h_max")
    mode_dwell_time: float = _number(10e-6, "s", 0.0, 1e-2, "minimum cumulative dwell tau_min of a counted mode")

    def __post_init__(self):
        validate(self)
        for name, _, meta in declarations():          # numpy scalars in, plain Python numbers stored
            if is_numeric(meta):
                value = getattr(self, name)
                object.__setattr__(self, name, int(value) if meta["integer"] else float(value))

    def replace(self, **changes) -> "CompressorParameters":
        """A copy with some values changed (validated)."""
        return dataclasses.replace(self, **changes)

    # derived quantities used everywhere ------------------------------------------------------------
    @property
    def tip_radius(self) -> float:
        """Tip semicircle radius rho = t/2 (docs/model.md §2.1)."""
        return 0.5 * self.vane_thickness

    @property
    def base_radius(self) -> float:
        """Tip-centre radius at zero stroke, R0 = R_r - rho (docs/model.md §2.3)."""
        return self.rotor_radius - self.tip_radius

    @property
    def slot_width(self) -> float:
        """Slot width w = t + c_R (docs/model.md §2.2)."""
        return self.vane_thickness + self.slot_clearance

    @property
    def mouth_radius(self) -> float:
        """Radius of the slot-mouth edges R_m = sqrt(R_r^2 - (w/2)^2) (docs/model.md §2.2)."""
        return math.sqrt(self.rotor_radius ** 2 - (0.5 * self.slot_width) ** 2)

    @property
    def envelope_offset(self) -> float:
        """Offset d = rho + c_S of the stator from the pitch curve (docs/model.md §2.5)."""
        return self.tip_radius + self.stator_clearance


# The tight setting of docs/model.md §8.2 that validation runs use where they need it (the defaults are the cheapest
# setting that keeps the per-revolution figures within their accuracy bounds, benchmarks/bench_tolerances.py).
REFERENCE_NUMERICS = dict(relative_tolerance=1e-6, max_step=2e-5)


def is_numeric(metadata: dict[str, Any]) -> bool:
    """True for a number parameter, False for a string one (a choice or a fluid name)."""
    return "choices" not in metadata and not metadata.get("fluid")


def declarations():
    """(name, default, metadata) for every parameter, in declaration order."""
    return [(f.name, f.default, dict(f.metadata)) for f in dataclasses.fields(CompressorParameters)]


def allowed_range_text(metadata: dict[str, Any]) -> str:
    """Human-readable allowed range of one parameter, e.g. '[0, 0.001] m' or 'one of harmonic, cycloidal'."""
    if "choices" in metadata:
        return metadata["choices"].allowed()
    if metadata.get("fluid"):
        return "a CoolProp fluid name"
    kind = "integer in " if metadata["integer"] else ""
    unit = "" if metadata["unit"] == "1" else metadata["unit"]
    return f"{kind}[{metadata['min']:g}, {metadata['max']:g}] {unit}".rstrip()


def short_repr(value, limit: int = 80) -> str:
    """repr(value), cut to `limit` characters: a message never echoes a long bad value in full."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def _reject(name, value, allowed):
    raise ValueError(f"parameter '{name}' = {short_repr(value)} is out of range: allowed {allowed}")


def _validate_declared_ranges(params: CompressorParameters) -> None:
    for name, _, meta in declarations():
        value = getattr(params, name)
        allowed = allowed_range_text(meta)
        if "choices" in meta:
            if value not in meta["choices"]:
                _reject(name, value, allowed)
            continue
        if meta.get("fluid"):                             # its CoolProp check: _validate_relations
            if not isinstance(value, str) or not value:
                _reject(name, value, allowed)
            continue
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            _reject(name, value, allowed)
        if meta["integer"] and int(value) != value:
            _reject(name, value, allowed)
        if not math.isfinite(value):
            _reject(name, value, allowed)
        if not meta["min"] <= value <= meta["max"]:
            _reject(name, value, allowed)


OPERATING_POINT = ("suction_pressure", "suction_temperature", "discharge_pressure")


def _validate_relations(params: CompressorParameters) -> None:
    """Conditions that involve several parameters (each message names the parameter to change)."""
    p = params
    if p.discharge_pressure <= p.suction_pressure:
        _reject("discharge_pressure", p.discharge_pressure,
                f"greater than suction_pressure = {p.suction_pressure:g} Pa")
    if p.pressure_model == "real_gas":       # CoolProp's checks, or a cached point that passed them (no import)
        try:
            operating_point_for(p.fluid, p.suction_pressure, p.suction_temperature, p.discharge_pressure)
        except UnknownFluidError as error:
            raise ValueError(f"parameter 'fluid' = {short_repr(p.fluid)} is not valid: "
                             f"{str(error).replace(repr(p.fluid), short_repr(p.fluid))}") from None
        except ValueError as error:       # the operating point or the compression from it leaves the fluid's range
            text = str(error)
            name = next((n for n in OPERATING_POINT if text.startswith(n)), "discharge_pressure")
            if text.startswith("temperature="):
                text = "the table of the compression from suction to discharge pressure reaches " + text
            raise ValueError(f"parameter '{name}' = {getattr(p, name):g} is out of range for {p.fluid} at "
                             + ", ".join(f"{n} = {getattr(p, n):g}" for n in OPERATING_POINT if n != name)
                             + f": {text}") from None
    if p.pressure_model == "ideal_gas_table" and p.end_valley_leak_law == "friction_corrected":
        _reject("end_valley_leak_law", p.end_valley_leak_law,
                "nozzle or sealed with pressure_model 'ideal_gas_table' (the friction-corrected law needs the "
                "fluid's viscosity: pressure_model 'real_gas')")
    if p.initial_step > p.max_step:
        _reject("initial_step", p.initial_step, f"<= max_step = {p.max_step:g} s")
    if p.stroke >= p.base_radius:
        _reject("stroke", p.stroke, f"< rotor_radius - vane_thickness/2 = {p.base_radius:g} m")
    if p.slot_width >= p.rotor_radius:
        _reject("vane_thickness", p.vane_thickness, f"slot width t + c_R < rotor_radius = {p.rotor_radius:g} m")
    if p.friction_model == "ambrosio" and p.friction_velocity >= p.friction_velocity_full:
        _reject("friction_velocity_full", p.friction_velocity_full,
                f"greater than friction_velocity = {p.friction_velocity:g} m/s for the ambrosio law")
    lobe = 2 * math.pi / p.lobes
    if p.suction_close_angle > lobe:
        _reject("suction_close_angle", p.suction_close_angle,
                f"<= 2 pi / lobes = {lobe:g} rad (the suction port closes inside the lobe)")
    if p.displacement_law == "harmonic_dwell":
        free = 2 * math.pi / p.lobes - p.bottom_dwell - p.top_dwell
        if free <= 0.0:
            _reject("bottom_dwell", p.bottom_dwell,
                    f"bottom_dwell + top_dwell < 2 pi / lobes = {2 * math.pi / p.lobes:g} rad")
    # the vane: straight part must stay engaged in the slot by at least one thickness at full stroke,
    # and never reach the slot bottom at zero stroke (docs/model.md §2.1, §4.3)
    straight_length = p.vane_length - p.tip_radius
    bottom_radius_at_full_stroke = p.base_radius + p.stroke - straight_length
    shortest = p.base_radius + p.stroke - p.mouth_radius + p.vane_thickness + p.tip_radius
    if bottom_radius_at_full_stroke > p.mouth_radius - p.vane_thickness:
        if p.vane_length == _declared("vane_length")[0] and p.stroke != _declared("stroke")[0]:
            longest_stroke = p.mouth_radius - p.vane_thickness + straight_length - p.base_radius
            _reject("stroke", p.stroke, f"<= {longest_stroke:g} m (at least one vane thickness of the vane_length = "
                                        f"{p.vane_length:g} m engaged in the slot at full stroke)")
        _reject("vane_length", p.vane_length,
                f">= {shortest:g} m (at least one vane thickness engaged in the slot at full stroke "
                f"{p.stroke:g} m)")
    bottom_radius_at_rest = p.base_radius - straight_length
    if bottom_radius_at_rest <= p.slot_bottom_radius:
        # name the parameter that was changed: a long vane_length makes any slot_bottom_radius impossible
        longest = p.base_radius - p.slot_bottom_radius + p.tip_radius
        default, meta = _declared("slot_bottom_radius")
        if bottom_radius_at_rest <= meta["min"] or p.slot_bottom_radius == default:
            _reject("vane_length", p.vane_length,
                    f"< {longest:g} m (the vane bottom at zero stroke must clear the slot bottom at slot_bottom_radius "
                    f"= {p.slot_bottom_radius:g} m)")
        _reject("slot_bottom_radius", p.slot_bottom_radius,
                f"< {bottom_radius_at_rest:g} m (the vane bottom at zero stroke, with vane_length = "
                f"{p.vane_length:g} m, must clear the slot bottom)")


def _lobe_angle(values) -> float:
    return 2.0 * math.pi / values["lobes"]


def _thickest_vane(values) -> float:
    """t + c_R < R_r, and room for the shortest declared stroke: R_m - t > h_lo, i.e. (t + h_lo)^2 + (t + c_R)^2/4
    < R_r^2, a quadratic in t."""
    radius, clearance = values["rotor_radius"], values["slot_clearance"]
    shortest_stroke = _declared("stroke")[1]["min"]
    a, b = 1.25, 2.0 * shortest_stroke + 0.5 * clearance
    c = shortest_stroke ** 2 + 0.25 * clearance ** 2 - radius ** 2
    return min(radius - clearance, (-b + math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a))


def _mouth_radius(values) -> float:
    """R_m = sqrt(R_r^2 - (w/2)^2) of drawn values (CompressorParameters.mouth_radius)."""
    return math.sqrt(values["rotor_radius"] ** 2 - (0.5 * (values["vane_thickness"] + values["slot_clearance"])) ** 2)


def _longest_stroke(values) -> float:
    """stroke < R0 (the valley) and stroke < R_m - t (a vane long enough to stay engaged must clear r_sb >= 0)."""
    return min(values["rotor_radius"] - 0.5 * values["vane_thickness"],
               _mouth_radius(values) - values["vane_thickness"])


def _vane_length_range(values) -> tuple:
    """[one thickness engaged at full stroke, R_r): R0 + h - (l_v - rho) <= R_m - t, and below R_r the vane bottom
    at rest clears some r_sb >= 0."""
    return values["rotor_radius"] + values["stroke"] - _mouth_radius(values) + values["vane_thickness"], \
        values["rotor_radius"]


# The range the relations of `_validate_relations` leave one parameter once those it depends on are known, in an
# order in which each comes after the ones it depends on: (name, bounds(values) -> (low, high) for a number, None
# for either end at its declaration; or the allowed choices). A sampler draws the other parameters over their
# declared ranges, then these in this order within their bounds, and so lands in the valid region without
# rejection except for the relations with no closed form: the stator regularity (mechanics.geometry.stator) and the
# fluid's range (CoolProp). tests/mechanics/test_parameters.py checks each bound against validation.
RELATION_BOUNDS = (
    ("discharge_pressure", lambda v: (math.nextafter(v["suction_pressure"], math.inf), None)),
    ("end_valley_leak_law", lambda v: tuple(law for law in LEAKAGE_LAWS if law != "friction_corrected"
                                            or v["pressure_model"] != "ideal_gas_table")),
    ("initial_step", lambda v: (None, v["max_step"])),
    ("vane_thickness", lambda v: (None, _thickest_vane(v))),
    ("stroke", lambda v: (None, _longest_stroke(v))),
    ("vane_length", _vane_length_range),
    ("slot_bottom_radius", lambda v: (None, v["rotor_radius"] - v["vane_length"])),
    ("friction_velocity_full", lambda v: (v["friction_velocity"], None) if v["friction_model"] == "ambrosio"
     else (None, None)),
    ("suction_close_angle", lambda v: (None, _lobe_angle(v))),
    ("bottom_dwell", lambda v: (None, _lobe_angle(v)) if v["displacement_law"] == "harmonic_dwell" else (None, None)),
    ("top_dwell", lambda v: (None, _lobe_angle(v) - v["bottom_dwell"]) if v["displacement_law"] == "harmonic_dwell"
     else (None, None)),
)


def _declared(name: str):
    """(default, metadata) of one parameter."""
    return next((default, meta) for field_name, default, meta in declarations() if field_name == name)


def validate(params: CompressorParameters) -> None:
    """Raise ValueError naming the parameter, its value and the allowed range, for any invalid value.

    The stator regularity condition 1 + d kappa_C > 0 (docs/model.md §2.5) is checked by the geometry module.
    """
    _validate_declared_ranges(params)
    _validate_relations(params)
    check_stator_regularity(params)


def markdown_table() -> str:
    """The parameter table of the README, generated from the declarations."""
    lines = ["| parameter | default | unit | allowed | description |", "|---|---|---|---|---|"]
    for name, default, meta in declarations():
        unit = meta["unit"] or "-"
        shown = f"`{default}`" if isinstance(default, str) else f"{default:g}"
        lines.append(f"| `{name}` | {shown} | {unit} | {allowed_range_text(meta)} | {meta['description']} |")
    return "\n".join(lines)
