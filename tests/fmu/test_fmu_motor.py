"""The DriveMotor FMU (fmu_src/motor.py) as built: validators, and the motor physics against closed forms.

The FMUs are built once per module into a temporary folder (`python -m rotary_vane.fmu_src.build --out DIR`) and every FMU run
happens in a subprocess started in that folder, so the FMU can only use its own bundled code. pythonfmu 0.7.0
cannot instantiate the same FMU twice in one process (its class lookup releases a reference to the entry module's
globals that it does not own), so each subprocess instantiates each FMU once and uses fmi2Reset for more runs.
The references below are written from the model equations (Kloss curve, DC armature circuit, shaft), not
imported from the project.
"""
import json
import math
import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

import fmu_helpers

PROJECT = Path(__file__).resolve().parents[2]
RPM = 2.0 * math.pi / 60.0

# defaults of the FMU (fmu_src/motor.py), repeated here on purpose: a changed default must be a visible decision
INDUCTION = dict(rated_power=1500.0, rated_speed=1440.0, supply_frequency=50.0, pole_pairs=2,
                 breakdown_torque_ratio=2.5)
DC = dict(voltage=48.0, armature_resistance=0.3, armature_inductance=1e-3, torque_constant=0.28)
INERTIA = 4.0e-3 + 5.5e-4                       # motor_inertia + load_inertia [kg.m2]


def kloss(rated_power, rated_speed, supply_frequency, pole_pairs, breakdown_torque_ratio):
    """Reference Kloss curve from the nameplate: (w_s [rad/s], T_r, T_b, s_b, torque(w))."""
    w_s = 2.0 * math.pi * supply_frequency / pole_pairs
    w_r = rated_speed * RPM
    s_r = 1.0 - w_r / w_s
    t_r = rated_power / w_r
    k = breakdown_torque_ratio
    s_b = s_r * (k + math.sqrt(k * k - 1.0))
    t_b = k * t_r

    def torque(w):
        s = 1.0 - w / w_s
        return 2.0 * t_b / (s / s_b + s_b / s) if s != 0.0 else 0.0
    return w_s, t_r, t_b, s_b, torque


SIMULATE = r'''
import json, sys
from fmpy import simulate_fmu
spec = json.loads(sys.argv[1])
result = simulate_fmu(spec["fmu"], stop_time=spec["stop"], output_interval=spec["step"], debug_logging=True,
                      start_values=spec["start"])
print("RESULT " + json.dumps({name: result[name].tolist() for name in result.dtype.names}))
'''


@pytest.fixture(scope="module")
def fmus(built_fmus):
    """The folder of the FMUs built once per session."""
    assert (built_fmus / "DriveMotor.fmu").is_file()
    return built_fmus


@pytest.fixture(scope="module")
def simulate(fmus):
    """simulate(start_values, stop, step) -> dict of numpy arrays; asserts that the run reached the stop time."""
    def run(start, stop, step):
        result, _ = fmu_helpers.run_json_script(SIMULATE, dict(fmu=str(fmus / "DriveMotor.fmu"), start=start, stop=stop, step=step),
                               fmus)
        result = {name: np.array(values) for name, values in result.items()}
        assert result["time"][-1] == pytest.approx(stop, abs=step / 2), "the run stopped early (a discarded step)"
        return result
    return run


# ------------------------------------------------------------------------------------------------------------
# validators and the modelDescription

def test_fmpy_validate_reports_nothing(fmus):
    process = subprocess.run([sys.executable, "-m", "fmpy", "validate", str(fmus / "DriveMotor.fmu")],
                             capture_output=True, text=True, timeout=120)
    assert process.returncode == 0 and process.stdout.strip() == "No problems found.", process.stdout


def test_fmutool_check_reports_nothing(fmus):
    process = subprocess.run(
        [sys.executable, "-c", "import sys; from fmu_manipulation_toolbox.cli.fmutool import fmutool; "
                               "sys.exit(fmutool())", "-input", str(fmus / "DriveMotor.fmu"), "-check"],
        capture_output=True, text=True, timeout=120)
    output = process.stdout + process.stderr
    assert process.returncode == 0, output
    assert "No semantic error" in output and "compliant with FMI-2.0" in output, output
    assert not [line for line in output.splitlines() if line.startswith(("ERROR", "WARNING"))], output


def test_model_description_has_units_ranges_and_descriptions(fmus):
    with zipfile.ZipFile(fmus / "DriveMotor.fmu") as archive:
        root = ElementTree.fromstring(archive.read("modelDescription.xml"))
    assert root.find("CoSimulation").get("modelIdentifier") == "DriveMotor"
    assert root.find("CoSimulation").get("canHandleVariableCommunicationStepSize") == "true"   # ECCO needs it
    variables = {v.get("name"): v for v in root.find("ModelVariables")}
    expected_units = {"load_torque": "N.m", "voltage": "V", "rated_power": "W", "rated_speed": "rpm",
                      "supply_frequency": "Hz", "breakdown_torque_ratio": "1", "armature_resistance": "Ohm",
                      "armature_inductance": "H", "torque_constant": "N.m/A", "motor_inertia": "kg.m2",
                      "load_inertia": "kg.m2", "initial_speed": "rpm", "shaft_speed": "rpm", "motor_torque": "N.m",
                      "electrical_power": "W", "efficiency": "1", "shaft_angle": "rad", "current": "A",
                      "electrical_energy": "J", "motor_work": "J"}
    for name, unit in expected_units.items():
        assert variables[name].find("Real").get("unit") == unit, name
    assert variables["motor_type"].find("String").get("start") == "induction"
    assert variables["pole_pairs"].find("Integer").get("start") == "2"
    assert {name for name, v in variables.items() if v.get("causality") == "input"} == {"load_torque", "voltage"}
    assert all(v.get("description") for v in variables.values())


# ------------------------------------------------------------------------------------------------------------
# induction motor

def test_induction_no_load_settles_at_synchronous_speed(simulate, check):
    """From rest without load the slip decays to 0: n -> 60 f / p (here f = 60 Hz, p = 3: 1200 rpm)."""
    nameplate = dict(INDUCTION, supply_frequency=60.0, pole_pairs=3, rated_speed=1150.0)
    result = simulate(nameplate, 0.3, 1e-3)
    check("induction no-load speed / (60 f/p) - 1", abs(result["shaft_speed"][-1] / 1200.0 - 1.0), 1e-4)
    assert abs(result["motor_torque"][-1]) < 1e-3


def test_induction_rated_load_settles_at_rated_speed(simulate, check):
    """With T_load = T_r = P_r / w_r the steady speed is the rated speed, the efficiency 1 - s_r."""
    w_s, t_r, *_ = kloss(**INDUCTION)
    result = simulate(dict(INDUCTION, initial_speed=1500.0, load_torque=t_r), 0.1, 1e-3)
    speed = result["shaft_speed"][-1]
    check("induction rated-load speed / rated_speed - 1", abs(speed / 1440.0 - 1.0), 1e-3)
    check("induction rated torque / (P_r/w_r) - 1", abs(result["motor_torque"][-1] / t_r - 1.0), 1e-3)
    check("induction air-gap power / (T_r w_s) - 1",
          abs(result["electrical_power"][-1] / (t_r * w_s) - 1.0), 1e-3)
    check("induction efficiency - (1 - s_r)", abs(result["efficiency"][-1] - 1440.0 / 1500.0), 1e-3)
    assert np.all(result["current"] == 0.0)


def test_induction_breakdown_torque_at_breakdown_slip(simulate, check):
    """At s = s_b = s_r (k + sqrt(k^2 - 1)) the Kloss curve peaks at T_b = k T_r (held there by T_load = T_b)."""
    w_s, t_r, t_b, s_b, _ = kloss(**INDUCTION)
    result = simulate(dict(INDUCTION, initial_speed=(1.0 - s_b) * w_s / RPM, load_torque=t_b), 1e-3, 1e-3)
    check("induction torque at s_b / (k T_r) - 1", abs(result["motor_torque"][-1] / t_b - 1.0), 1e-6)


def test_induction_generator_region(simulate):
    """Above synchronous speed (s < 0) the torque and the air-gap power are negative, the efficiency 0."""
    result = simulate(dict(INDUCTION, initial_speed=1550.0, motor_inertia=10.0), 1e-3, 1e-3)
    _, _, _, _, torque = kloss(**INDUCTION)
    assert result["motor_torque"][-1] == pytest.approx(torque(result["shaft_speed"][-1] * RPM), rel=1e-9)
    assert result["motor_torque"][-1] < 0 and result["electrical_power"][-1] < 0
    assert result["efficiency"][-1] == 0.0


@pytest.mark.parametrize("motor_type", ["induction", "dc"])
def test_start_up_from_rest_matches_the_closed_form(simulate, check, motor_type):
    """t = 0+: induction dw/dt = T(s=1)/J, T(1) = 2 T_b / (1/s_b + s_b); dc (i(0) = 0) di/dt = V/L, so over a
    short step i(h) = V/R (1 - exp(-R h/L)) (the back-emf is O(h^2) there)."""
    h = 1e-5
    if motor_type == "induction":
        _, _, t_b, s_b, _ = kloss(**INDUCTION)
        result = simulate({}, h, h)
        acceleration = result["shaft_speed"][-1] * RPM / h
        check("induction start-up acceleration / (T(1)/J) - 1",
              abs(acceleration / (2.0 * t_b / (1.0 / s_b + s_b) / INERTIA) - 1.0), 1e-3)
    else:
        result = simulate({"motor_type": "dc"}, h, h)
        v, r, l = DC["voltage"], DC["armature_resistance"], DC["armature_inductance"]
        check("dc start-up current / (V/R (1 - exp(-R h/L))) - 1",
              abs(result["current"][-1] / (v / r * (1.0 - math.exp(-r * h / l))) - 1.0), 1e-3)


# ------------------------------------------------------------------------------------------------------------
# DC motor

@pytest.mark.parametrize("load", [0.0, 2.5, 9.0])
def test_dc_steady_speed(simulate, check, load):
    """Steady state: i = T/K, w = (V - R T/K)/K."""
    v, r, _, k = DC.values()
    result = simulate({"motor_type": "dc", "load_torque": load}, 0.3, 1e-3)
    expected = (v - r * load / k) / k / RPM
    check("dc steady speed / ((V - R T/K)/K) - 1", abs(result["shaft_speed"][-1] / expected - 1.0), 1e-3)
    check("dc steady current - T/K [A]", abs(result["current"][-1] - load / k), 1e-3)


# ------------------------------------------------------------------------------------------------------------
# energy balance: electrical energy = work on the load + kinetic (and magnetic) energy + losses

def test_dc_energy_balance(simulate, check):
    """E_el = int T_load w dt + J (w1^2 - w0^2)/2 + int R i^2 dt + L i1^2/2, the losses from the current samples."""
    v, r, l, _ = DC.values()
    load = 2.5
    result = simulate({"motor_type": "dc", "load_torque": load}, 0.2, 1e-4)
    t, w, i = result["time"], result["shaft_speed"] * RPM, result["current"]
    supplied = result["electrical_energy"][-1]
    balance = (np.trapezoid(load * w, t) + 0.5 * INERTIA * (w[-1] ** 2 - w[0] ** 2) + np.trapezoid(r * i * i, t)
               + 0.5 * l * i[-1] ** 2)
    check("dc energy balance residual / E_el", abs(balance / supplied - 1.0), 1e-2)
    check("dc electrical_energy / int V i dt - 1", abs(supplied / np.trapezoid(v * i, t) - 1.0), 1e-3)
    check("dc motor_work / (work on load + kinetic) - 1",
          abs(result["motor_work"][-1] / (np.trapezoid(load * w, t) + 0.5 * INERTIA * w[-1] ** 2) - 1.0), 1e-3)


def test_induction_energy_balance(simulate, check):
    """E_el = int T w_s dt = int T_load w dt + J (w1^2 - w0^2)/2 + slip losses int T (w_s - w) dt."""
    w_s, *_ = kloss(**INDUCTION)
    load = 2.5
    result = simulate({"load_torque": load}, 0.3, 1e-4)
    t, w, torque = result["time"], result["shaft_speed"] * RPM, result["motor_torque"]
    supplied = result["electrical_energy"][-1]
    balance = (np.trapezoid(load * w, t) + 0.5 * INERTIA * (w[-1] ** 2 - w[0] ** 2)
               + np.trapezoid(torque * (w_s - w), t))
    check("induction energy balance residual / E_el", abs(balance / supplied - 1.0), 1e-2)


# ------------------------------------------------------------------------------------------------------------
# integration: fixed-size RK4 substeps bounded by the stiffest time scale, whatever the communication step

@pytest.mark.parametrize("motor_type", ["induction", "dc"])
def test_large_communication_steps_match_small_ones(simulate, check, motor_type):
    """One 60 ms step (RK4 substeps <= h_max) gives the state of 600 steps of 0.1 ms; a 1 s step stays stable."""
    start = {"motor_type": motor_type, "load_torque": 2.5}
    fine = simulate(start, 0.06, 1e-4)
    coarse = simulate(start, 0.06, 0.06)
    check("speed after one 60 ms step / after 600 steps of 0.1 ms - 1",
          abs(coarse["shaft_speed"][-1] / fine["shaft_speed"][-1] - 1.0), 1e-3)
    huge = simulate(start, 1.0, 1.0)
    assert abs(huge["shaft_speed"][-1] / simulate(start, 1.0, 1e-2)["shaft_speed"][-1] - 1.0) < 1e-6


# ------------------------------------------------------------------------------------------------------------
# state save/restore and serialization (all states, including the DC current)

STATE = r'''
import base64, json, sys
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave
spec = json.loads(sys.argv[1])
md = read_model_description(spec["fmu"])
vr = {v.name: v.valueReference for v in md.modelVariables}
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(spec["fmu"]), modelIdentifier="DriveMotor", instanceName="m")
fmu.instantiate(loggingOn=True)
fmu.setupExperiment(startTime=0.0)
fmu.enterInitializationMode()
fmu.setString([vr["motor_type"]], ["dc"])
fmu.setReal([vr["load_torque"]], [2.5])
fmu.exitInitializationMode()
OUT = [vr[n] for n in ("shaft_speed", "current", "shaft_angle", "electrical_energy", "motor_work")]

def advance(t, n):
    values = []
    for k in range(n):
        fmu.doStep(t + k * 1e-3, 1e-3)
        values.append(fmu.getReal(OUT))
    return values

result = {}
if spec["serialized"] is None:
    advance(0.0, 10)
    state = fmu.getFMUstate()
    result["serialized"] = base64.b64encode(fmu.serializeFMUstate(state)).decode()
    result["first"] = advance(0.01, 10)
    fmu.setFMUstate(state)
    result["again"] = advance(0.01, 10)
else:
    fmu.setFMUstate(fmu.deSerializeFMUstate(base64.b64decode(spec["serialized"])))
    result["restored"] = advance(0.01, 10)
fmu.terminate()
fmu.freeInstance()
print("RESULT " + json.dumps(result))
'''


def test_state_get_set_and_serialization_across_processes(fmus):
    fmu = str(fmus / "DriveMotor.fmu")
    first, _ = fmu_helpers.run_json_script(STATE, dict(fmu=fmu, serialized=None), fmus)
    assert first["again"] == first["first"]               # fmi2SetFMUstate rolls back every state exactly
    assert first["first"][0][1] > 1.0                       # the current is part of the state
    second, _ = fmu_helpers.run_json_script(STATE, dict(fmu=fmu, serialized=first["serialized"]), fmus)
    assert second["restored"] == first["first"]             # a state serialized in one process, restored in another


# ------------------------------------------------------------------------------------------------------------
# bad input: a clear message (name, value, allowed range) and a discarded step, never an exception in pythonfmu

ERRORS = r'''
import json, math, sys
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave
spec = json.loads(sys.argv[1])
md = read_model_description(spec["fmu"])
vr = {v.name: (v.valueReference, v.type) for v in md.modelVariables}
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(spec["fmu"]), modelIdentifier="DriveMotor", instanceName="m")
fmu.instantiate(loggingOn=True)
setters = {"Real": fmu.setReal, "Integer": fmu.setInteger, "String": fmu.setString}
outcomes = []
for case in spec["cases"]:
    fmu.reset()                                       # one instance per process (pythonfmu), reset between cases
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    for name, value in case["parameters"].items():
        setters[vr[name][1]]([vr[name][0]], [float(value) if value == "nan" else value])
    try:
        fmu.exitInitializationMode()
        steps = ["ok"]
    except Exception as error:
        steps = [str(error)]
    for k, inputs in enumerate(case["steps"]):
        for name, value in inputs.items():
            fmu.setReal([vr[name][0]], [float(value)])
        try:
            fmu.doStep(case["times"][k], case.get("sizes", [1e-3] * len(case["steps"]))[k])
            steps.append("ok")
        except Exception as error:
            steps.append(str(error))
        print(f"CASE-STEP {len(outcomes)} {k}", file=sys.stderr, flush=True)
    outcomes.append(steps)
print("RESULT " + json.dumps(outcomes))
'''

BAD_PARAMETERS = [  # (parameters, words the message must contain)
    ({"motor_type": "ac"}, ["'motor_type'", "'ac'", "induction, dc"]),
    ({"rated_speed": 1600.0}, ["'rated_speed'", "1600", "(0, 1500) rpm"]),
    ({"breakdown_torque_ratio": 1.0}, ["'breakdown_torque_ratio'", "1.0", "[1.01, 10]"]),
    ({"pole_pairs": 0}, ["'pole_pairs'", "= 0", "[1, 50]"]),
    ({"motor_type": "dc", "armature_inductance": 0.0}, ["'armature_inductance'", "0.0", "[1e-09, 10] H"]),
    ({"motor_inertia": 0.0, "load_inertia": 0.0}, ["motor_inertia + load_inertia", "allowed > 0 kg.m2"]),
    ({"initial_speed": "nan"}, ["'initial_speed'", "nan", "[-100000, 100000] rpm"]),
]


def test_bad_parameters_and_inputs_give_clear_messages(fmus):
    cases = [dict(parameters=p, steps=[{}], times=[0.0]) for p, _ in BAD_PARAMETERS]
    cases.append(dict(parameters={}, steps=[{"load_torque": "nan"}, {"load_torque": 1.0}], times=[0.0, 0.0]))
    cases.append(dict(parameters={}, steps=[{}, {}], times=[0.0, 0.0], sizes=[1e4, 1e-3]))   # 7e6 substeps
    cases.append(dict(parameters={}, steps=[{}, {}], times=[0.0, 0.5]))         # t = 0.5 s skips model time
    outcomes, process = fmu_helpers.run_json_script(ERRORS, dict(fmu=str(fmus / "DriveMotor.fmu"), cases=cases), fmus)
    messages = process.stderr.split("CASE-STEP")
    for index, (_, words) in enumerate(BAD_PARAMETERS):        # fmi2Error at initialization and at the step
        assert "error" in outcomes[index][0] and "error" in outcomes[index][1], outcomes[index]
        for word in words:
            assert word in messages[index], (word, messages[index])
    bad_input, repeated = outcomes[-3], messages[len(BAD_PARAMETERS)]
    assert bad_input[0] == "ok" and "discard" in bad_input[1] and bad_input[2] == "ok"   # that step only
    assert "input 'load_torque' = nan N.m is invalid" in repeated and "[-1e+06, 1e+06] N.m" in repeated
    assert "discard" in outcomes[-2][1] and outcomes[-2][2] == "ok"      # a step too large: retry a shorter one
    assert "communication step size = 10000.0 s is too large: allowed up to 1377.03 s" in process.stderr
    assert outcomes[-1][:2] == ["ok", "ok"] and "error" in outcomes[-1][2]     # a time gap: misuse
    assert "does not continue the model time" in process.stderr
    assert "Traceback" not in process.stderr and "fatal" not in process.stdout.lower()


AFTER_THE_COMPRESSOR = '''
import json
from fmpy import simulate_fmu
compressor = simulate_fmu(FOLDER + "/RotaryVaneCompressor.fmu", stop_time=0.01, output_interval=1e-3)
motor = simulate_fmu(FOLDER + "/DriveMotor.fmu", stop_time=0.01, output_interval=1e-3)
print("RESULT " + json.dumps([len(compressor), len(motor), float(motor["shaft_speed"][-1])]))
'''


def test_the_motor_runs_after_the_compressor_in_one_process(fmus):
    """Both FMUs bundle the same package; simulate_fmu deletes the compressor's folder after its run, and the
    motor's instantiation must still find its own module (it used to fail as fmi2Fatal: no module ...motor)."""
    done = subprocess.run([sys.executable, "-c", f"FOLDER = {str(fmus)!r}\n" + AFTER_THE_COMPRESSOR],
                          capture_output=True, text=True, timeout=300, cwd=fmus)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
    rows_compressor, rows_motor, speed = json.loads(lines[-1][len("RESULT "):])
    assert rows_compressor == rows_motor == 11 and speed > 0.0
