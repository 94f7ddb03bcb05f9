"""RefrigerationLoop.fmu (fmu_src/refrigeration_loop.py, docs/model.md §12.3, §16) as built, run in fmpy in a
subprocess: a run with a prescribed compressor exchange keeps the charge balance, a state serialized mid-run and set
back repeats the run exactly, a bad input discards the step, a bad parameter is fmi2Error naming it."""
import subprocess
import sys

import pytest

import fmu_helpers

MODEL = "RefrigerationLoop"
MASS_FLOW, DISCHARGE_ENTHALPY = 0.01, 440e3       # kg/s, J/kg: the prescribed compressor

RUN = r'''
import base64, json, math, sys
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave
spec = json.loads(sys.argv[1])
md = read_model_description(spec["fmu"])
vr = {v.name: v.valueReference for v in md.modelVariables}
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(spec["fmu"]), modelIdentifier="RefrigerationLoop",
                instanceName="loop")
fmu.instantiate(loggingOn=True)
OUT = [vr[n] for n in ("suction_pressure", "discharge_pressure", "suction_enthalpy", "evaporator_heat_flow",
                       "refrigerant_charge_in_loop")]
IN = [vr[n] for n in ("drawn_mass", "drawn_enthalpy", "delivered_mass", "delivered_enthalpy")]
m, h, dt = spec["mass_flow"], spec["enthalpy"], spec["step"]
drawn_enthalpy = [0.0]

def advance(k0, n):
    values = []
    for k in range(k0, k0 + n):
        t = (k + 1) * dt
        drawn_enthalpy[0] += m * dt * fmu.getReal([vr["suction_enthalpy"]])[0]
        fmu.setReal(IN, [m * t, drawn_enthalpy[0], m * t, m * h * t])
        fmu.doStep(k * dt, dt)
        values.append(fmu.getReal(OUT))
    return values

result = {}
if spec["bad_parameter"]:
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["condenser_ua"]], [-5.0])
    try:
        fmu.exitInitializationMode()
        result["status"] = 0
    except Exception as error:
        result["status"] = str(error)
else:
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    result["start"] = fmu.getReal(OUT)
    result["run"] = advance(0, spec["steps"])
    state = fmu.getFMUstate()
    blob = fmu.serializeFMUstate(state)
    saved_drawn_enthalpy = drawn_enthalpy[0]
    result["first"] = advance(spec["steps"], 5)
    fmu.setFMUstate(fmu.deSerializeFMUstate(blob))
    drawn_enthalpy[0] = saved_drawn_enthalpy
    result["again"] = advance(spec["steps"], 5)
    fmu.setReal([vr["evaporator_secondary_temperature"]], [math.nan])
    try:
        result["bad_input"] = fmu.doStep((spec["steps"] + 5) * dt, dt)
    except Exception as error:
        result["bad_input"] = str(error)
    result["after_bad_input"] = fmu.getReal(OUT)
    fmu.terminate()
fmu.freeInstance()
print("RESULT " + json.dumps(result))
'''


@pytest.fixture(scope="module")
def loop_fmu(built_fmus):
    path = built_fmus / f"{MODEL}.fmu"
    assert path.is_file()
    return path


def run(loop_fmu, **spec):
    """The script's result, with the FMU's messages (which it also writes to stderr) as "messages"."""
    spec = {**dict(fmu=str(loop_fmu), mass_flow=MASS_FLOW, enthalpy=DISCHARGE_ENTHALPY, step=0.5, steps=60,
                   bad_parameter=False), **spec}
    result, process = fmu_helpers.run_json_script(RUN, spec, loop_fmu.parent)
    return dict(result, messages=process.stderr.splitlines())


def test_a_run_in_fmpy_keeps_the_charge_and_restores_a_serialized_state(loop_fmu):
    result = run(loop_fmu)
    start, end = result["start"], result["run"][-1]
    assert start[0] == pytest.approx(start[1])                        # standstill: equal pressures
    assert end[1] > 2.0 * end[0]                                      # the compressor has lifted the pressure
    assert end[3] > 500.0                                             # and the evaporator cools its stream
    assert end[4] == pytest.approx(start[4], rel=1e-9)                # drawn = delivered: the charge stays
    assert result["again"] == result["first"]                         # fmi2SetFMUstate from serialized bytes
    assert "status 2 (discard)" in str(result["bad_input"]), result["bad_input"]
    assert result["after_bad_input"] == result["again"][-1]           # the discarded step changed nothing
    assert any("evaporator_secondary_temperature" in text for text in result["messages"])


def test_a_bad_parameter_is_refused_by_name(loop_fmu):
    result = run(loop_fmu, bad_parameter=True)
    assert result["status"] != 0
    assert any("parameter 'condenser_ua' = -5.0" in text for text in result["messages"]), result["messages"]


def test_fmpy_validates_the_model_description(loop_fmu):
    done = subprocess.run([sys.executable, "-m", "fmpy", "validate", str(loop_fmu)], capture_output=True, text=True)
    assert done.returncode == 0 and "No problems found" in done.stdout, done.stdout + done.stderr
