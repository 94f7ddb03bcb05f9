"""An independent steady vapour-compression cycle from CoolProp states, the cross-check of the refrigeration
system's steady state (README "Refrigeration system", docs/model.md §16.7).

Given the system's steady p_s, suction enthalpy h_s and p_d, and the compressor's delivered mass flow, speed and
shaft power, the cycle takes from CoolProp (not from the project's property table) the suction density rho_s and
entropy s_s, the isentropic discharge enthalpy h_2s = h(p_d, s_s), and the condenser's outlet as saturated liquid
at p_d (docs/model.md §16.2: the loop's condenser gives saturated liquid while liquid fills at least
`separation_fill` of it; it has no subcooling). With the compressor's own efficiencies

    eta_v  = m_dot / (rho_s V_swept n),     eta_is = m_dot (h_2s - h_s) / P_shaft,

the cycle's mass flow eta_v rho_s V_swept n and shaft power m_dot (h_2s - h_s) / eta_is are the compressor's by
construction; what the cycle checks independently is the loop: its capacity (heat taken by the evaporator and the
suction line, docs/model.md §16.4) against the isenthalpic valve fed by saturated liquid. The textbook cycle's
capacity is m_dot (h_s - h_valve,in). The compressor does not draw h_s per kilogram, though: what flows back
through its suction ports and valley seals carries the chamber's energy, and the valley switch moves internal
energy (docs/model.md §16.5), so its drawn energy per drawn mass, h_drawn, is below h_s and the difference
m_dot (h_s - h_drawn) returns to the evaporator. With that, the compressor's third own figure beside eta_v and
eta_is, the cycle's capacity is m_dot (h_drawn - h_valve,in); both are reported. COP = capacity / the electrical
power the system's COP uses (the motor's, scaled by the cycle's shaft power over the compressor's: the same power
here)."""
from __future__ import annotations

import dataclasses
import math

from ..mechanics.geometry.stator import lobe_area
from ..mechanics.parameters import CompressorParameters


def saturated(quantity: str, temperature: float, quality: float, fluid: str = "R134a") -> float:
    """CoolProp's `quantity` (PropsSI letter) of `fluid` saturated at `temperature` [K] and `quality` (0 liquid,
    1 vapour)."""
    from CoolProp.CoolProp import PropsSI
    return PropsSI(quantity, "T", temperature, "Q", quality, fluid)


def swept_volume(start_values: dict) -> float:
    """Swept volume per revolution, lobes x axial length x lobe area [m3], of the compressor with these start values
    over the defaults of docs/model.md §9 (only the geometry matters; the operating point is left at its default)."""
    fields = {field.name for field in dataclasses.fields(CompressorParameters)}
    geometry = {name: value for name, value in start_values.items()
                if name in fields and name not in ("suction_pressure", "suction_temperature", "discharge_pressure")}
    params = dataclasses.replace(CompressorParameters(), **geometry)
    return params.lobes * params.axial_length * lobe_area(params)


def independent_cycle(fluid: str, suction_pressure: float, suction_enthalpy: float, discharge_pressure: float,
                      mass_flow: float, speed: float, shaft_power: float, electrical_power: float,
                      displacement: float, drawn_enthalpy: float) -> dict[str, float]:
    """The steady cycle of the module docstring. speed in rev/s, displacement = swept volume per revolution [m3];
    powers [W], mass flow [kg/s], pressures [Pa], enthalpies (drawn_enthalpy: the compressor's drawn energy per
    drawn mass) [J/kg]. Returns the efficiencies, states and figures."""
    from CoolProp.CoolProp import PropsSI
    suction_density = PropsSI("D", "P", suction_pressure, "H", suction_enthalpy, fluid)
    suction_entropy = PropsSI("S", "P", suction_pressure, "H", suction_enthalpy, fluid)
    isentropic_enthalpy = PropsSI("H", "P", discharge_pressure, "S", suction_entropy, fluid)
    volumetric = mass_flow / (suction_density * displacement * speed)
    isentropic = mass_flow * (isentropic_enthalpy - suction_enthalpy) / shaft_power
    cycle_mass_flow = volumetric * suction_density * displacement * speed
    cycle_shaft_power = cycle_mass_flow * (isentropic_enthalpy - suction_enthalpy) / isentropic
    valve_inlet_enthalpy = PropsSI("H", "P", discharge_pressure, "Q", 0.0, fluid)
    textbook_capacity = cycle_mass_flow * (suction_enthalpy - valve_inlet_enthalpy)
    capacity = cycle_mass_flow * (drawn_enthalpy - valve_inlet_enthalpy)
    cycle_electrical_power = electrical_power * cycle_shaft_power / shaft_power
    if not all(map(math.isfinite, (capacity, textbook_capacity, cycle_electrical_power))):
        raise ValueError(f"the independent cycle is not finite at p_s = {suction_pressure:g} Pa, h_s = "
                         f"{suction_enthalpy:g} J/kg, p_d = {discharge_pressure:g} Pa")
    return {"volumetric efficiency": volumetric, "isentropic efficiency": isentropic,
            "suction density [kg/m3]": suction_density, "isentropic discharge enthalpy [J/kg]": isentropic_enthalpy,
            "valve inlet enthalpy (saturated liquid at p_d) [J/kg]": valve_inlet_enthalpy,
            "mass flow [kg/s]": cycle_mass_flow, "shaft power [W]": cycle_shaft_power,
            "electrical power [W]": cycle_electrical_power,
            "returned to the suction side m_dot (h_s - h_drawn) [W]": textbook_capacity - capacity,
            "capacity [W]": capacity, "COP": capacity / cycle_electrical_power,
            "textbook capacity m_dot (h_s - h_valve,in) [W]": textbook_capacity,
            "textbook COP": textbook_capacity / cycle_electrical_power}
