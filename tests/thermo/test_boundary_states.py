"""Boundary states solved on R134a's fluid-wide property table (thermo.boundary_states) against CoolProp HEOS: the
suction node from (p_s, T_s) or (p_s, h_s), wet states included, and the back node at p_d on the suction isentrope,
also for equal and reversed pressures; states the table cannot hold come back with the node that failed."""
import pytest

from rotary_vane.thermo.boundary_states import (DISCHARGE_STATE, SUCTION_STATE, boundary_states,
                                                describe_boundary_status)
from rotary_vane.thermo.fluid import Fluid
from rotary_vane.thermo.fluid_envelope import fluid_tables_for
from rotary_vane.thermo.property_table import table_arrays

RELATIVE = 1e-7            # density, enthalpies (measured: 3e-10 for h_2s, 1e-9 for rho_s)


@pytest.fixture(scope="module")
def fluid():
    return Fluid("R134a")


@pytest.fixture(scope="module")
def arrays():
    return table_arrays(fluid_tables_for("R134a")[0])


def exact_suction(fluid, pressure, temperature=None, quality=None):
    """(T, rho, h, s) from HEOS: a gas at (p, T) or a mixture of `quality` at p."""
    if quality is None:
        density = fluid.density(temperature, pressure)
        state = fluid.properties(temperature, density)
        return temperature, density, state.enthalpy, state.entropy
    saturation = fluid.saturation_temperature(pressure)
    mixture = fluid.saturated_state(saturation, quality)
    return saturation, mixture.rhomass(), mixture.hmass(), mixture.smass()


# (p_s, T_s or None, quality or None, p_d): the default point, the corners of the input range, equal and reversed
# pressures, a wet suction state of quality 0.95 and one of 0.6
CASES = [(0.2928e6, 283.15, None, 1.3179e6), (0.06e6, 240.0, None, 2.0e6), (0.55e6, 320.0, None, 0.6e6),
         (0.6e6, 304.72, None, 0.6e6), (0.6e6, 304.72, None, 0.4e6), (0.2928e6, None, 0.95, 1.3179e6),
         (0.1e6, None, 0.6, 1.0e6)]


@pytest.mark.parametrize("suction_pressure, temperature, quality, discharge_pressure", CASES)
def test_boundary_nodes_agree_with_heos(fluid, arrays, check, suction_pressure, temperature, quality,
                                        discharge_pressure):
    t_s, rho_s, h_s, s_s = exact_suction(fluid, suction_pressure, temperature, quality)
    by_enthalpy = quality is not None
    solved = boundary_states(suction_pressure, h_s if by_enthalpy else t_s, by_enthalpy, discharge_pressure,
                             t_s + 7.0, 0.8 * rho_s, *arrays)
    assert solved[6:] == (0, 0)
    h_2s = fluid.isentropic_enthalpy(discharge_pressure, s_s)
    t_2s = fluid.state_at_pressure_entropy(discharge_pressure, s_s).temperature
    label = f"boundary nodes p_s {suction_pressure:g}, p_d {discharge_pressure:g}"
    check(f"{label}: rho_s", abs(solved[1] / rho_s - 1.0), RELATIVE)
    check(f"{label}: h_s", abs(solved[2] / h_s - 1.0), RELATIVE)
    check(f"{label}: T_s [K]", abs(solved[0] - t_s), 1e-5)
    check(f"{label}: h_2s", abs(solved[5] / h_2s - 1.0), RELATIVE)
    check(f"{label}: T_2s [K]", abs(solved[3] - t_2s), 1e-4)


def test_states_outside_the_table_name_the_node(fluid, arrays):
    below_dew = boundary_states(0.6e6, 250.0, False, 1.0e6, 300.0, 25.0, *arrays)     # a liquid at 0.6 MPa, 250 K
    assert below_dew[6] != 0 and below_dew[7] == SUCTION_STATE
    far_above = boundary_states(0.3e6, 290.0, False, 30e6, 290.0, 13.0, *arrays)
    assert far_above[6] != 0 and far_above[7] == DISCHARGE_STATE
    assert describe_boundary_status(far_above[6]).startswith("the state is ")
