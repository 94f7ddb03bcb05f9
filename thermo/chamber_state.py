"""The chamber model's state block (docs/model.md §7.3-§7.4), placed after the vane's states by the caller.

Temperature and gas mass of the leading (L) and trailing (T) chambers, then the cumulative flows across the
chambers' boundary: net mass and energy from the suction side (ports, valley leaks, chambers filled from or vented
to the idle lobes), mass and enthalpy out through the discharge valve, the compression work -sum p dV on the two
chambers, and net mass and energy from the back chamber (slot side faces).
"""
(LEADING_TEMPERATURE, LEADING_MASS, TRAILING_TEMPERATURE, TRAILING_MASS, MASS_SUCTION, MASS_DISCHARGE,
 ENERGY_SUCTION, ENERGY_DISCHARGE, WORK_CHAMBERS, MASS_BACK_CHAMBER, ENERGY_BACK_CHAMBER) = range(11)
GAS_STATE_SIZE = 11
CHAMBER_STATES = 4                 # T_L, m_L, T_T, m_T: the states the flows feed back on
