"""Chamber thermodynamics: isentropic-nozzle flow (docs/model.md §7.4) and the
leading-chamber pressure tables p_L(phase) of Level 0 (docs/model.md §6.1) and
Level 0.5 (docs/model.md §7.5).

This package is independent of ``mechanics``: the chamber volume V(phase)
and dV/dphase are passed in by the caller (thin-vane volume of docs/model.md §6.5).
"""

from pathlib import Path

from ..kernels.compile_cache import install as _install_compile_cache

_install_compile_cache(Path(__file__).parent, __name__)       # before any kernel is defined

from .nozzle import isentropic_nozzle_mass_flow  # noqa: E402
from .pressure_tables import ideal_gas_pressure_table, polytropic_pressure_table  # noqa: E402
from .fluid import Fluid, check_operating_point  # noqa: E402
from .property_table import (Envelope, PropertyTable, describe_status, envelope_for,  # noqa: E402
                             property_table_for, table_ideal_gas_exponent, table_properties, table_status)
from .operating_point import OperatingPoint, operating_point_for  # noqa: E402

__all__ = [
    "isentropic_nozzle_mass_flow",
    "ideal_gas_pressure_table",
    "polytropic_pressure_table",
    "Fluid",
    "check_operating_point",
    "Envelope",
    "PropertyTable",
    "describe_status",
    "envelope_for",
    "property_table_for",
    "table_ideal_gas_exponent",
    "table_properties",
    "table_status",
    "OperatingPoint",
    "operating_point_for",
]
