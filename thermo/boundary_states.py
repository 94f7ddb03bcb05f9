"""The boundary states of a real-gas run from the property table alone, so that the suction and discharge
conditions can move during a run without CoolProp (docs/model.md §7.4, "Boundary states that move").

A run's two boundary nodes (thermo.flow_paths: "suction", "back") are

    suction node   (T_s, rho_s) at the suction pressure p_s and either the suction temperature T_s (a gas state) or
                   the suction enthalpy h_s (any state the table holds: superheated gas or an equilibrium mixture
                   of quality x < 1 inside the dome of a two-phase table)
    back node      (T_2s, rho_2s) at the discharge pressure p_d on the suction isentrope, h_2s = h(p_d, s_s): the
                   discharge plenum and the back chamber (docs/model.md §7.4)

Inversions (all on the table's interpolant, thermo.property_table, in the variables T and x = ln rho):

    rho at (T, p):   Newton on ln p(T, x) = ln p with d ln p/dx = rho (dp/drho)_T / p (nearly linear for a gas)
    (T, rho) at (p, h): Newton on (p, h)(T, x) with the Jacobian from the table's derivatives,
                     dh/dT|_rho = c_v + (dp/dT)_rho / rho,   dh/dx|_T = (dp/drho)_T - T (dp/dT)_rho / rho
                     (the thermodynamic identity; it holds for the equilibrium mixture too, where (dp/drho)_T = 0)

Each Newton solve starts from a guess (the caller's previous boundary state); a (p, h) solve that fails from it
is retried along a continuation from the guess's own (p, h) to the target in 2, 4, ... 64 equal parts.

Isentrope: along s = const, dh = dp/rho, so h_2s = h_s + int_{ln p_s}^{ln p_d} p/rho(p, h) d(ln p), integrated with
the classical Runge-Kutta rule in ISENTROPE_STEPS equal steps of ln p, each stage's rho from the (p, h) inversion.
Measured for R134a on the fluid-wide table (tests/thermo/test_boundary_states.py): h_2s within 4e-10 relative of
CoolProp's h(p_d, s_s), T_2s within 3e-7 K, rho_s within 3e-9, over the declared input range and for wet suction
states.

Status codes: STATUS_OK (0), or the property table's code of the state that stopped a solve, or
STATUS_NOT_CONVERGED; `describe_boundary_status` names the input.
"""
from __future__ import annotations

import math

from ..kernels.kernel import kernel
from .property_table import (STATUS_DENSITY_ABOVE_TABLE, STATUS_DENSITY_BELOW_TABLE, STATUS_INACCURATE_CELL,
                             STATUS_INVALID_STATE, STATUS_LIQUID, STATUS_NEAR_SATURATION, STATUS_OK,
                             STATUS_TEMPERATURE_ABOVE_TABLE, STATUS_TEMPERATURE_BELOW_TABLE, table_from_arrays,
                             table_state)

NEWTON_ITERATIONS = 40
NEWTON_TOLERANCE = 1e-12            # relative, on p and h (and on the step in T and ln rho)
CONTINUATION_LEVELS = 7             # continuation in 2^1 ... 2^6 parts after a failed direct solve
ISENTROPE_STEPS = 24                # RK4 steps in ln p from p_s to p_d
STATUS_NOT_CONVERGED = 20           # beyond the table's codes (thermo.property_table)


@kernel
def _density_newton(temperature, pressure, density, table):
    """(rho, status): Newton on ln p(T, ln rho) = ln pressure from `density`; nearly linear for a gas (p ~ rho),
    so it converges from far guesses, with the step held to 1 in ln rho."""
    log_density = math.log(density)
    target = math.log(pressure)
    for _ in range(NEWTON_ITERATIONS):
        state = table_state(temperature, math.exp(log_density), table)
        if state.status != STATUS_OK:
            return math.nan, state.status
        slope = state.pressure_density_derivative * math.exp(log_density) / state.pressure
        if not slope > 0.0:                               # the flat dome: no gas state at this (T, p)
            return math.nan, STATUS_NOT_CONVERGED
        residual = math.log(state.pressure) - target
        step = max(-1.0, min(1.0, residual / slope))
        log_density -= step
        if abs(residual) <= NEWTON_TOLERANCE and abs(step) < 1e-10:
            return math.exp(log_density), STATUS_OK
    return math.nan, STATUS_NOT_CONVERGED


@kernel
def gas_density(temperature, pressure, guess, table):
    """(rho [kg/m^3], status) of the gas at (T [K], p [Pa]) on the table, by Newton from the density `guess`
    (module docstring); STATUS_NOT_CONVERGED where no gas state is there (inside the dome)."""
    return _density_newton(temperature, pressure, guess, table)


@kernel
def _pressure_enthalpy_newton(pressure, enthalpy, temperature, density, table):
    """(T, rho, status): 2-D Newton on (p, h)(T, ln rho) = (pressure, enthalpy) from (temperature, density)."""
    log_density = math.log(density)
    scale = max(abs(enthalpy), 1e5)            # J/kg: h's zero is the fluid's reference state
    for _ in range(NEWTON_ITERATIONS):
        rho = math.exp(log_density)
        state = table_state(temperature, rho, table)
        if state.status != STATUS_OK:
            return math.nan, math.nan, state.status
        p_t = state.pressure_temperature_derivative
        p_x = state.pressure_density_derivative * rho
        h_t = state.heat_capacity_v + p_t / rho
        h_x = state.pressure_density_derivative - temperature * p_t / rho
        f = state.pressure - pressure
        g = state.enthalpy - enthalpy
        determinant = p_t * h_x - p_x * h_t
        if not (determinant != 0.0 and math.isfinite(determinant)):
            return math.nan, math.nan, STATUS_NOT_CONVERGED
        d_temperature = (f * h_x - p_x * g) / determinant
        d_log_density = (p_t * g - h_t * f) / determinant
        d_temperature = max(-0.2 * temperature, min(0.2 * temperature, d_temperature))   # damped far away
        d_log_density = max(-1.0, min(1.0, d_log_density))
        temperature -= d_temperature
        log_density -= d_log_density
        if (abs(f) <= NEWTON_TOLERANCE * pressure and abs(g) <= NEWTON_TOLERANCE * scale
                and abs(d_temperature) < 1e-9 and abs(d_log_density) < 1e-11):
            return temperature, math.exp(log_density), STATUS_OK
    return math.nan, math.nan, STATUS_NOT_CONVERGED


@kernel
def state_at_pressure_enthalpy(pressure, enthalpy, temperature, density, table):
    """(T, rho, status) at (p [Pa], h [J/kg]) on the table, from the guess (temperature, density) (module
    docstring: Newton, then a continuation from the guess's own (p, h) if Newton fails)."""
    result = _pressure_enthalpy_newton(pressure, enthalpy, temperature, density, table)
    if result[2] == STATUS_OK:
        return result
    start = table_state(temperature, density, table)
    if start.status != STATUS_OK:
        return result
    for level in range(1, CONTINUATION_LEVELS):
        parts = 1 << level
        t, rho, status = temperature, density, STATUS_OK
        for k in range(1, parts + 1):
            w = k / parts
            t, rho, status = _pressure_enthalpy_newton(start.pressure + w * (pressure - start.pressure),
                                                       start.enthalpy + w * (enthalpy - start.enthalpy), t, rho,
                                                       table)
            if status != STATUS_OK:
                break
        if status == STATUS_OK:
            return t, rho, status
    return result


@kernel
def isentropic_state(pressure, enthalpy, temperature, density, end_pressure, table):
    """(T, rho, h, status) at `end_pressure` on the isentrope through the state (p, h) = (pressure, enthalpy) whose
    (T, rho) is (temperature, density) (module docstring: RK4 in ln p on dh/d(ln p) = p/rho)."""
    step = (math.log(end_pressure) - math.log(pressure)) / ISENTROPE_STEPS
    u = math.log(pressure)
    h = enthalpy
    t, rho = temperature, density
    last = 0.0
    for _ in range(ISENTROPE_STEPS):
        slopes = 0.0
        for stage in range(4):
            offset = 0.0 if stage == 0 else 0.5 if stage < 3 else 1.0
            weight = 1.0 if stage == 0 or stage == 3 else 2.0
            if stage == 0:
                stage_enthalpy = h
            elif stage < 3:
                stage_enthalpy = h + 0.5 * step * last
            else:
                stage_enthalpy = h + step * last
            p = math.exp(u + offset * step)
            t, rho, status = state_at_pressure_enthalpy(p, stage_enthalpy, t, rho, table)
            if status != STATUS_OK:
                return math.nan, math.nan, math.nan, status
            last = p / rho
            slopes += weight * last
        u += step
        h += step * slopes / 6.0
    t, rho, status = state_at_pressure_enthalpy(end_pressure, h, t, rho, table)
    return t, rho, h, status


SUCTION_STATE, DISCHARGE_STATE = 1, 2          # which node a failed solve concerns


@kernel(allocates=True)
def boundary_states(suction_pressure, suction_value, by_enthalpy, discharge_pressure, guess_temperature,
                    guess_density, scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes):
    """(T_s, rho_s, h_s, T_2s, rho_2s, h_2s, status, which node failed) of the boundary (module docstring) on the
    table given as thermo.property_table.table_arrays; `suction_value` is T_s [K], or h_s [J/kg] if `by_enthalpy`;
    (guess_temperature, guess_density) a nearby suction state."""
    table = table_from_arrays(scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes)
    if by_enthalpy:
        temperature, density, status = state_at_pressure_enthalpy(suction_pressure, suction_value,
                                                                  guess_temperature, guess_density, table)
    else:
        temperature = suction_value
        density, status = _density_newton(temperature, suction_pressure, guess_density, table)
    if status != STATUS_OK:
        return math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, status, SUCTION_STATE
    suction = table_state(temperature, density, table)
    if suction.status != STATUS_OK:
        return math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, suction.status, SUCTION_STATE
    back_temperature, back_density, back_enthalpy, status = isentropic_state(
        suction_pressure, suction.enthalpy, temperature, density, discharge_pressure, table)
    if status != STATUS_OK:
        return temperature, density, suction.enthalpy, math.nan, math.nan, math.nan, status, DISCHARGE_STATE
    return (temperature, density, suction.enthalpy, back_temperature, back_density, back_enthalpy, STATUS_OK,
            0)


@kernel(allocates=True)
def temperature_at_pressure_enthalpy(pressure, enthalpy, guess_temperature, guess_density, scalars, nodes,
                                     dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes):
    """T [K] at (p, h) on the table given as thermo.property_table.table_arrays (`state_at_pressure_enthalpy`
    from the guess); NaN if the table refuses it."""
    table = table_from_arrays(scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes)
    return state_at_pressure_enthalpy(pressure, enthalpy, guess_temperature, guess_density, table)[0]


STATUS_TEXT = {
    STATUS_INVALID_STATE: "not a physical state",
    STATUS_TEMPERATURE_BELOW_TABLE: "colder than the property table reaches",
    STATUS_TEMPERATURE_ABOVE_TABLE: "hotter than the property table reaches",
    STATUS_DENSITY_BELOW_TABLE: "thinner than the property table reaches",
    STATUS_DENSITY_ABOVE_TABLE: "denser than the property table reaches",
    STATUS_NEAR_SATURATION: "inside the two-phase dome or within the superheat margin of it, which this table "
                            "does not take",
    STATUS_INACCURATE_CELL: "in a table cell that failed its accuracy check (near the critical point)",
    STATUS_LIQUID: "a liquid (denser than the saturated liquid)",
    STATUS_NOT_CONVERGED: "not found on the table (no gas state there: a temperature at or below the dew point of "
                          "the pressure, or a state beyond the table's reach)",
}


def describe_boundary_status(status: int) -> str:
    """What a status of `boundary_states` says of the state it concerns."""
    return "the state is " + STATUS_TEXT.get(int(status), f"refused (status {int(status)})")
