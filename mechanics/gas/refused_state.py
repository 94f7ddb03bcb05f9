"""Which chamber state of a failed step attempt left the fluid property table, and how (docs/model.md §7.3).

When the tables refuse a state, the step is rejected and retried smaller; a run stops only when the refusal
persists down to the smallest step. The state of the last accepted step is then inside the tables: the state
that left them is the failed attempt's. The compiled loop keeps the node states of the last refused evaluation
in the flow network's working values (thermo.flow_paths.note_refused); `refused_state_text` turns them into a
sentence per refused node: its temperature and density, the pressure and enthalpy there from HEOS (relative to
the boundary pressures), and the bound it crossed (the table's temperature or density range, the dome, a liquid)
as thermo.property_table.describe_status and thermo.real_gas_nozzle.describe_nozzle_status word it.
"""
from __future__ import annotations

import math

from ...thermo.flow_paths import NODES
from ...thermo.fluid import Fluid
from ...thermo.property_table import describe_status, table_status
from ...thermo.real_gas_nozzle import describe_nozzle_status, table_viscosity


def exact_state_text(fluid: Fluid, temperature: float, density: float, suction_pressure: float,
                     discharge_pressure: float) -> str:
    """' (p = ... Pa = ... x discharge_pressure, h = ... J/kg from HEOS)', or why HEOS has no single-phase state."""
    try:
        exact = fluid.properties(temperature, density)
    except ValueError as error:
        return f" (HEOS: {error})"
    return (f" (from HEOS: p = {exact.pressure:.4g} Pa = {exact.pressure / discharge_pressure:.3g} x "
            f"discharge_pressure = {exact.pressure / suction_pressure:.3g} x suction_pressure, "
            f"h = {exact.enthalpy:.6g} J/kg)")


def _node_text(name, temperature, density, table, nozzles, fluid: Fluid, lobe: int, suction_pressure: float,
               discharge_pressure: float) -> str | None:
    """Why the property table or the nozzle table refuses the state of node `name`, with its exact state; None if
    both accept it."""
    where = f"{name} {'chamber' if name in ('leading', 'trailing') else 'node'} (lobe {lobe})"
    code = table_status(temperature, density, table)
    if code != 0:
        text = describe_status(code, temperature, density, table, fluid=fluid, state=where)
    else:
        nozzle_code = table_viscosity(temperature, density, nozzles)[1]          # as a nozzle's upstream state
        if nozzle_code == 0:
            return None
        text = describe_nozzle_status(nozzle_code, temperature, density, nozzles, fluid=fluid, state=where)
    return text + exact_state_text(fluid, temperature, density, suction_pressure, discharge_pressure)


def refused_state_text(work, accepted, table, nozzles, fluid: Fluid, lobe: int, suction_pressure: float,
                       discharge_pressure: float) -> str:
    """'; in the failed step attempt at t = ...: <node>: <why>' for every node of the last refused evaluation
    (`work`: the flow network's working values) that the property table or the nozzle table refuses; if no
    evaluation was refused (the stop came from the valley switch), '; <chamber>: <why>' for each refused state of
    `accepted`, the (name, T, rho) of the chambers at the last accepted step."""
    time = float(work["refused_time"])
    if math.isfinite(time):
        states = [(name, work["refused_temperature"][node], work["refused_density"][node])
                  for node, name in enumerate(NODES)]
        head = f"; in the failed step attempt at t = {time:.9g} s: "
    else:
        states, head = accepted, "; "
    parts = [_node_text(name, float(temperature), float(density), table, nozzles, fluid, lobe, suction_pressure,
                        discharge_pressure) for name, temperature, density in states]
    parts = [part for part in parts if part is not None]
    return head + "; ".join(parts) if parts else ""
