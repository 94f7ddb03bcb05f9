"""A pure or pseudo-pure working fluid from CoolProp's Helmholtz equations of state (docs/model.md §7.1, §7.3, §7.4).

`Fluid(name)` wraps two `CoolProp.AbstractState("HEOS", name)` objects: one with CoolProp's own phase
determination (exact reference values, saturation, flashes) and one with the gas phase imposed, which evaluates
the Helmholtz energy directly at (T, rho) without any phase test (the smooth, metastable continuation of the gas
branch that the property table is built from, `thermo.property_table`). Everything is SI: K, Pa, kg/m^3, J/kg,
J/(kg K). Nothing here is called in the time loop; the fast path is the numba table.

`check_operating_point` validates a compressor operating point before any work starts (docs/model.md §7.1): the suction
state must be a gas at least `SUPERHEAT_MARGIN` = 1 K outside the two-phase dome (docs/model.md §7.3: T > T_sat(p) + 1 K),
and the discharge pressure must exceed the suction pressure. `check_operating_numbers` is its part that needs no
fluid, and `coolprop_version` names the installed CoolProp without importing it: what a cache lookup needs
(thermo.operating_point).
"""
from __future__ import annotations

import functools
import math
from typing import NamedTuple

from .checks import checked_number, fail

UNIVERSAL_GAS_CONSTANT = 8314.462        # J/(kmol K), docs/model.md §7.4: R = 8314.462/M with M in kg/kmol
SUPERHEAT_MARGIN = 1.0                   # K, smallest accepted distance from the dew line (docs/model.md §7.3)
LIST_FLUIDS_HINT = "list valid names with CoolProp.CoolProp.get_global_param_string('FluidsList')"
COOLPROP_DISTRIBUTION = "CoolProp"       # the name CoolProp's wheel is installed under (its METADATA's Name)


def coolprop():
    """CoolProp's low-level module `CoolProp.CoolProp`, imported on first use: the import costs about 2.3 s of CPU,
    which `import thermo` must not pay when no real gas is used."""
    import CoolProp.CoolProp as CP
    return CP


@functools.lru_cache(maxsize=None)
def coolprop_version() -> str:
    """The version of the installed CoolProp distribution, read from its metadata (a few ms) without importing
    CoolProp (2.3 s): part of every cache key of CoolProp-derived data (docs/model.md §7.1)."""
    from importlib.metadata import version
    return version(COOLPROP_DISTRIBUTION)


class UnknownFluidError(ValueError):
    """A fluid name that is not a pure or pseudo-pure CoolProp fluid (the message says how to list the valid ones)."""


class ExactProperties(NamedTuple):
    """Properties of one (T, rho) state from CoolProp HEOS, SI units."""
    pressure: float                          # p [Pa]
    enthalpy: float                          # h [J/kg]
    isochoric_heat_capacity: float           # c_v [J/(kg K)]
    pressure_temperature_derivative: float   # (dp/dT)_rho [Pa/K]
    entropy: float                           # s [J/(kg K)]
    isobaric_heat_capacity: float            # c_p [J/(kg K)]


class PressureEntropyState(NamedTuple):
    """The state at given (p, s), e.g. the end of an isentropic compression."""
    temperature: float                       # T [K]
    density: float                           # rho [kg/m^3]
    enthalpy: float                           # h [J/kg]


def _positive(name, value, unit):
    """A finite float > 0, else ValueError naming the variable, its value and the range."""
    return checked_number(name, value, f"a finite number > 0 {unit}", lambda x: x > 0.0)


def _unknown_fluid(name) -> UnknownFluidError:
    return UnknownFluidError(f"fluid={name!r} is out of range; allowed: the name of a pure or pseudo-pure CoolProp "
                             f"fluid; {LIST_FLUIDS_HINT}")


def _two_phase_quality(state):
    """The vapour quality of an updated AbstractState inside the dome, None outside it."""
    CP = coolprop()
    return state.Q() if state.phase() == CP.iphase_twophase else None


class Fluid:
    """A pure or pseudo-pure CoolProp fluid (R134a by default; e.g. Air, R410A, R1234yf, R290, CO2).

    Unknown names and mixtures ("A&B") raise ValueError; the message says how to list the valid names.
    """

    def __init__(self, name: str = "R134a"):
        CP = coolprop()
        if not isinstance(name, str) or not name or "&" in name:
            raise _unknown_fluid(name)
        try:
            state = CP.AbstractState("HEOS", name)
        except ValueError:
            raise _unknown_fluid(name) from None
        self.name = name
        self.coolprop_name = state.fluid_param_string("name")       # canonical, e.g. "CarbonDioxide" for "CO2"
        self._state = state
        self._gas = CP.AbstractState("HEOS", name)
        self._gas.specify_phase(CP.iphase_gas)
        self.molar_mass = state.molar_mass()                             # kg/mol
        self.gas_constant = UNIVERSAL_GAS_CONSTANT / (1e3 * self.molar_mass)   # J/(kg K)
        self.critical_temperature = state.T_critical()
        self.critical_pressure = state.p_critical()
        self.critical_density = state.rhomass_critical()
        self.triple_temperature = state.Ttriple()
        self.minimum_temperature = state.Tmin()                      # validity range of the equation of state
        self.maximum_temperature = state.Tmax()
        self.maximum_pressure = state.pmax()

    def __repr__(self):
        return f"Fluid({self.name!r})"

    # ------------------------------------------------------------------------------------------------------
    def _update(self, state, inputs, first, second, description):
        """state.update(inputs, first, second); CoolProp failures become ValueErrors that name the state."""
        try:
            state.update(inputs, first, second)
        except ValueError as error:
            raise ValueError(f"CoolProp HEOS cannot evaluate {self.name} at {description}: {error}") from None

    def _check_temperature(self, temperature):
        temperature = _positive("temperature", temperature, "K")
        if not self.minimum_temperature <= temperature <= self.maximum_temperature:
            fail("temperature", temperature, f"[{self.minimum_temperature!r}, {self.maximum_temperature!r}] K "
                                              f"(validity range of the {self.name} equation of state)")
        return temperature

    def _update_temperature_density(self, state, temperature, density):
        CP = coolprop()
        temperature = self._check_temperature(temperature)
        density = _positive("density", density, "kg/m^3")
        self._update(state, CP.DmassT_INPUTS, density, temperature, f"T={temperature!r} K, rho={density!r} kg/m^3")
        return state

    def properties(self, temperature, density) -> ExactProperties:
        """p, h, c_v, (dp/dT)_rho, s, c_p at (T, rho) from HEOS. A two-phase state raises ValueError."""
        state = self._update_temperature_density(self._state, temperature, density)
        quality = _two_phase_quality(state)
        if quality is not None:
            raise ValueError(f"{self.name} at T={temperature!r} K, rho={density!r} kg/m^3 is inside the two-phase "
                             f"dome (vapour quality {quality:.4f}, saturation pressure {state.p():.6g} Pa); "
                             "only single-phase states are supported")
        return self._single_phase_properties(state)

    def vapour_quality(self, temperature, density):
        """The vapour mass fraction of a two-phase (T, rho), or None for a single-phase state."""
        return _two_phase_quality(self._update_temperature_density(self._state, temperature, density))

    def gas_branch_state(self, temperature, density):
        """CoolProp's AbstractState at (T, rho) on the gas branch of the equation of state, without a phase test:
        identical to `properties` for any gas state, the smooth metastable continuation inside the dome. For
        low-level derivatives (the property table's nodes); valid until the next call."""
        return self._update_temperature_density(self._gas, temperature, density)

    @staticmethod
    def _single_phase_properties(state) -> ExactProperties:
        CP = coolprop()
        return ExactProperties(state.p(), state.hmass(), state.cvmass(),
                               state.first_partial_deriv(CP.iP, CP.iT, CP.iDmass), state.smass(), state.cpmass())

    # ------------------------------------------------------------------------------------------------------
    def saturation_temperature(self, pressure):
        """Dew-point temperature T_sat(p) [K] (vapour quality 1), or None if p >= p_crit (no dome there)."""
        CP = coolprop()
        pressure = _positive("pressure", pressure, "Pa")
        if pressure >= self.critical_pressure:
            return None
        self._update(self._state, CP.PQ_INPUTS, pressure, 1.0, f"p={pressure!r} Pa on the dew line")
        return self._state.T()

    def _check_subcritical(self, temperature):
        temperature = _positive("temperature", temperature, "K")
        low, high = self.triple_temperature, self.critical_temperature
        if not low <= temperature < high:
            fail("temperature", temperature, f"[{low!r}, {high!r}) K (triple point to critical point of {self.name})")
        return temperature

    def _dew_point(self, temperature):
        CP = coolprop()
        temperature = self._check_subcritical(temperature)
        self._update(self._state, CP.QT_INPUTS, 1.0, temperature, f"T={temperature!r} K on the dew line")
        return self._state

    def saturated_state(self, temperature, quality):
        """CoolProp's AbstractState of the saturated liquid (quality 0) or vapour (1) at T_triple <= T < T_crit, for
        saturation-line derivatives (thermo.saturation); valid until the next call."""
        CP = coolprop()
        temperature = self._check_subcritical(temperature)
        self._update(self._state, CP.QT_INPUTS, float(quality), temperature,
                     f"T={temperature!r} K, vapour quality {quality!r}")
        return self._state

    def dew_pressure(self, temperature):
        """Saturated-vapour pressure p_dew(T) [Pa] for T_triple <= T < T_crit."""
        return self._dew_point(temperature).p()

    def dew_density(self, temperature):
        """Saturated-vapour density [kg/m^3] for T_triple <= T < T_crit."""
        return self._dew_point(temperature).rhomass()

    def _density(self, state, temperature, pressure):
        CP = coolprop()
        temperature = self._check_temperature(temperature)
        pressure = _positive("pressure", pressure, "Pa")
        self._update(state, CP.PT_INPUTS, pressure, temperature, f"p={pressure!r} Pa, T={temperature!r} K")
        return state.rhomass()

    def density(self, temperature, pressure):
        """rho(T, p) [kg/m^3] (CoolProp's phase determination: the liquid density for a liquid state)."""
        return self._density(self._state, temperature, pressure)

    def gas_density(self, temperature, pressure):
        """rho(T, p) [kg/m^3] on the gas branch (no phase test; a metastable vapour below the dew temperature)."""
        return self._density(self._gas, temperature, pressure)

    def state_at_pressure_entropy(self, pressure, entropy) -> PressureEntropyState:
        """T, rho and h at (p, s), e.g. the end of an isentropic compression from s_1 to p_2."""
        CP = coolprop()
        pressure = _positive("pressure", pressure, "Pa")
        try:
            entropy = float(entropy)
        except (TypeError, ValueError):
            fail("entropy", entropy, "a finite number [J/(kg K)]")
        if not math.isfinite(entropy):
            fail("entropy", entropy, "a finite number [J/(kg K)]")
        self._update(self._state, CP.PSmass_INPUTS, pressure, entropy, f"p={pressure!r} Pa, s={entropy!r} J/(kg K)")
        return PressureEntropyState(self._state.T(), self._state.rhomass(), self._state.hmass())

    def pressure_at_temperature_entropy(self, temperature, entropy):
        """p [Pa] at (T, s), e.g. where an isentrope reaches a temperature."""
        CP = coolprop()
        temperature = self._check_temperature(temperature)
        self._update(self._state, CP.SmassT_INPUTS, float(entropy), temperature,
                     f"T={temperature!r} K, s={entropy!r} J/(kg K)")
        return self._state.p()

    def isentropic_enthalpy(self, pressure, entropy):
        """h(p_2, s_1) [J/kg]: the enthalpy after an isentropic change of state to p_2."""
        return self.state_at_pressure_entropy(pressure, entropy).enthalpy

    def ideal_gas_exponent(self, temperature):
        """k = c_p0/(c_p0 - R) at T with R = 8314.462/M (docs/model.md §7.4); c_p0 depends on T only."""
        CP = coolprop()
        temperature = self._check_temperature(temperature)
        ideal_gas_density = 1e-3 * self.critical_density      # c_p0 does not depend on density; any will do
        self._update(self._gas, CP.DmassT_INPUTS, ideal_gas_density, temperature, f"T={temperature!r} K")
        heat_capacity = self._gas.cp0mass()
        return heat_capacity / (heat_capacity - self.gas_constant)

    def dome_temperature(self, pressure):
        """The temperature superheat is counted from [K]: T_dew(p) for p < p_crit, T_crit for p >= p_crit
        (docs/model.md §7.3)."""
        dew = self.saturation_temperature(pressure)
        return self.critical_temperature if dew is None else dew

    def superheat(self, temperature, pressure):
        """Distance from the dome [K]: T - T_dew(p) for p < p_crit, T - T_crit for p >= p_crit."""
        return float(temperature) - self.dome_temperature(pressure)


def typical_operating_point(fluid: Fluid) -> tuple[float, float, float]:
    """(p_s [Pa], T_s [K], p_d [Pa]) of a typical compressor duty: docs/model.md §7.1 for R134a and air; CO2 as a
    transcritical heat pump (3.5 -> 10 MPa, 283.15 K); other fluids evaporating at 0 °C with 10 K superheat and
    condensing at 50 °C."""
    if fluid.name == "R134a":
        return 0.2928e6, 283.15, 1.3179e6
    if fluid.name == "Air":
        return 101325.0, 293.15, 5e5
    if fluid.name == "CO2":
        return 3.5e6, 283.15, 10e6
    return fluid.dew_pressure(273.15), 283.15, fluid.dew_pressure(323.15)


def check_operating_numbers(suction_pressure, suction_temperature, discharge_pressure,
                            superheat_margin=SUPERHEAT_MARGIN) -> tuple[float, float, float, float]:
    """The checks of `check_operating_point` that need no fluid (docs/model.md §7.1): p_s, T_s, p_d and the margin
    finite numbers > 0 and p_d > p_s; returns them as floats, else ValueError naming the variable."""
    suction_pressure = _positive("suction_pressure", suction_pressure, "Pa")
    suction_temperature = _positive("suction_temperature", suction_temperature, "K")
    discharge_pressure = _positive("discharge_pressure", discharge_pressure, "Pa")
    superheat_margin = _positive("superheat_margin", superheat_margin, "K")
    if not discharge_pressure > suction_pressure:
        fail("discharge_pressure", discharge_pressure, f"> suction_pressure = {suction_pressure!r} Pa")
    return suction_pressure, suction_temperature, discharge_pressure, superheat_margin


def check_operating_point(fluid: Fluid, suction_pressure, suction_temperature, discharge_pressure,
                          superheat_margin=SUPERHEAT_MARGIN):
    """Validate a compressor operating point (docs/model.md §7.1) before any work starts; ValueError otherwise.

    Requires p_s > 0, T_s > 0, p_d > p_s, p_s at least the triple-point pressure, states inside the equation of
    state's range, and a suction gas at least
    `superheat_margin` outside the two-phase dome: T_s >= T_dew(p_s) + margin for p_s < p_crit, and
    T_s >= T_crit + margin for p_s >= p_crit (a supercritical gas; colder is a compressed liquid).
    Returns the suction superheat [K] in that sense.
    """
    suction_pressure, suction_temperature, discharge_pressure, superheat_margin = check_operating_numbers(
        suction_pressure, suction_temperature, discharge_pressure, superheat_margin)
    if not discharge_pressure <= fluid.maximum_pressure:
        fail("discharge_pressure", discharge_pressure,
              f"<= {fluid.maximum_pressure!r} Pa (validity range of the {fluid.name} equation of state)")
    triple_pressure = fluid.dew_pressure(fluid.triple_temperature)
    if not suction_pressure >= triple_pressure:
        fail("suction_pressure", suction_pressure,
              f">= {triple_pressure!r} Pa, the triple-point pressure of {fluid.name} (the chamber model's "
              f"property table follows the liquid-vapour dome, which ends there)")
    if not fluid.minimum_temperature <= suction_temperature <= fluid.maximum_temperature:
        fail("suction_temperature", suction_temperature,
              f"[{fluid.minimum_temperature!r}, {fluid.maximum_temperature!r}] K "
              f"(validity range of the {fluid.name} equation of state)")
    dew = fluid.saturation_temperature(suction_pressure)
    if dew is None:
        limit = fluid.critical_temperature + superheat_margin
        reason = (f"suction_pressure = {suction_pressure!r} Pa is above the critical pressure "
                  f"{fluid.critical_pressure!r} Pa, so the suction gas must be hotter than T_crit + "
                  f"{superheat_margin} K")
    else:
        limit = dew + superheat_margin
        reason = (f"superheated {fluid.name} vapour: dew temperature {dew!r} K at suction_pressure = "
                  f"{suction_pressure!r} Pa plus a margin of {superheat_margin} K")
    if not suction_temperature >= limit:
        fail("suction_temperature", suction_temperature, f">= {limit!r} K ({reason})")
    return fluid.superheat(suction_temperature, suction_pressure)
