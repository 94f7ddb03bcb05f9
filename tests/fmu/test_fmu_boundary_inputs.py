"""The built compressor FMU with its suction and discharge conditions as inputs (fmu_src.boundary_inputs): declared
ranges from the R134a tables it ships, a start from standstill at equal pressures, moving pressures with the flow
outputs conserving mass and enthalpy across the interface step by step, a wet suction state given by enthalpy.
Bad inputs and the pressure-table models' refusals are contract rows C10 and C27 (tests/fmu/test_fmu_contract.py)."""
import math

import pytest

import fmu_helpers as H

CONSERVATION = 1e-9                # relative: sums of step means x h against the cumulative outputs
MOVED_PRESSURE = 1.3679e6          # Pa: p_d 50 kPa above its start value


def test_declared_ranges_are_those_of_the_shipped_r134a_tables(fmu):
    from fmpy import read_model_description

    from rotary_vane.thermo.fluid import Fluid
    from rotary_vane.thermo.fluid_envelope import input_range
    variables = {v.name: v for v in read_model_description(str(fmu)).modelVariables}
    fluid = Fluid("R134a")
    inputs = input_range(fluid)
    coldest = fluid.saturation_temperature(inputs.suction_pressure_min)
    expected = {
        "suction_pressure": (inputs.suction_pressure_min, inputs.discharge_pressure_max),
        "discharge_pressure": (inputs.suction_pressure_min, inputs.discharge_pressure_max),
        "suction_temperature": (coldest + 1.0, inputs.suction_temperature_max),
        "suction_enthalpy": (fluid.saturated_state(coldest, inputs.suction_quality_min).hmass(),
                             fluid.properties(inputs.suction_temperature_max,
                                              fluid.density(inputs.suction_temperature_max,
                                                            inputs.suction_pressure_min)).enthalpy)}
    for name, (low, high) in expected.items():
        variable = variables[name]
        assert variable.causality == "input" and variable.variability == "continuous", name
        assert float(variable.min) == pytest.approx(low, rel=1e-6), name
        assert float(variable.max) == pytest.approx(high, rel=1e-6), name
    assert variables["suction_state_input"].causality == "parameter"


RUN = """
import math
import fmu_helpers as H
out = {}
host = H.Host($fmu)
# standstill at equal pressures, 10 K superheat
assert host.initialize(shaft_speed=0.0, rotor_inertia=0.0, suction_pressure=0.6e6, discharge_pressure=0.6e6,
                       suction_temperature=304.72) == H.OK, host.messages()
h, t, rows = 1e-3, 0.0, []
for k in range(120):
    host.set(shaft_speed=min(1500.0, 1500.0 * t / 0.03), discharge_pressure=0.6e6 + 0.4e6 * min(1.0, t / 0.1))
    status = host.step(t, h)
    assert status == H.OK, (t, status, host.messages()[-3:])
    t += h
    rows.append(host.outputs())
out["rows"] = rows
out["warnings"] = [m for s, _, m in host.messages() if s == H.WARNING][:3]
host.close()
# a wet suction state (quality 0.95 at 0.2928 MPa) by enthalpy, one revolution at 1500 rpm
wet = H.Host($fmu)
assert wet.initialize(shaft_speed=1500.0, suction_state_input="enthalpy", suction_enthalpy=$wet_enthalpy) == H.OK, \\
    wet.messages()
out["wet"] = wet.run(0.0, 1e-3, 45)[-1]
wet.close()
# p_d moved by 50 kPa in the fifth 1 ms step at 1500 rpm, held or interpolated over it
for interpolate in (True, False):
    moved = H.Host($fmu)
    assert moved.initialize(shaft_speed=1500.0, interpolate_speed=interpolate) == H.OK, moved.messages()
    moved.run(0.0, 1e-3, 4)
    moved.set(discharge_pressure=$moved_pressure)
    assert moved.step(4e-3, 1e-3) == H.OK, moved.messages()
    out[f"moved interpolate={interpolate}"] = moved.outputs()["shaft_work"]
    moved.close()
H.emit(out)
"""


@pytest.fixture(scope="module")
def boundary_run(fmu, env):
    from rotary_vane.thermo.fluid import Fluid
    fluid = Fluid("R134a")
    wet_enthalpy = fluid.saturated_state(fluid.saturation_temperature(0.2928e6), 0.95).hmass()
    from string import Template
    script = Template(RUN).substitute(fmu=repr(str(fmu)), wet_enthalpy=repr(wet_enthalpy),
                                      moved_pressure=repr(MOVED_PRESSURE))
    return H.run_host(script, env=env).check().result


def test_a_start_from_standstill_at_equal_pressures_runs_and_says_when_nothing_is_delivered(boundary_run):
    """At rest with p_s = p_d the valve passes only the little gas the vane displaces as it settles from its
    nominal pose (measured 1e-8 kg, 2e-4 of the chambers' gas); at speed it delivers; a step in which it stays
    shut reports the discharge plenum's enthalpy as its mean discharge enthalpy (finite, with fmi2OK)."""
    rows = boundary_run["rows"]
    assert abs(rows[0]["delivered_mass"]) < 1e-7, rows[0]["delivered_mass"]
    assert rows[-1]["delivered_mass"] > 1e-5
    shut = [row for before, row in zip(rows, rows[1:]) if row["delivered_mass"] == before["delivered_mass"]]
    assert shut and all(math.isfinite(row["discharge_enthalpy_mean"]) for row in rows)
    assert boundary_run["warnings"] == []


def test_step_means_sum_to_the_cumulative_flows(boundary_run, check):
    rows, h = boundary_run["rows"], 1e-3
    last = rows[-1]
    delivered = [b["delivered_mass"] - a["delivered_mass"] for a, b in zip([dict(delivered_mass=0.0)] + rows, rows)]
    sums = {"drawn_mass": sum(r["suction_mass_flow_mean"] for r in rows) * h,
            "delivered_mass": sum(r["discharge_mass_flow_mean"] for r in rows) * h,
            "delivered_enthalpy": sum(r["discharge_enthalpy_mean"] * m for r, m in zip(rows, delivered))}
    for name, total in sums.items():
        check(f"FMU flow outputs: sum of step means x h vs {name}", abs(total / last[name] - 1.0), CONSERVATION)


def test_a_wet_suction_state_given_by_enthalpy_runs_a_revolution(boundary_run):
    wet = boundary_run["wet"]
    assert 0.0 < wet["volumetric_efficiency"] < 1.0 and wet["input_power"] > 0.0, wet
    assert wet["discharge_mass_flow"] > 0.0 and math.isfinite(wet["discharge_temperature"]), wet


def test_interpolate_speed_moves_the_boundary_inputs_over_the_step_as_the_library_does(boundary_run):
    """p_d changed for one step: with interpolate_speed the FMU's shaft work is the library's advance that moves
    the boundary linearly over the step, without it the advance that holds the new value (the FMU adds no physics),
    and the two differ (tests/mechanics/test_boundary.py: the ramp is the limit of many held steps)."""
    from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
    from rotary_vane.mechanics.loop.layout import WORK_IN
    start = dict(suction_pressure=0.2928e6, discharge_pressure=1.3179e6, suction_temperature=283.15)
    for interpolate in (True, False):
        run = Simulation(CompressorParameters(), constant_speed(1500.0), initial_angle=0.0, keep_history=False)
        for k in range(1, 5):
            run.advance(k * 1e-3, speed_rpm=1500.0, interpolate=interpolate, boundary=start)
        run.advance(5e-3, speed_rpm=1500.0, interpolate=interpolate,
                    boundary={**start, "discharge_pressure": MOVED_PRESSURE})
        assert boundary_run[f"moved interpolate={interpolate}"] == pytest.approx(run.state[WORK_IN], rel=1e-9)
    held, ramped = boundary_run["moved interpolate=False"], boundary_run["moved interpolate=True"]
    assert abs(held - ramped) > 1e-3 * abs(held), (held, ramped)
