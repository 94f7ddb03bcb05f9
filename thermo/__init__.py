"""Chamber thermodynamics: isentropic-nozzle flow (SPEC §7.4) and the
leading-chamber pressure tables p_L(phase) of Level 0 (SPEC §6.1) and
Level 0.5 (SPEC §7.5).

This package is independent of ``mechanics``: the chamber volume V(phase)
and dV/dphase are passed in by the caller (thin-vane volume of SPEC §6.5).
"""

from .nozzle import isentropic_nozzle_mass_flow
from .pressure_tables import ideal_gas_pressure_table, polytropic_pressure_table

__all__ = [
    "isentropic_nozzle_mass_flow",
    "ideal_gas_pressure_table",
    "polytropic_pressure_table",
]
