"""Suction and discharge conditions that move during a run (docs/model.md §7.4, "Boundary states that move").

A real-gas run on its fluid's fluid-wide tables (thermo.fluid_envelope; mechanics.gas.gas_coupling) holds its
boundary nodes in the chamber model's constants record: the suction node (the suction plenum and the idle lobes)
and the back node (discharge plenum and back chamber, p_d on the suction isentrope). `solve_boundary` validates a
new boundary and solves its nodes on the property table (thermo.boundary_states, no CoolProp); `hold_boundary`
writes them into the record, which the compiled loop reads at each evaluation, so the new boundary is held from
the current time on; `ramp_boundary` moves them linearly over an advance instead (an input interpolated over a
step, as the speed: docs/model.md §7.3.3). The pressure-table models (Level 0/0.5), and a real-gas run on the tables of one operating
point, take no other boundary than their parameters': a changed value is refused by name.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from ...thermo.boundary_states import describe_boundary_status, temperature_at_pressure_enthalpy
from ...thermo.flow_paths import FlowNode
from ...thermo.gas_reference import GasReference
from ...thermo.real_gas_nozzle import (STATUS_THROAT_NEAR_SATURATION, describe_nozzle_status,
                                       nozzle_table_from_arrays, real_gas_mass_flux)

from .gas_coupling import boundary_nodes_of

SUCTION_FIELDS = ("suction_temperature", "suction_density", "suction_pressure", "suction_enthalpy")
BACK_FIELDS = ("discharge_temperature", "discharge_density", "discharge_pressure", "discharge_enthalpy")


class Boundary(NamedTuple):
    """The boundary nodes a run holds (thermo.flow_paths.FlowNode)."""
    suction: FlowNode
    back: FlowNode


def boundary_of(chambers) -> Boundary:
    """The boundary nodes of the chamber model's constants record."""
    return Boundary(FlowNode(*(float(chambers[name][0]) for name in SUCTION_FIELDS)),
                    FlowNode(*(float(chambers[name][0]) for name in BACK_FIELDS)))


def hold_boundary(gas, nodes: Boundary) -> None:
    """Write the nodes into the constants record the compiled loop reads (in place: the loop's argument), held."""
    ramp_boundary(gas, nodes, nodes, 0.0, 0.0)


def ramp_boundary(gas, start: Boundary, end: Boundary, start_time: float, duration: float) -> None:
    """Move the nodes linearly from `start` at `start_time` to `end` at `start_time + duration` [s], held after
    it (thermo.chamber_model.boundary_nodes; duration 0: `end` held)."""
    for names, begin, node in ((SUCTION_FIELDS, start.suction, end.suction), (BACK_FIELDS, start.back, end.back)):
        for name, first, value in zip(names, begin, node):
            gas.chambers[name][0] = value
            gas.chambers[f"{name}_from"][0] = first
    gas.chambers["ramp_start"][0] = start_time
    gas.chambers["ramp_duration"][0] = duration


def ramp_duration(chambers) -> float:
    """The duration [s] of the last ramp the record holds (0: the nodes are held)."""
    return float(chambers["ramp_duration"][0])


def _refuse(name, value, unit, allowed):
    raise ValueError(f"input '{name}' = {value!r} {unit} is out of range: allowed {allowed}")


def _number(name, value, unit):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0.0:
        _refuse(name, value, unit, "a finite number > 0")
    return float(value)


def _check_fixed(params, values: dict) -> None:
    """A run without fluid-wide tables takes only its parameters' boundary."""
    for name, value in values.items():
        if name == "suction_enthalpy" or value != getattr(params, name):
            fixed = getattr(params, name, None)
            allowed = (f"{fixed!r} (the parameter's value)" if fixed is not None else
                       "no value (give the suction state by suction_temperature)")
            reason = ("the pressure table of pressure_model " + repr(params.pressure_model) + " is built for one "
                      "operating point" if params.pressure_model != "real_gas" else
                      f"the property tables of this run cover its operating point only ({params.fluid} at these "
                      "parameters has no fluid-wide tables, thermo.fluid_envelope)")
            _refuse(name, value, "Pa" if "pressure" in name else "K" if "temperature" in name else "J/kg",
                    f"{allowed}: {reason}")


def _check_range(inputs, values: dict) -> None:
    """The declared input range of the fluid-wide tables (thermo.fluid_envelope.input_range), with the suction
    pressure allowed up to the largest discharge pressure: the pressures equalised at standstill lie above the
    evaporating range, and the states they make are inside the tables (which the solve checks)."""
    p_s = values["suction_pressure"]
    if not inputs.suction_pressure_min <= p_s <= inputs.discharge_pressure_max:
        _refuse("suction_pressure", p_s, "Pa", f"[{inputs.suction_pressure_min:.6g}, "
                                               f"{inputs.discharge_pressure_max:.6g}] Pa (the fluid's tables)")
    if not values["discharge_pressure"] <= inputs.discharge_pressure_max:
        _refuse("discharge_pressure", values["discharge_pressure"], "Pa",
                f"(0, {inputs.discharge_pressure_max:.6g}] Pa (the fluid's tables)")
    temperature = values.get("suction_temperature")
    if temperature is not None and not temperature <= inputs.suction_temperature_max:
        _refuse("suction_temperature", temperature, "K", f"<= {inputs.suction_temperature_max:.6g} K (the fluid's "
                                                         "tables)")


def _check_nozzle_inlet(gas, name, value, unit, node: FlowNode, where):
    """A boundary state the nozzle table refuses as the inlet of a flow path (thermo.real_gas_nozzle)."""
    nozzles = nozzle_table_from_arrays(*gas.nozzles)
    status = real_gas_mass_flux(node.temperature, node.density, node.pressure, 0.5 * node.pressure, nozzles)[1]
    if status not in (0, STATUS_THROAT_NEAR_SATURATION):
        _refuse(name, value, unit, "a state the nozzle table takes: " + describe_nozzle_status(
            status, node.temperature, node.density, nozzles, state=where))


def solve_boundary(params, gas, current: Boundary, suction_pressure, discharge_pressure, suction_temperature=None,
                   suction_enthalpy=None) -> Boundary | None:
    """The boundary nodes of (p_s, T_s or h_s, p_d), or None if they are the current ones; ValueError naming the
    input for a value the run cannot take: not a finite number > 0, both or neither of T_s and h_s, a change of
    a run without fluid-wide tables, outside the fluid's declared input range, or a state the tables refuse."""
    if (suction_temperature is None) == (suction_enthalpy is None):
        raise ValueError("the suction state needs exactly one of 'suction_temperature' and 'suction_enthalpy'")
    values = {"suction_pressure": _number("suction_pressure", suction_pressure, "Pa"),
              "discharge_pressure": _number("discharge_pressure", discharge_pressure, "Pa")}
    by_enthalpy = suction_enthalpy is not None
    if by_enthalpy:
        if isinstance(suction_enthalpy, bool) or not isinstance(suction_enthalpy, (int, float)) \
                or not math.isfinite(suction_enthalpy):
            _refuse("suction_enthalpy", suction_enthalpy, "J/kg", "a finite number")
        values["suction_enthalpy"] = float(suction_enthalpy)
        state_name, state_unit = "suction_enthalpy", "J/kg"
    else:
        values["suction_temperature"] = _number("suction_temperature", suction_temperature, "K")
        state_name, state_unit = "suction_temperature", "K"
    if gas.input_range is None:
        _check_fixed(params, values)
        return None
    _check_range(gas.input_range, values)
    same_state = (current.suction.enthalpy == values["suction_enthalpy"] if by_enthalpy else
                  current.suction.temperature == values["suction_temperature"])
    if same_state and (current.suction.pressure, current.back.pressure) == (values["suction_pressure"],
                                                                            values["discharge_pressure"]):
        return None
    suction, back, status, which = boundary_nodes_of(values["suction_pressure"], values[state_name], by_enthalpy,
                                                     values["discharge_pressure"], current.suction, gas.properties)
    if status != 0:
        name, unit = (state_name, state_unit) if which == 1 else ("discharge_pressure", "Pa")
        where = (f"the suction state at suction_pressure = {values['suction_pressure']:.6g} Pa" if which == 1 else
                 "the discharge plenum on the suction isentrope")
        _refuse(name, values[name], unit, f"a state inside the {params.fluid} property table; {where}: "
                                          f"{describe_boundary_status(status)}")
    _check_nozzle_inlet(gas, state_name, values[state_name], state_unit, suction, "suction state")
    if params.slot_leak_law != "sealed":
        _check_nozzle_inlet(gas, "discharge_pressure", values["discharge_pressure"], "Pa", back,
                            "back chamber (p_d on the suction isentrope)")
    return Boundary(suction, back)


def moved_reference(reference: GasReference, gas, nodes: Boundary) -> GasReference:
    """The figures' references at the new boundary (thermo.gas_reference): rho_s and h_1 of the suction node, h_2s
    of the back node, T(p_d, h) on the property table."""
    back = nodes.back

    def discharge_temperature(enthalpy):
        return float(temperature_at_pressure_enthalpy(back.pressure, float(enthalpy), back.temperature,
                                                      back.density, *gas.properties))
    return GasReference(reference.point, reference.displacement,
                        (nodes.suction.density, nodes.suction.enthalpy, back.enthalpy, discharge_temperature))
