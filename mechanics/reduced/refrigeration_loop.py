"""A lumped vapour-compression loop around the compressor: condenser, expansion valve, evaporator and suction line
(docs/model.md §16), its right-hand side and integrator in numba on the property table through the dome.

States y = (M_c, U_c, M_e, U_e, Q_c, Q_e, Q_sh): mass and internal energy of the condenser and the evaporator
(thermo.volume_state gives T, p and the quality of each), and the cumulative heats into the condenser, the
evaporator and the suction line. With the compressor's step exchange as constant rates over a step (drawn mass
rate m_s, drawn enthalpy rate H_s, delivered mass rate m_d, delivered enthalpy rate H_d) and the valve flow m_v at
the enthalpy h_v,in of its upstream volume's outlet (docs/model.md §16.2-16.5):

    dM_c/dt = m_d - m_v                 dU_c/dt = H_d - m_v h_v,in + UA_c (T_c,sec - T_c)
    dM_e/dt = m_v - m_s                 dU_e/dt = m_v h_v,in - H_s + m_s (h_s - h_e,out) + UA_e (T_e,sec - T_e)
    dQ_c/dt = UA_c (T_c,sec - T_c)      dQ_e/dt = UA_e (T_e,sec - T_e)    dQ_sh/dt = m_s (h_s - h_e,out)

h_s being the suction enthalpy the loop gave the compressor for the step: the evaporator gives m_s h_e,out, the
suction line heats it by Q_sh to m_s h_s, and what the compressor's drawn energy H_s differs from that (back-flow
from the chambers at their energy, docs/model.md §16.5) returns to the evaporator, the massless suction line's
upstream volume. Every exchange between the two volumes enters one and leaves the other with the same rate, and
RK4 combines the stages linearly, so M_c + M_e changes by exactly the compressor's (delivered - drawn) mass and
U_c + U_e by its (delivered - drawn) enthalpy plus the three heats, to round-off.
"""
from __future__ import annotations

import math

import numpy as np

from ...kernels.kernel import kernel
from ...thermo.boundary_states import (STATUS_NOT_CONVERGED, describe_boundary_status, gas_density,
                                        state_at_pressure_enthalpy)
from ...thermo.property_table import STATUS_OK, table_arrays, table_from_arrays, table_state
from ...thermo.volume_state import volume_state

# parameter vector (LoopParameters.vector)
(CONDENSER_VOLUME, EVAPORATOR_VOLUME, CONDENSER_UA, EVAPORATOR_UA, VALVE_KIND, VALVE_AREA, DISCHARGE_COEFFICIENT,
 STATIC_SUPERHEAT, SUPERHEAT_BAND, SUCTION_LINE_EFFECTIVENESS, SEPARATION_FILL, DRYOUT_QUALITY) = range(12)
PARAMETER_COUNT = 12
FIXED_ORIFICE, THERMOSTATIC = 0, 1
VALVE_KINDS = ("fixed_orifice", "thermostatic")
# input vector: rates held over a step
(DRAWN_RATE, DRAWN_ENTHALPY_RATE, DELIVERED_RATE, DELIVERED_ENTHALPY_RATE, CONDENSER_SECONDARY_TEMPERATURE,
 EVAPORATOR_SECONDARY_TEMPERATURE, SUCTION_ENTHALPY) = range(7)
INPUT_COUNT = 7
EXCHANGE_COUNT = 4                     # cumulative drawn mass, drawn enthalpy, delivered mass, delivered enthalpy
# state vector
CONDENSER_MASS, CONDENSER_ENERGY, EVAPORATOR_MASS, EVAPORATOR_ENERGY, CONDENSER_HEAT, EVAPORATOR_HEAT, \
    SUCTION_LINE_HEAT = range(7)
STATE_COUNT = 7

VALVE_LAMINAR_PRESSURE = 1000.0        # Pa: dp0 of the orifice law's regularisation (docs/model.md §16.3)
EMPTY_QUALITY = 0.999                  # an evaporator this dry has run empty (docs/model.md §16.2)

# loop status (the second code returned with it is the property table's, thermo.property_table)
LOOP_OK = 0
CONDENSER_STATE_FAILED = 1
EVAPORATOR_STATE_FAILED = 2
EVAPORATOR_EMPTY = 3
SUCTION_STATE_FAILED = 4


@kernel
def condenser_outlet(state, separation_fill):
    """(h, rho) of what leaves the condenser (docs/model.md §16.2): saturated liquid while liquid fills at least
    `separation_fill` of the volume, then a mixture whose quality rises to the mean quality x as the liquid fill
    phi_l = (1 - x) rho v_l falls to 0: x_out = x max(0, 1 - phi_l / separation_fill); a gas leaves as it is."""
    if state.quality >= 1.0:
        return state.enthalpy, state.density
    liquid_fill = (1.0 - state.quality) * state.density * state.liquid_volume
    quality = state.quality * max(0.0, 1.0 - liquid_fill / separation_fill)
    return (state.liquid_enthalpy + quality * (state.vapour_enthalpy - state.liquid_enthalpy),
            1.0 / (state.liquid_volume + quality * (state.vapour_volume - state.liquid_volume)))


@kernel
def evaporator_outlet(state, separation_fill):
    """(h, rho, x) of what leaves the evaporator (docs/model.md §16.2): saturated vapour while vapour fills at least
    `separation_fill` of the volume, then liquid carried over, the liquid fraction rising to the mean 1 - x as the
    vapour fill phi_v = x rho v_v falls to 0: 1 - x_out = (1 - x) max(0, 1 - phi_v / separation_fill)."""
    if state.quality >= 1.0:
        return state.enthalpy, state.density, 1.0
    vapour_fill = state.quality * state.density * state.vapour_volume
    quality = 1.0 - (1.0 - state.quality) * max(0.0, 1.0 - vapour_fill / separation_fill)
    return (state.liquid_enthalpy + quality * (state.vapour_enthalpy - state.liquid_enthalpy),
            1.0 / (state.liquid_volume + quality * (state.vapour_volume - state.liquid_volume)), quality)


@kernel
def dry_fraction(evaporator, dryout_quality):
    """Fraction d of the evaporator's surface that is dry (docs/model.md §16.2): 0 while its mean vapour quality x
    is at most the dry-out quality x_d, rising linearly to 1 at x = 1: d = clip((x - x_d)/(1 - x_d), 0, 1)."""
    return max(0.0, min(1.0, (evaporator.quality - dryout_quality) / (1.0 - dryout_quality)))


@kernel
def orifice_flow(area, discharge_coefficient, upstream_density, pressure_difference):
    """m = C_d A sqrt(2 rho_in) dp / (dp^2 + dp0^2)^(1/4) [kg/s] (docs/model.md §16.3): C_d A sqrt(2 rho_in dp)
    for |dp| >> dp0, linear in dp through dp = 0 (no infinite slope at equal pressures)."""
    return (discharge_coefficient * area * math.sqrt(2.0 * upstream_density) * pressure_difference
            / (pressure_difference * pressure_difference + VALVE_LAMINAR_PRESSURE ** 2) ** 0.25)


@kernel
def valve_opening(parameters, superheat):
    """Open fraction of the valve's area: 1 for the fixed orifice; the thermostatic valve's proportional law
    clip((SH - SH_static) / SH_band, 0, 1) (docs/model.md §16.3)."""
    if parameters[VALVE_KIND] == FIXED_ORIFICE:
        return 1.0
    return max(0.0, min(1.0, (superheat - parameters[STATIC_SUPERHEAT]) / parameters[SUPERHEAT_BAND]))


@kernel
def suction_state(evaporator, outlet_enthalpy, outlet_quality, secondary_temperature, effectiveness, table):
    """(T_s, h_s, x_s, status) at the compressor's suction (docs/model.md §16.4): the evaporator's outlet heated
    isobarically by q = h(p_e, T_e + eps (T_sec - T_e)) - h_v (0 if T_sec <= T_e), so that a dry outlet leaves at
    T_s = T_e + eps (T_sec - T_e); h_s = h_out + q, wet (x_s < 1 at T_s = T_e) if that stays below h_v."""
    temperature, pressure = evaporator.temperature, evaporator.pressure
    heated = temperature + effectiveness * (secondary_temperature - temperature)
    heat = 0.0
    heated_density = 1.0 / evaporator.vapour_volume
    if heated > temperature:
        heated_density, status = gas_density(heated, pressure, 1.0 / evaporator.vapour_volume, table)
        if status != STATUS_OK:
            return math.nan, math.nan, math.nan, status
        heat = table_state(heated, heated_density, table).enthalpy - evaporator.vapour_enthalpy
    if outlet_quality >= 1.0:
        return max(heated, temperature), outlet_enthalpy + heat, 1.0, STATUS_OK
    enthalpy = outlet_enthalpy + heat
    quality = (enthalpy - evaporator.liquid_enthalpy) / (evaporator.vapour_enthalpy - evaporator.liquid_enthalpy)
    if quality < 1.0:
        return temperature, enthalpy, quality, STATUS_OK
    suction_temperature, _, status = state_at_pressure_enthalpy(pressure, enthalpy, heated, heated_density, table)
    return suction_temperature, enthalpy, 1.0, status


@kernel
def loop_derivatives(y, parameters, inputs, guesses, table, slopes):
    """Fill `slopes` with dy/dt (module docstring) and update `guesses` (T_c, T_e) to the volumes' temperatures;
    return (LOOP_OK, 0) or (loop status, table status)."""
    condenser = volume_state(y[CONDENSER_MASS], y[CONDENSER_ENERGY], parameters[CONDENSER_VOLUME], guesses[0], table)
    if condenser.status != STATUS_OK:
        return CONDENSER_STATE_FAILED, condenser.status
    evaporator = volume_state(y[EVAPORATOR_MASS], y[EVAPORATOR_ENERGY], parameters[EVAPORATOR_VOLUME], guesses[1],
                              table)
    if evaporator.status != STATUS_OK:
        return EVAPORATOR_STATE_FAILED, evaporator.status
    if not evaporator.quality < EMPTY_QUALITY:
        return EVAPORATOR_EMPTY, 0
    guesses[0], guesses[1] = condenser.temperature, evaporator.temperature
    fill = parameters[SEPARATION_FILL]
    condenser_enthalpy, condenser_density = condenser_outlet(condenser, fill)
    evaporator_enthalpy, evaporator_density, evaporator_quality = evaporator_outlet(evaporator, fill)
    secondary = inputs[EVAPORATOR_SECONDARY_TEMPERATURE]
    dry = dry_fraction(evaporator, parameters[DRYOUT_QUALITY])
    suction = suction_state(evaporator, evaporator_enthalpy, evaporator_quality, secondary,
                            dry * parameters[SUCTION_LINE_EFFECTIVENESS], table)
    if suction[3] != STATUS_OK:
        return SUCTION_STATE_FAILED, suction[3]
    opening = valve_opening(parameters, suction[0] - evaporator.temperature)
    difference = condenser.pressure - evaporator.pressure
    upstream_enthalpy, upstream_density = condenser_enthalpy, condenser_density
    if difference < 0.0:
        upstream_enthalpy, upstream_density = evaporator_enthalpy, evaporator_density
    valve = orifice_flow(opening * parameters[VALVE_AREA], parameters[DISCHARGE_COEFFICIENT], upstream_density,
                         difference)
    condenser_heat = parameters[CONDENSER_UA] * (inputs[CONDENSER_SECONDARY_TEMPERATURE] - condenser.temperature)
    evaporator_heat = (1.0 - dry) * parameters[EVAPORATOR_UA] * (secondary - evaporator.temperature)
    drawn = inputs[DRAWN_RATE]
    slopes[CONDENSER_MASS] = inputs[DELIVERED_RATE] - valve
    slopes[CONDENSER_ENERGY] = inputs[DELIVERED_ENTHALPY_RATE] - valve * upstream_enthalpy + condenser_heat
    slopes[EVAPORATOR_MASS] = valve - drawn
    suction_line_heat = drawn * (inputs[SUCTION_ENTHALPY] - evaporator_enthalpy)
    slopes[EVAPORATOR_ENERGY] = (valve * upstream_enthalpy - inputs[DRAWN_ENTHALPY_RATE] + suction_line_heat
                                 + evaporator_heat)
    slopes[CONDENSER_HEAT] = condenser_heat
    slopes[EVAPORATOR_HEAT] = evaporator_heat
    slopes[SUCTION_LINE_HEAT] = suction_line_heat
    return LOOP_OK, 0


@kernel(allocates=True)
def advance_loop(y, step, substeps, parameters, inputs, guesses, scalars, nodes, dome_limit, accurate_cell,
                 ideal_gas_exponent, saturation_nodes):
    """(y after `step` [s] in `substeps` classical RK4 substeps with the inputs held, loop status, table status);
    `guesses` (T_c, T_e) is updated; y is returned unchanged with a status != LOOP_OK if a stage fails."""
    table = table_from_arrays(scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes)
    h = step / substeps
    state = y.copy()
    stage = np.empty(STATE_COUNT)
    k1, k2, k3, k4 = (np.empty(STATE_COUNT), np.empty(STATE_COUNT), np.empty(STATE_COUNT), np.empty(STATE_COUNT))
    for _ in range(substeps):
        status = loop_derivatives(state, parameters, inputs, guesses, table, k1)
        if status[0] == LOOP_OK:
            stage[:] = state + 0.5 * h * k1
            status = loop_derivatives(stage, parameters, inputs, guesses, table, k2)
        if status[0] == LOOP_OK:
            stage[:] = state + 0.5 * h * k2
            status = loop_derivatives(stage, parameters, inputs, guesses, table, k3)
        if status[0] == LOOP_OK:
            stage[:] = state + h * k3
            status = loop_derivatives(stage, parameters, inputs, guesses, table, k4)
        if status[0] != LOOP_OK:
            return y.copy(), status[0], status[1]
        state += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return state, LOOP_OK, 0


@kernel(allocates=True)
def loop_outputs(y, parameters, drawn_rate, secondary_temperature, guesses, scalars, nodes, dome_limit,
                 accurate_cell, ideal_gas_exponent, saturation_nodes):
    """The loop's algebraic outputs at the state y (docs/model.md §16.5), as an array: T_c, p_c, x_c, T_e, p_e, x_e,
    T_s, h_s, x_s, valve opening, valve mass flow; then (loop status, table status)."""
    table = table_from_arrays(scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes)
    values = np.full(11, np.nan)
    slopes = np.empty(STATE_COUNT)
    inputs = np.zeros(INPUT_COUNT)
    inputs[DRAWN_RATE] = drawn_rate
    inputs[EVAPORATOR_SECONDARY_TEMPERATURE] = secondary_temperature
    status = loop_derivatives(y, parameters, inputs, guesses, table, slopes)
    if status[0] != LOOP_OK:
        return values, status[0], status[1]
    condenser = volume_state(y[CONDENSER_MASS], y[CONDENSER_ENERGY], parameters[CONDENSER_VOLUME], guesses[0], table)
    evaporator = volume_state(y[EVAPORATOR_MASS], y[EVAPORATOR_ENERGY], parameters[EVAPORATOR_VOLUME], guesses[1],
                              table)
    enthalpy, _, quality = evaporator_outlet(evaporator, parameters[SEPARATION_FILL])
    suction = suction_state(evaporator, enthalpy, quality, secondary_temperature,
                            dry_fraction(evaporator, parameters[DRYOUT_QUALITY])
                            * parameters[SUCTION_LINE_EFFECTIVENESS], table)
    opening = valve_opening(parameters, suction[0] - evaporator.temperature)
    values[0], values[1], values[2] = condenser.temperature, condenser.pressure, condenser.quality
    values[3], values[4], values[5] = evaporator.temperature, evaporator.pressure, evaporator.quality
    values[6], values[7], values[8] = suction[0], suction[1], suction[2]
    values[9], values[10] = opening, slopes[EVAPORATOR_MASS] + drawn_rate
    return values, LOOP_OK, 0


@kernel(allocates=True)
def thermal_time_constant(y, parameters, guesses, scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent,
                          saturation_nodes):
    """min(M_c c_v,c / UA_c, M_e c_v,e / UA_e) [s] at the state y: the time constants of the volumes' heat exchange
    (docs/model.md §16.6); NaN if a volume's state fails."""
    table = table_from_arrays(scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes)
    condenser = volume_state(y[CONDENSER_MASS], y[CONDENSER_ENERGY], parameters[CONDENSER_VOLUME], guesses[0], table)
    evaporator = volume_state(y[EVAPORATOR_MASS], y[EVAPORATOR_ENERGY], parameters[EVAPORATOR_VOLUME], guesses[1],
                              table)
    return min(y[CONDENSER_MASS] * condenser.heat_capacity / parameters[CONDENSER_UA],
               y[EVAPORATOR_MASS] * evaporator.heat_capacity / parameters[EVAPORATOR_UA])


@kernel(allocates=True)
def standstill_state(temperature, charge, condenser_volume, evaporator_volume, scalars, nodes, dome_limit,
                     accurate_cell, ideal_gas_exponent, saturation_nodes):
    """(y, table status): the charge spread at one density over both volumes at one temperature (equal pressures,
    docs/model.md §16.6), zero cumulative heats."""
    table = table_from_arrays(scalars, nodes, dome_limit, accurate_cell, ideal_gas_exponent, saturation_nodes)
    density = charge / (condenser_volume + evaporator_volume)
    state = table_state(temperature, density, table)
    y = np.zeros(STATE_COUNT)
    if state.status != STATUS_OK:
        return y, state.status
    energy = state.enthalpy - state.pressure / density
    y[CONDENSER_MASS] = density * condenser_volume
    y[CONDENSER_ENERGY] = y[CONDENSER_MASS] * energy
    y[EVAPORATOR_MASS] = density * evaporator_volume
    y[EVAPORATOR_ENERGY] = y[EVAPORATOR_MASS] * energy
    return y, STATUS_OK


# ----------------------------------------------------------------------------------------------------------
# the loop in Python: parameters, state, and one communication step

MAX_SUBSTEP = 0.02                     # s: RK4 substep bound (docs/model.md §16.6)
THERMAL_SUBSTEP_FRACTION = 0.5         # substep / the volumes' shortest heat exchange time constant
SUBSTEP_REFINEMENTS = 3                # a failed step is retried with 4 and 16 times as many substeps
MAX_SUBSTEPS = 1_000_000               # in one communication step
OUTPUT_NAMES = ("condenser_temperature", "discharge_pressure", "condenser_quality", "evaporator_temperature",
                "suction_pressure", "evaporator_quality", "suction_temperature", "suction_enthalpy",
                "suction_quality", "valve_opening", "valve_mass_flow")
HEAT_FLOW_NAMES = ("condenser_heat_flow", "evaporator_heat_flow")   # step means
FAILURES = {
    CONDENSER_STATE_FAILED: "the condenser's state",
    EVAPORATOR_STATE_FAILED: "the evaporator's state",
    EVAPORATOR_EMPTY: f"the evaporator ran empty: its mean vapour quality exceeds {EMPTY_QUALITY:g} (next to no "
                      f"liquid left)",
    SUCTION_STATE_FAILED: "the suction state",
}


class LoopFailure(Exception):
    """The loop cannot continue: the message says which part failed and why."""


def describe_failure(loop_status: int, table_status: int) -> str:
    """A sentence for a loop status and the property table's status that came with it."""
    text = FAILURES.get(int(loop_status), f"loop status {int(loop_status)}")
    if loop_status == EVAPORATOR_EMPTY:
        return text
    if loop_status in (CONDENSER_STATE_FAILED, EVAPORATOR_STATE_FAILED) and table_status == STATUS_NOT_CONVERGED:
        return f"{text} was not found: no temperature on the property table gives its internal energy"
    return f"{text} cannot be computed: {describe_boundary_status(table_status)}"


class RefrigerationLoop:
    """The loop's state between communication steps, advanced with the compressor's cumulative exchange
    (docs/model.md §16.5). `parameters`: the vector of the PARAMETER indices; `table`: a two-phase PropertyTable."""

    def __init__(self, parameters: np.ndarray, table, standstill_temperature: float, charge: float,
                 suction_quality_min: float):
        """The loop at standstill; LoopFailure if that state is not on the table or already floods the
        compressor."""
        self.parameters = np.asarray(parameters, dtype=float)
        self.arrays = table_arrays(table)
        self.suction_quality_min = suction_quality_min
        y, status = standstill_state(standstill_temperature, charge, self.parameters[CONDENSER_VOLUME],
                                     self.parameters[EVAPORATOR_VOLUME], *self.arrays)
        if status != STATUS_OK:
            raise LoopFailure(f"the standstill state (the charge {charge!r} kg at {standstill_temperature!r} K) is "
                              f"not on the property table: {describe_boundary_status(status)}")
        self.state = y
        self.guesses = np.array([standstill_temperature, standstill_temperature])
        self.exchange = np.zeros(EXCHANGE_COUNT)     # the compressor's cumulative exchange at the state
        self.drawn_rate = 0.0
        self.secondary_temperatures = (standstill_temperature, standstill_temperature)
        self.outputs = {**self._outputs(), **dict.fromkeys(HEAT_FLOW_NAMES, 0.0)}

    def _outputs(self) -> dict:
        values, status, table_status = loop_outputs(self.state, self.parameters, self.drawn_rate,
                                                    self.secondary_temperatures[1], self.guesses.copy(),
                                                    *self.arrays)
        if status != LOOP_OK:
            raise LoopFailure(describe_failure(status, table_status))
        outputs = dict(zip(OUTPUT_NAMES, (float(value) for value in values)))
        if outputs["suction_quality"] < self.suction_quality_min:
            raise LoopFailure(f"the compressor would flood: suction vapour quality {outputs['suction_quality']:.4g} "
                              f"is below the compressor's limit {self.suction_quality_min:g} (the evaporator "
                              f"carries liquid over: it holds too much of the charge)")
        return outputs

    def step(self, step_size, exchange, condenser_secondary_temperature, evaporator_secondary_temperature) -> None:
        """Advance by `step_size` [s] with the compressor's cumulative (drawn mass, drawn enthalpy, delivered mass,
        delivered enthalpy) at the step's end; LoopFailure (the loop unchanged) if it cannot, or if the step ends
        with the evaporator empty or the suction wetter than suction_quality_min (the compressor flooded)."""
        exchange = np.asarray(exchange, dtype=float)
        rates = (exchange - self.exchange) / step_size
        inputs = np.empty(INPUT_COUNT)
        inputs[DRAWN_RATE], inputs[DRAWN_ENTHALPY_RATE], inputs[DELIVERED_RATE], inputs[DELIVERED_ENTHALPY_RATE] = rates
        inputs[CONDENSER_SECONDARY_TEMPERATURE] = condenser_secondary_temperature
        inputs[EVAPORATOR_SECONDARY_TEMPERATURE] = evaporator_secondary_temperature
        inputs[SUCTION_ENTHALPY] = self.outputs["suction_enthalpy"]
        time_constant = thermal_time_constant(self.state, self.parameters, self.guesses, *self.arrays)
        substep = min(MAX_SUBSTEP, THERMAL_SUBSTEP_FRACTION * time_constant) if time_constant > 0.0 else MAX_SUBSTEP
        substeps = max(1, math.ceil(step_size / substep))
        for _ in range(SUBSTEP_REFINEMENTS):
            if substeps > MAX_SUBSTEPS:
                raise LoopFailure(f"the step of {step_size!r} s needs more than {MAX_SUBSTEPS} RK4 substeps (the "
                                  f"volumes' heat exchange time constant is {time_constant:.3g} s): use a shorter "
                                  f"communication step")
            guesses = self.guesses.copy()
            y, status, table_status = advance_loop(self.state, step_size, substeps, self.parameters, inputs,
                                                   guesses, *self.arrays)
            if status == LOOP_OK:
                break
            substeps *= 4
        if status != LOOP_OK:
            raise LoopFailure(describe_failure(status, table_status))
        saved = (self.state, self.guesses, self.exchange, self.drawn_rate, self.secondary_temperatures)
        self.state, self.guesses, self.exchange = y, guesses, exchange
        self.drawn_rate = float(rates[0])
        self.secondary_temperatures = (condenser_secondary_temperature, evaporator_secondary_temperature)
        try:
            outputs = self._outputs()
        except LoopFailure:
            self.state, self.guesses, self.exchange, self.drawn_rate, self.secondary_temperatures = saved
            raise
        released = saved[0][CONDENSER_HEAT] - y[CONDENSER_HEAT]
        taken = y[EVAPORATOR_HEAT] + y[SUCTION_LINE_HEAT] - saved[0][EVAPORATOR_HEAT] - saved[0][SUCTION_LINE_HEAT]
        self.outputs = {**outputs, "condenser_heat_flow": float(released / step_size),
                        "evaporator_heat_flow": float(taken / step_size)}

    @property
    def charge(self) -> float:
        """Refrigerant mass in the two volumes [kg]."""
        return float(self.state[CONDENSER_MASS] + self.state[EVAPORATOR_MASS])
