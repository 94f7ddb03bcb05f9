"""The start values the shipped system files (fmu_src/systems/) give each component, read with the standard
library's XML parser: the reference the engines' read-back is compared with, independent of every engine."""
from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path

SSD = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
       "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues"}
OSP = {"osp": "http://opensimulationplatform.com/MSMI/OSPSystemStructure"}
TYPES = {"Real": float, "Integer": int, "Boolean": lambda text: text == "true", "String": str}


def typed(element) -> object:
    """The value of an <ssv:Real value=...>, <Real value=...>, ... element, as a Python value."""
    kind = element.tag.rsplit("}", 1)[-1]
    return TYPES[kind](element.get("value"))


def ssd_parameters(path: Path) -> dict[str, dict[str, object]]:
    """component -> {parameter: value} of every inline ParameterSet of an SSD (all sets, whatever their name)."""
    root = ElementTree.parse(path).getroot()
    values: dict[str, dict[str, object]] = {}
    for component in root.iterfind("ssd:System/ssd:Elements/ssd:Component", SSD):
        found = values.setdefault(component.get("name"), {})
        for parameter in component.iterfind(
                "ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues/ssv:ParameterSet/ssv:Parameters/"
                "ssv:Parameter", SSD):
            found[parameter.get("name")] = typed(parameter[0])
    return values


def ssd_parameter_set_names(path: Path) -> set[str]:
    """The names of the SSD's ParameterSets."""
    root = ElementTree.parse(path).getroot()
    return {s.get("name") for s in root.iter("{%s}ParameterSet" % SSD["ssv"])}


def osp_initial_values(path: Path) -> dict[str, dict[str, object]]:
    """simulator -> {variable: value} of an OspSystemStructure.xml's InitialValues."""
    root = ElementTree.parse(path).getroot()
    return {simulator.get("name"): {value.get("variable"): typed(value[0])
                                    for value in simulator.iterfind("osp:InitialValues/osp:InitialValue", OSP)}
            for simulator in root.iterfind("osp:Simulators/osp:Simulator", OSP)}
