"""FMI variables with units, display units and ranges, and the unit definitions they refer to.

pythonfmu 0.7.0 writes bare `<Real/>` elements; `RealVariable` and `IntegerVariable` add unit, displayUnit, min,
max and nominal, and `unit_definitions` writes the `<UnitDefinitions>` block with SI base-unit exponents
(FMI 2.0 §2.2.2). Parameters of the compressor are generated from `mechanics.parameters.declarations()`.
"""
from __future__ import annotations

import math
from xml.etree.ElementTree import Element, SubElement

from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Variability
from pythonfmu.variables import Integer, Real, String

# unit -> (SI base-unit exponents, factor to SI); display units: unit -> [(name, factor, offset)]
UNITS = {
    "1": ({}, 1.0), "m": ({"m": 1}, 1.0), "m2": ({"m": 2}, 1.0), "m3": ({"m": 3}, 1.0), "s": ({"s": 1}, 1.0),
    "rad": ({"rad": 1}, 1.0), "K": ({"K": 1}, 1.0), "kg/m3": ({"kg": 1, "m": -3}, 1.0),
    "kg.m2": ({"kg": 1, "m": 2}, 1.0), "Pa": ({"kg": 1, "m": -1, "s": -2}, 1.0),
    "N": ({"kg": 1, "m": 1, "s": -2}, 1.0), "N.m": ({"kg": 1, "m": 2, "s": -2}, 1.0),
    "J": ({"kg": 1, "m": 2, "s": -2}, 1.0), "W": ({"kg": 1, "m": 2, "s": -3}, 1.0),
    "m/s": ({"m": 1, "s": -1}, 1.0), "m/s2": ({"m": 1, "s": -2}, 1.0), "rad/s": ({"rad": 1, "s": -1}, 1.0),
    "J/(kg.K)": ({"m": 2, "s": -2, "K": -1}, 1.0), "kg/s": ({"kg": 1, "s": -1}, 1.0),
    "rpm": ({"rad": 1, "s": -1}, 2.0 * math.pi / 60.0), "V": ({"kg": 1, "m": 2, "s": -3, "A": -1}, 1.0),
    "A": ({"A": 1}, 1.0), "Ohm": ({"kg": 1, "m": 2, "s": -3, "A": -2}, 1.0),
    "H": ({"kg": 1, "m": 2, "s": -2, "A": -2}, 1.0), "N.m/A": ({"kg": 1, "m": 2, "s": -2, "A": -1}, 1.0),
    "Hz": ({"s": -1}, 1.0), "J/kg": ({"m": 2, "s": -2}, 1.0), "kg": ({"kg": 1}, 1.0),
    "W/K": ({"kg": 1, "m": 2, "s": -3, "K": -1}, 1.0),
}
DISPLAY_UNITS = {
    "m": [("mm", 1e3, 0.0)], "rad": [("deg", 180.0 / math.pi, 0.0)], "Pa": [("bar", 1e-5, 0.0)],
    "K": [("degC", 1.0, -273.15)], "rad/s": [("rpm", 60.0 / (2.0 * math.pi), 0.0)], "W": [("kW", 1e-3, 0.0)],
    "m2": [("mm2", 1e6, 0.0)], "m3": [("cm3", 1e6, 0.0)],
}
DEFAULT_DISPLAY_UNIT = {unit: options[0][0] for unit, options in DISPLAY_UNITS.items()}


def unit_definitions(units_used) -> Element:
    """<UnitDefinitions> for the given unit names, with base-unit exponents and display units."""
    block = Element("UnitDefinitions")
    for name in sorted(units_used):
        exponents, factor = UNITS[name]
        unit = SubElement(block, "Unit", name=name)
        base = {key: str(value) for key, value in exponents.items()}
        if factor != 1.0:
            base["factor"] = repr(factor)
        SubElement(unit, "BaseUnit", base)
        for display, display_factor, offset in DISPLAY_UNITS.get(name, []):
            attributes = {"name": display, "factor": repr(display_factor)}
            if offset:
                attributes["offset"] = repr(offset)
            SubElement(unit, "DisplayUnit", attributes)
    return block


class RealVariable(Real):
    """A Real with unit, display unit, min, max and nominal in the modelDescription."""

    def __init__(self, name, unit, *, minimum=None, maximum=None, nominal=None, **kwargs):
        if unit not in UNITS:
            raise ValueError(f"unit {unit!r} of variable {name!r} has no definition in fmu_src.variables.UNITS")
        super().__init__(name, **kwargs)
        self.unit = unit
        self.limits = dict(min=minimum, max=maximum, nominal=nominal)

    def to_xml(self) -> Element:
        node = super().to_xml()
        real = node.find("Real")
        real.set("unit", self.unit)
        if self.unit in DEFAULT_DISPLAY_UNIT:
            real.set("displayUnit", DEFAULT_DISPLAY_UNIT[self.unit])
        for key, value in self.limits.items():
            if value is not None:
                real.set(key, f"{value:.16g}")
        return node


class IntegerVariable(Integer):
    """An Integer with min and max in the modelDescription."""

    def __init__(self, name, *, minimum=None, maximum=None, **kwargs):
        super().__init__(name, **kwargs)
        self.limits = dict(min=minimum, max=maximum)

    def to_xml(self) -> Element:
        node = super().to_xml()
        integer = node.find("Integer")
        for key, value in self.limits.items():
            if value is not None:
                integer.set(key, str(int(value)))
        return node


def output(name, unit, description, getter):
    """A continuous Real output computed in do_step, read through `getter`."""
    return RealVariable(name, unit, causality=Fmi2Causality.output, variability=Fmi2Variability.continuous,
                        description=description, getter=getter)


def integer_output(name, description, getter=None):
    """A discrete Integer output computed in do_step (read through `getter` if given)."""
    return IntegerVariable(name, causality=Fmi2Causality.output, variability=Fmi2Variability.discrete,
                           description=description, getter=getter)


def parameter(name, unit, description, minimum=None, maximum=None):
    """A fixed Real parameter with its range."""
    return RealVariable(name, unit, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                        initial=Fmi2Initial.exact, description=description, minimum=minimum, maximum=maximum)


def declared_parameter(name, metadata):
    """The FMI parameter of one declaration of `mechanics.parameters` (type, unit, range, description)."""
    description = metadata["description"]
    if "choices" in metadata:
        return String(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                      initial=Fmi2Initial.exact, description=f"{description} (one of {', '.join(metadata['choices'])})")
    if metadata.get("fluid"):
        return String(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                      initial=Fmi2Initial.exact, description=description)
    if metadata["integer"]:
        return IntegerVariable(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                               initial=Fmi2Initial.exact, description=description, minimum=metadata["min"],
                               maximum=metadata["max"])
    return parameter(name, metadata["unit"], description, metadata["min"], metadata["max"])
