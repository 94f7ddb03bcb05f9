"""The FMI 2.0 status contract of the built FMUs: every row of the README's contract table, checked through fmpy.

The README's table (rows C1..C26: a call and situation, the status) is the specification: this file reads it, runs
each row's situations against the built FMU in host processes (tests/fmu_helpers.py; rows C16-C22, which concern
the FMU's C shim, through tests/fmu_shim_cases.py) and checks that every situation returns the row's status (for
fmi2Instantiate: an instance or NULL). It also checks what each row says follows: nothing is set, the model state
after a refused call is byte for byte the state before it, a pickle handed in as a state runs nothing, a discarded
step can be retried, the error state is left by fmi2SetFMUstate and fmi2Reset; and what a user sees of a bad
parameter in fmpy.simulate_fmu and in libcosim.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

import fmu_helpers as H
import fmu_shim_cases as S
from test_fmu_compressor import script

README = Path(__file__).resolve().parents[2] / "README.md"
ROW = re.compile(r"^\s*\| (C\d+) \| (.+?) \| (fmi2OK|fmi2Warning|fmi2Discard|fmi2Error|fmi2Fatal|an instance|NULL) "
                 r"\| (.+?) \|\s*$", re.M)
STATUS = {"fmi2OK": H.OK, "fmi2Warning": H.WARNING, "fmi2Discard": H.DISCARD, "fmi2Error": H.ERROR,
          "fmi2Fatal": H.FATAL, S.INSTANCE: S.INSTANCE, S.NULL: S.NULL}


def contract_rows() -> dict[str, int | str]:
    """row -> status (or what fmi2Instantiate returns), from the README's table."""
    return {row: STATUS[status] for row, _, status, _ in ROW.findall(README.read_text(encoding="utf-8"))}


def status_name(status: int | str) -> str:
    return H.STATUS_NAMES[status] if isinstance(status, int) else status


# host side: shared by the scripts below --------------------------------------------------------------------------
PRELUDE = """
import ctypes, math, os, pickle, struct, zlib
import fmu_helpers as H
from ctypes import byref, c_char_p, c_double, c_int, c_uint
from fmpy.fmi1 import FMICallException

out = {}

def record(row, label, status):
    out.setdefault(row, []).append([label, int(status)])

def status(call):
    try:
        result = call()
        return result if isinstance(result, int) else H.OK
    except FMICallException as error:
        return error.status

def raw(f, function, *args):
    return status(lambda: getattr(f, function)(f.component, *args))

def direct(f, function, argtypes, *args):
    # the FMU's function called without fmpy's wrapper (whose call logger would dereference null pointers)
    prototype = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, *argtypes)((function, f.dll))
    return prototype(f.component, *args)

def refs(f, vr, names):
    return (c_uint * len(names))(*[vr[n] if isinstance(n, str) else n for n in names])

def get_reals(f, vr, names):
    values = (c_double * len(names))()
    return raw(f, "fmi2GetReal", refs(f, vr, names), len(names), values), list(values)

def set_real(f, vr, name, value):
    return raw(f, "fmi2SetReal", refs(f, vr, [name]), 1, (c_double * 1)(value))

def blob(f):
    state = f.getFMUstate()
    data = bytes(f.serializeFMUstate(state))
    f.freeFMUstate(state)
    return data

def step(f, t, h):
    return raw(f, "fmi2DoStep", t, h, 1)
"""

MISUSE = PRELUDE + """
host = H.Host($fmu)
f, vr = host.fmu, {name: v.valueReference for name, v in host.variables.items()}

# C3 and C20 before initialization; each refusal is followed by fmi2Reset (row C9)
for label, call in [
        ("getReal in the instantiated state", lambda: get_reals(f, vr, ["shaft_torque"])[0]),
        ("doStep in the instantiated state", lambda: step(f, 0.0, 1e-3)),
        ("exitInitializationMode without enter", lambda: raw(f, "fmi2ExitInitializationMode")),
        ("terminate in the instantiated state", lambda: raw(f, "fmi2Terminate")),
        ("doStep in initialization mode", lambda: (f.setupExperiment(startTime=0.0), f.enterInitializationMode(),
                                                    step(f, 0.0, 1e-3))[2])]:
    record("C3", label, call())
    record("C9", f"fmi2Reset after '{label}'", status(f.reset))
record("C20", "fmi2GetStatus before initialization", raw(f, "fmi2GetStatus", 0, byref(c_int())))
record("C9", "fmi2Reset after fmi2GetStatus", status(f.reset))

assert host.initialize(**H.OPERATING_POINT) == H.OK
assert step(f, 0.0, 1e-3) == H.OK
good, good_blob, t = f.getFMUstate(), blob(f), 1e-3

def refused(row, label, call, leave=True):
    # the call's status; the model state must be the one before it; fmi2SetFMUstate leaves the error state
    record(row, label, call())
    record("unchanged", label, blob(f) == good_blob)
    if leave:
        record("C9", f"fmi2SetFMUstate after '{label}'", status(lambda: f.setFMUstate(good)))

# C4: writes that may not happen, reads of what does not exist; then C8: the error state, C9: what it allows
refused("C4", "setReal of an output", lambda: set_real(f, vr, "shaft_torque", 1.0), leave=False)
for label, call in [("doStep", lambda: step(f, t, 1e-3)),
                    ("setReal of the input", lambda: set_real(f, vr, "shaft_speed", 1000.0)),
                    ("setupExperiment", lambda: raw(f, "fmi2SetupExperiment", 0, 0.0, 0.0, 0, 0.0)),
                    ("enterInitializationMode", lambda: raw(f, "fmi2EnterInitializationMode")),
                    ("exitInitializationMode", lambda: raw(f, "fmi2ExitInitializationMode")),
                    ("terminate", lambda: raw(f, "fmi2Terminate"))]:
    record("C8", f"{label} in the error state", call())
error_messages = [m for _, _, m in host.messages()]
for label, call in [("getReal", lambda: get_reals(f, vr, ["shaft_torque"])[0]),
                    ("getFMUstate and serialize", lambda: (blob(f), H.OK)[1])]:
    record("C9", f"{label} in the error state", call())
record("C9", "fmi2SetFMUstate in the error state", status(lambda: f.setFMUstate(good)))
refused("C4", "setReal of a fixed parameter after initialization", lambda: set_real(f, vr, "slot_clearance", 1e-4),
        leave=False)
record("C9", "getReal of the refused parameter", get_reals(f, vr, ["slot_clearance"])[0])
out["slot_clearance after the refused write"] = get_reals(f, vr, ["slot_clearance"])[1][0]
record("C9", "fmi2SetFMUstate", status(lambda: f.setFMUstate(good)))
refused("C4", "setInteger of a fixed parameter after initialization",
        lambda: raw(f, "fmi2SetInteger", refs(f, vr, ["lobes"]), 1, (c_int * 1)(5)))
refused("C4", "setString of a fixed parameter after initialization",
        lambda: raw(f, "fmi2SetString", refs(f, vr, ["pressure_model"]), 1, (c_char_p * 1)(b"real_gas")))
refused("C4", "getReal of an unknown value reference", lambda: get_reals(f, vr, [987654])[0])
refused("C4", "setReal of an unknown value reference", lambda: set_real(f, vr, 987654, 1.0))
refused("C4", "getReal of a String variable", lambda: get_reals(f, vr, ["displacement_law"])[0])
refused("C4", "setReal of an Integer parameter", lambda: set_real(f, vr, "lobes", 3.0))
refused("C5", "setString of bytes that are not UTF-8", lambda: raw(
    f, "fmi2SetString", refs(f, vr, ["displacement_law"]), 1, (c_char_p * 1)(b"harm\\xff\\xfeonic")))
refused("C5", "setReal with null pointers", lambda: direct(
    f, "fmi2SetReal", [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p], None, 1, None))
refused("C5", "setFMUstate of a null state", lambda: direct(f, "fmi2SetFMUstate", [ctypes.c_void_p], None))
refused("C3", "setupExperiment after initialization", lambda: raw(f, "fmi2SetupExperiment", 0, 0.0, 5.0, 0, 0.0))
refused("C3", "enterInitializationMode after initialization", lambda: raw(f, "fmi2EnterInitializationMode"))
for h in (0.0, -1e-3, math.nan, math.inf):
    refused("C6", f"doStep with the step size {h!r}", lambda: step(f, t, h))
for point in (t + 5e-3, 0.0, math.nan, t + 1e-12):
    refused("C7", f"doStep at {point!r} instead of {t!r}", lambda: step(f, point, 1e-3))

# C12: state bytes that are not a state of this build; a pickle must not run
marker = $marker

class Payload:
    def __reduce__(self):
        return (os.system, (f"touch {marker}",))

payload = good_blob[96:]
tag = good_blob[24:96]
def envelope(body, version=2, tag=tag):
    return b"RVFMUSTATE" + struct.pack("<HQI", version, len(body), zlib.crc32(body)) + tag + body
changed = bytearray(good_blob); changed[200] ^= 1
for label, data in [("junk", b"junk"), ("nothing", b""), ("a pickle whose loading runs a command", pickle.dumps(Payload())),
                    ("the state truncated", good_blob[:-10]), ("the state extended", good_blob + b"0"),
                    ("one byte changed", bytes(changed)), ("format version 7", envelope(payload, version=7)),
                    ("another build's tag", envelope(payload, tag=b"RotaryVaneCompressor/rotary_vane_0_0_1".ljust(72, bytes(1)))),
                    ("a checked envelope around a malformed description", envelope(b"\\x05\\x00\\x00\\x00{bad}")),
                    ("a checked envelope around a description of another shape", envelope(
                        struct.pack("<I", 11) + b'{"d":{}}   '))]:
    refused("C12", f"deSerializeFMUstate of {label}", lambda: status(lambda: f.deSerializeFMUstate(data)))
out["the pickle's command ran"] = os.path.exists(marker)
restored = f.deSerializeFMUstate(good_blob)
record("C9", "setFMUstate of the deserialized good state", status(lambda: f.setFMUstate(restored)))

# C10: a bad input discards the step, the state stays, a good input goes on
for speed in (-5.0, math.nan, 1e9):
    set_real(f, vr, "shaft_speed", speed)
    before = blob(f)
    record("C10", f"doStep with shaft_speed = {speed!r}", step(f, t, 1e-3))
    record("unchanged", f"after shaft_speed = {speed!r}", blob(f) == before)
set_real(f, vr, "shaft_speed", 1500.0)
record("C15", "doStep after the discarded steps, fixed input", step(f, t, 1e-3))
t += 1e-3
# C3 after fmi2Terminate
record("C15", "terminate", status(f.terminate))
record("C3", "doStep after terminate", step(f, t, 1e-3))
record("C9", "fmi2Reset after terminate", status(f.reset))
record("C15", "initialize after reset", host.initialize(**H.OPERATING_POINT))
record("C15", "doStep after reset", step(f, 0.0, 1e-3))
f.terminate()
record("C3", "setReal after terminate", set_real(f, vr, "shaft_speed", 1000.0))
record("messages", "all", 0)
out["messages"] = [m for _, _, m in host.messages()]
out["error state messages"] = error_messages
f.freeInstance()

# C10: the boundary inputs of the real-gas model: not a number > 0, outside the tables' range, a state the tables
# cannot hold
gas_host = H.Host($fmu)
g, gvr = gas_host.fmu, {name: v.valueReference for name, v in gas_host.variables.items()}
assert gas_host.initialize(**{**H.OPERATING_POINT, "pressure_model": "real_gas"}) == H.OK
assert step(g, 0.0, 1e-3) == H.OK
for name, value, good in (("suction_pressure", -1e5, 292800.0), ("discharge_pressure", math.nan, 1317900.0),
                          ("discharge_pressure", 3e7, 1317900.0), ("suction_pressure", math.inf, 292800.0),
                          ("suction_temperature", 240.0, 283.15)):
    set_real(g, gvr, name, value)
    before = blob(g)
    record("C10", f"real_gas doStep with {name} = {value!r}", step(g, 1e-3, 1e-3))
    record("unchanged", f"after {name} = {value!r}", blob(g) == before)
    set_real(g, gvr, name, good)
record("C15", "real_gas doStep after the discarded steps", step(g, 1e-3, 1e-3))
out["boundary messages"] = [m for _, _, m in gas_host.messages()]
gas_host.close()

# C27: a pressure-table model takes no other boundary than the one it was built for
table_host = H.Host($fmu)
assert table_host.initialize(**{**H.OPERATING_POINT, "pressure_model": "polytropic"}) == H.OK
table_host.set(discharge_pressure=1.4e6)
record("C27", "doStep of pressure_model polytropic with a changed discharge_pressure", table_host.step(0.0, 1e-3))
table_host.set(discharge_pressure=1317900.0)
record("C15", "doStep of pressure_model polytropic after the input is back", table_host.step(0.0, 1e-3))
out["table messages"] = [m for _, _, m in table_host.messages()]
table_host.close()
H.emit(out)
"""


@pytest.fixture(scope="module")
def misuse(fmu, env, tmp_path_factory):
    marker = tmp_path_factory.mktemp("pickle") / "the_state_blob_ran_a_command"
    return H.run_host(script(MISUSE, fmu=fmu, marker=marker), env=env).check().result


BAD_PARAMETER = """
import fmu_helpers as H
from fmpy import simulate_fmu
out = {"statuses": [], "messages": []}
host = H.Host($fmu)
for values in [{"restitution": 5.0}, {"vane_length": 0.03}, {"displacement_law": "x" * 100000},
               {"shaft_speed": -5.0}, {"lobes": 6, "stroke": 0.01, "friction_coefficient": 0.4}]:
    host.fmu.reset()
    out["statuses"].append(host.initialize(**{**H.OPERATING_POINT, **values}))
    out["statuses"].append(host.step(0.0, 1e-3))
    out["messages"].append([m for _, _, m in host.messages()])
    host.events.clear()
host.fmu.freeInstance()
try:
    simulate_fmu($fmu, stop_time=0.01, output_interval=1e-3, start_values={"restitution": 5.0})
    out["simulate_fmu"] = "returned"
except Exception as error:
    out["simulate_fmu"] = f"{type(error).__name__}: {error}"
H.emit(out)
"""


@pytest.fixture(scope="module")
def bad_parameters(fmu, env):
    return H.run_host(script(BAD_PARAMETER, fmu=fmu), env=env).check()


INTEGRATION_FAILURE = PRELUDE + """
host = H.Host($fmu)
f = host.fmu
# 15000 rpm behind a 5 mm2 discharge port: the leading chamber over-compresses out of the fluid's property table
# near t = 1.1 ms and the run stops there
assert host.initialize(**dict(H.OPERATING_POINT, shaft_speed=15000.0, pressure_model="real_gas",
                              discharge_port_area=5e-6)) == H.OK
assert step(f, 0.0, 1e-3) == H.OK
before = blob(f)
record("C11", "doStep of 1 ms across the failure", step(f, 1e-3, 1e-3))
out["unchanged"] = blob(f) == before
out["message"] = [m for _, _, m in host.messages()][-1]
record("C15", "a shorter retry that ends before the failure", step(f, 1e-3, 5e-5))
host.close()
H.emit(out)
"""

NO_GAS = PRELUDE + """
host = H.Host($fmu)
f, vr = host.fmu, {name: v.valueReference for name, v in host.variables.items()}
# a dead volume as large as the chamber: the gas never reaches the discharge pressure, nothing is delivered
assert host.initialize(shaft_speed=1500.0, pressure_model="real_gas", dead_volume=1e-4) == H.OK
statuses, t = [], 0.0
for k in range(100):
    statuses.append(step(f, t, 1e-3))
    t += 1e-3
for k, code in enumerate(statuses):
    if code != H.OK:
        record("C13", f"the doStep to t = {(k + 1) * 1e-3:.3f} s", code)
out["step statuses"] = statuses
for name in ("discharge_temperature", "discharge_mass_flow"):
    code, values = get_reals(f, vr, [name])
    out[name] = [code, values[0]]
record("C13", "getReal of discharge_temperature", out["discharge_temperature"][0])
out["messages"] = [m for s, _, m in host.messages() if s == H.WARNING][:3]
host.close()
H.emit(out)
"""


@pytest.fixture(scope="module")
def integration_failure(fmu, env):
    return H.run_host(script(INTEGRATION_FAILURE, fmu=fmu), env=env).check().result


@pytest.fixture(scope="module")
def no_gas(fmu, env):
    return H.run_host(script(NO_GAS, fmu=fmu), env=env, timeout=600).check().result


AT_BOUNDS = """
import fmu_helpers as H
host = H.Host($fmu)
out = {}
for name in $names:
    variable = host.variables[name]
    for bound in ("min", "max"):
        host.fmu.reset()
        value = float(getattr(variable, bound)) if variable.type == "Real" else int(getattr(variable, bound))
        status = host.initialize(**{name: value, **$related.get(f"{name}={bound}", {})})
        out[f"{name}={bound}"] = [status, [m for s, _, m in host.messages() if s >= H.ERROR]]
        host.events.clear()
host.fmu.freeInstance()
H.emit(out)
"""


SAFE_GLUE = PRELUDE + """
sys.path.append(str(H.TESTS_DIR / "fmu"))             # the crafting helper of the fuzz family
from test_fmu_fuzz import craft_blob
host = H.Host($fmu)
f, vr = host.fmu, {name: v.valueReference for name, v in host.variables.items()}

# C23: crafted state contents with a valid envelope
assert host.initialize(**H.OPERATING_POINT) == H.OK
assert step(f, 0.0, 1e-3) == H.OK
good, good_blob = f.getFMUstate(), blob(f)
control = ["model", "simulation", "control"]
for label, edit in [("a malformed start time {'f': []}", ["set", ["clock", "start_time"], {"f": []}]),
                    ("a clock elapsed of 1e6 s", ["set", ["clock", "elapsed"], [1000000, 1]]),
                    ("fidelity 'bogus'", ["set", ["model", "parameters", "fidelity"], "bogus"]),
                    ("initial_rotor_angle = 1e300", ["set", ["model", "parameters", "initial_rotor_angle"], 1e300]),
                    ("a map_values of 1e6 entries", ["entries", ["model", "map_values"], 1000000]),
                    ("an integrator step size of 0", ["step", control, 0.0]),
                    ("NaN in the window", ["nan", ["model", "simulation", "window"], -1])]:
    data = craft_blob(good_blob, edit)
    record("C23", f"deSerializeFMUstate of {label}", status(lambda: f.deSerializeFMUstate(data)))
    record("unchanged", label, blob(f) == good_blob)
    record("C9", f"setFMUstate after {label}", status(lambda: f.setFMUstate(good)))
out["C23 logged"] = "\\n".join(m for _, _, m in host.messages())

# C24: the work bound, lowered so that a step of 50 ms (about 3500 attempts) exceeds it
f.reset()
assert host.initialize(**H.OPERATING_POINT, work_bound=1.0) == H.OK
record("C15", "a step of 0.1 ms within the work bound", step(f, 0.0, 1e-4))
before = blob(f)
record("C24", "a step of 50 ms beyond the work bound", step(f, 1e-4, 5e-2))
out["C24 unchanged"] = blob(f) == before
out["C24 message"] = [m for _, _, m in host.messages()][-1]

# C25, C26: stopTime
f.reset()
record("C26", "stopTime before startTime", raw(f, "fmi2SetupExperiment", 0, 0.0, 0.0, 1, -1.0))
f.reset()
record("C26", "stopTime nan", raw(f, "fmi2SetupExperiment", 0, 0.0, 0.0, 1, math.nan))
f.reset()
record("C15", "setupExperiment with stopTime 0.005 s", raw(f, "fmi2SetupExperiment", 0, 0.0, 0.0, 1, 0.005))
host.set(**H.OPERATING_POINT)
f.enterInitializationMode()
f.exitInitializationMode()
for k in range(5):
    record("C15", f"doStep to {(k + 1) * 1e-3:g} s, before the stop time", step(f, k * 1e-3, 1e-3))
record("C25", "doStep from 0.005 s past the stop time", step(f, 5e-3, 1e-3))
out["C25 message"] = [m for _, _, m in host.messages()][-1]
host.fmu.freeInstance()
H.emit(out)
"""


@pytest.fixture(scope="module")
def safe_glue(fmu, env):
    run = H.run_host(script(SAFE_GLUE, fmu=fmu), env=env).check()
    return {**run.result, "stderr": run.stderr}


def bounded_parameters(fmu_path: Path) -> list[str]:
    from fmpy import read_model_description
    return [v.name for v in read_model_description(str(fmu_path)).modelVariables
            if v.causality == "parameter" and v.type in ("Real", "Integer") and v.min is not None]


@pytest.fixture(scope="module")
def at_bounds(built_fmus, env):
    """Every bounded parameter of both FMUs initialized at its min and at its max (the others at their defaults;
    for the motor's pole_pairs = 50 a rated speed below the synchronous speed of 60 rpm)."""
    runs = {}
    for model, related in (("RotaryVaneCompressor", {}), ("DriveMotor", {"pole_pairs=max": {"rated_speed": 50.0}})):
        path = built_fmus / f"{model}.fmu"
        runs[model] = H.run_host(script(AT_BOUNDS, fmu=path, names=bounded_parameters(path), related=related),
                                 env=env, timeout=600).check().result
    return runs


def refused_for_its_range(name: str, messages: list[str]) -> bool:
    """A message that refuses `name` for its declared range ('allowed [min, max]'), not for a relation."""
    return any(f"'{name}' = " in m and re.search(r"allowed (a finite value in |an integer in |integer in )?\[", m)
               for m in messages)


@pytest.fixture(scope="module")
def shim_cases(built_fmus, tmp_path_factory) -> dict:
    """Rows C14 and C16-C22 from the runs of tests/fmu_shim_cases.py (made once per session)."""
    fmu, folder = built_fmus / "RotaryVaneCompressor.fmu", S.cases_folder(tmp_path_factory)
    python_host, fatal = S.python_host_cases(fmu, folder), S.fatal_cases(fmu, folder)
    no_python = S.parse_c_host(S.no_python_run(fmu, folder).stdout)
    rows = {row: python_host.get(row, []) + fatal.get(row, []) for row in ("C14", "C16", "C17", "C18", "C20", "C21",
                                                                           "C22")}
    rows["C19"] = [["C host, ROTARY_VANE_PYTHON naming no interpreter",
                    S.NULL if no_python["not_ok_calls"] == ["CALL fmi2Instantiate -> NULL"] else S.INSTANCE]]
    return rows


def statuses_of_row(row, misuse, bad_parameters, integration_failure, no_gas, at_bounds, large_start_times,
                    shim_cases, safe_glue):
    """[(situation, status)] of one README row from every run."""
    found = [tuple(item) for item in misuse.get(row, []) + shim_cases.get(row, []) + safe_glue.get(row, [])]
    found += [tuple(item) for item in integration_failure.get(row, []) + no_gas.get(row, [])]
    if row == "C1":     # a bound refused for a relation with another parameter is row C2, not C1
        found += [(f"{model} {case}", status) for model, run in at_bounds.items()
                  for case, (status, messages) in run.items()
                  if status == H.OK or refused_for_its_range(case.split("=")[0], messages)]
    if row == "C2":
        statuses = bad_parameters.result["statuses"]
        found += [(f"bad parameter {k}: exitInitializationMode", s) for k, s in enumerate(statuses[0::2])]
    if row == "C8":
        statuses = bad_parameters.result["statuses"]
        found += [(f"bad parameter {k}: the doStep after it", s) for k, s in enumerate(statuses[1::2])]
    if row == "C15":
        found += [(case, status) for case, statuses in large_start_times["statuses"].items() for status in set(statuses)]
    return found


@pytest.mark.parametrize("row", sorted(contract_rows(), key=lambda r: int(r[1:])))
def test_contract_row(row, misuse, bad_parameters, integration_failure, no_gas, at_bounds, large_start_times,
                      shim_cases, safe_glue):
    """Every situation of the README's row returns the row's status."""
    expected = contract_rows()[row]
    found = statuses_of_row(row, misuse, bad_parameters, integration_failure, no_gas, at_bounds, large_start_times,
                            shim_cases, safe_glue)
    assert found, f"no situation of row {row} was run"
    wrong = [(label, status_name(status)) for label, status in found if status != expected]
    assert not wrong, f"row {row} says {status_name(expected)}: {wrong}"


def test_the_readme_table_has_the_rows_this_file_runs():
    assert sorted(contract_rows(), key=lambda r: int(r[1:])) == [f"C{k}" for k in range(1, 28)]


def test_crafted_states_the_work_bound_and_the_stop_time_say_why(safe_glue):
    """C23: the state is kept and the reason names the field, through the importer's logger and on stderr; C24:
    the discarded step names the work bound and leaves the state as before; C25: the stop time is named."""
    assert all(same for _, same in safe_glue["unchanged"]), safe_glue["unchanged"]
    for reason in ("parameter 'fidelity' = 'bogus' is invalid: allowed one of detailed, periodic_map",
                   "parameter 'initial_rotor_angle' = 1e+300 is out of range: allowed [-1000, 1000]",
                   "the clock's elapsed time 1000000.0 s is not the model's time 0.001 s",
                   "state field 'model.map_values' = ['k0', 'k1', 'k10'] is invalid",
                   "malformed state node {'f': []}", "state field 'control[step]' = 0.0 s is invalid",
                   "state field 'model.simulation.window' holds values that are not finite"):
        assert reason in safe_glue["stderr"], (reason, safe_glue["stderr"][-3000:])
        assert reason in safe_glue["C23 logged"], (reason, safe_glue["C23 logged"][-3000:])
    assert safe_glue["C24 unchanged"] is True
    assert "work bound" in safe_glue["C24 message"] and "state is as before the step" in safe_glue["C24 message"], \
        safe_glue["C24 message"]
    assert "past the stopTime = 0.005 s" in safe_glue["C25 message"], safe_glue["C25 message"]


def test_a_refusal_at_a_bound_names_the_parameter_that_was_set(at_bounds):
    """Every bounded parameter of both FMUs set to its min and to its max: a refusal (a relation with a parameter at
    its default) names the parameter that was set and its value (README row C2)."""
    wrong = [(model, case, messages) for model, run in at_bounds.items() for case, (status, messages) in run.items()
             if status != H.OK and not any(f"'{case.split('=')[0]}' = " in m for m in messages)]
    assert not wrong, wrong


def test_a_refused_call_changes_nothing_and_a_state_blob_runs_nothing(misuse, integration_failure):
    """After each refused call (C3-C7, C12) and each discarded step (C10, C11) the serialized model state is the
    one before the call; the refused write left the parameter as it was; the pickle ran nothing."""
    changed = [label for label, same in misuse["unchanged"] if not same]
    assert not changed and len(misuse["unchanged"]) >= 30, misuse["unchanged"]
    assert misuse["slot_clearance after the refused write"] == H.OPERATING_POINT["slot_clearance"]
    assert misuse["the pickle's command ran"] is False
    assert integration_failure["unchanged"] is True
    assert "discharge_port_area" in integration_failure["message"] and "state is as before the step" in \
        integration_failure["message"], integration_failure["message"]


def test_messages_name_the_state_and_the_cause(misuse):
    messages = "\n".join(misuse["messages"])
    assert "fmi2GetReal is not allowed in the instantiated state (allowed in: initialization mode, initialized, " \
           "terminated)" in messages
    assert "fmi2DoStep is not allowed in the terminated state" in messages
    assert "'shaft_torque' is an output, it cannot be set" in messages
    assert "parameter 'slot_clearance' is fixed after initialization" in messages
    assert "value reference 987654 does not exist" in messages
    assert "not valid UTF-8" in messages
    assert "communication step size = nan s is invalid: allowed a finite value > 0" in messages
    assert "does not continue the model time: allowed t = 0.001 s" in messages
    assert "input 'shaft_speed' = -5.0 rpm is invalid: allowed [0, 30000] rpm" in messages
    boundary = "\n".join(misuse["boundary messages"])
    assert "input 'suction_pressure' = -100000.0 Pa is out of range: allowed a finite number > 0" in boundary
    assert "input 'discharge_pressure' = 30000000.0 Pa is out of range: allowed (0, 2.11683e+06] Pa" in boundary
    assert "input 'suction_temperature' = 240.0 K is out of range: allowed a state inside the R134a property " \
           "table" in boundary
    assert any("input 'discharge_pressure' = 1400000.0 Pa is out of range: allowed 1317900.0 (the parameter's "
               "value): the pressure table of pressure_model 'polytropic' is built for one operating point" in m
               for m in misuse["table messages"]), misuse["table messages"]
    assert "no RVFMUSTATE header" in messages and "checksum mismatch" in messages and "version 7" in messages
    assert "another model or build" in messages and "content is not a state of this build" in messages
    in_error = [m for m in misuse["error state messages"] if "not allowed in the error state" in m]
    assert len(in_error) == 6 and all("fmi2SetReal returned fmi2Error" in m and "'shaft_torque' is an output" in m
                                      for m in in_error), in_error


def test_bad_parameters_name_what_the_user_set(bad_parameters):
    """C2's messages: the parameter, its value and the range; a long vane_length is blamed on vane_length, not on
    slot_bottom_radius; a 100 kB string is echoed cut to a readable length; a vane that would self-lock in its slot
    (docs/model.md §5.5) is refused naming friction_coefficient; simulate_fmu raises and prints it."""
    out = bad_parameters.result
    restitution, vane, string, speed, locking = ("\n".join(m) for m in out["messages"])
    assert "parameter 'restitution' = 5.0 is out of range: allowed [0.1, 1]" in restitution
    assert "parameter 'vane_length' = 0.03 is out of range: allowed < 0.0205 m" in vane and "slot_bottom_radius'" \
        not in vane
    assert "parameter 'displacement_law' = 'xxxx" in string and "(100002 characters)" in string
    assert max(len(m) for m in out["messages"][2]) < 600, [len(m) for m in out["messages"][2]]
    assert "input 'shaft_speed' = -5.0 rpm at initialization is invalid" in speed
    assert "parameter 'friction_coefficient' = 0.4 is out of range for this vane and profile: allowed < 0.3" in locking \
        and "self-locks in its slot" in locking, locking
    assert out["simulate_fmu"].startswith("FMICallException") and "ExitInitializationMode" in out["simulate_fmu"]
    # fmpy's default logger prints the reason: the shim passes errors on even with debug logging off
    assert "parameter 'restitution' = 5.0 is out of range" in bad_parameters.stdout, bad_parameters.stdout[-2000:]


def test_a_discarded_step_can_be_retried_shorter(integration_failure):
    assert H.STATUS_NAMES[integration_failure["C15"][0][1]] == "OK"


def test_undefined_figures_are_warned_about_not_returned_silently(no_gas):
    """C13: the NaN comes with fmi2Warning and the reason; the other steps are fmi2OK; the mass flow is a defined
    0 (nothing delivered), with fmi2OK."""
    # 0.1 s at 1500 rpm from the angle 0: two revolutions complete (at 0.04 and 0.08 s), two steps warn
    warned = [k for k, code in enumerate(no_gas["step statuses"]) if code != H.OK]
    assert len(warned) == 2 and set(no_gas["step statuses"]) == {H.OK, H.WARNING}, no_gas["step statuses"]
    assert no_gas["discharge_mass_flow"] == [H.OK, 0.0]
    assert no_gas["discharge_temperature"][0] == H.WARNING
    assert any("discharge_temperature = nan" in m and "delivered no gas" in m for m in no_gas["messages"]), \
        no_gas["messages"]


# C15: time that scales ------------------------------------------------------------------------------------------
LARGE_START_TIME = """
import fmu_helpers as H
from fractions import Fraction
from fmpy import simulate_fmu
out = {}
for start in (1e5, 1e9):
    for master in ("sum", "product"):
        host = H.Host($fmu)
        h, n = 1e-3, 300
        assert host.initialize(start_time=start, **H.OPERATING_POINT) == H.OK
        statuses, t = [], start
        for k in range(n):
            statuses.append(host.step(t, h))
            t = t + h if master == "sum" else start + (k + 1) * h
        out[f"fmpy low-level, start {start:g} s, t {'+= h' if master == 'sum' else '= t0 + n h'}"] = statuses
        angle = host.outputs()["shaft_angle"]
        out[f"angle fmpy {start} {master}"] = angle
        out[f"gap {start} {master}"] = host.step(t + 0.5 * h, h)        # half a step skipped: row C7
        host.close()
# simulate_fmu itself takes a stop time within math.isclose's 1e-9 relative tolerance as reached (1 s at 1e9 s)
result = H.simulate($fmu, start_time=1e5, stop_time=1e5 + 0.05, output_interval=1e-3, start_values=H.OPERATING_POINT)
out["fmpy simulate_fmu, start 1e5 s"] = [H.STATUS_NAMES.index(s) for s in result["statuses"]]
out["simulate_fmu rows"] = len(result["columns"]["time"])
H.emit(out)
"""

LIBCOSIM_START_TIME = """
import gc
from ctypes import POINTER, c_int64
import fmu_helpers as H
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy._internal import libcosimc
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimSlave import CosimLocalSlave
log_output_level(CosimLogLevel.WARNING)
create = libcosimc().cosim_execution_create
create.argtypes, create.restype = [c_int64, c_int64], POINTER(CosimExecution)
out = {}
start = 10 ** 18                                           # 1e9 s in libcosim's integer nanoseconds
execution = CosimExecution(CosimExecution._CosimExecution__create_key, create(start, 10 ** 6))
slave = CosimLocalSlave(fmu_path=$fmu, instance_name="compressor")
index = execution.add_local_slave(local_slave=slave)
refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
for name, value in H.OPERATING_POINT.items():
    if isinstance(value, str):
        execution.string_initial_value(index, refs[name], value)
    else:
        execution.real_initial_value(index, refs[name], value)
observer = CosimObserver.create_last_value()
execution.add_observer(observer)
ok = execution.simulate_until(start + 300 * 10 ** 6)
out["libcosim, start 1e9 s (1e18 ns), 300 steps of 1 ms"] = [H.OK if ok else H.ERROR]
out["angle libcosim"] = observer.last_real_values(index, [refs["shaft_angle"]])[0]
del observer, execution, slave
gc.collect()
H.emit(out)
"""


@pytest.fixture(scope="module")
def large_start_times(fmu, env):
    fmpy_run = H.run_host(script(LARGE_START_TIME, fmu=fmu), env=env, timeout=600).check().result
    libcosim_run = H.run_host(script(LIBCOSIM_START_TIME, fmu=fmu), env=env, timeout=600).check().result
    runs = {"statuses": {key: value for key, value in {**fmpy_run, **libcosim_run}.items() if isinstance(value, list)}}
    runs["angles"] = {key: value for key, value in {**fmpy_run, **libcosim_run}.items() if key.startswith("angle")}
    runs["gaps"] = [value for key, value in fmpy_run.items() if key.startswith("gap")]
    runs["simulate_fmu rows"] = fmpy_run["simulate_fmu rows"]
    return runs


def test_large_start_times_continue_and_keep_the_physics(large_start_times):
    """300 steps of 1 ms at 1500 rpm from start times of 1e5 and 1e9 s turn the rotor by 1500/60 * 2 pi * 0.3 rad
    (the physics does not see the start time: exactly with fmpy's steps of 1 ms; libcosim's steps are differences
    of its time points, resolved to 1.2e-7 s at 1e9 s), and a gap of half a step is still refused."""
    angles = large_start_times["angles"]
    expected = 1500 / 60 * 2 * 3.141592653589793 * 0.3
    for key, angle in angles.items():
        assert angle == pytest.approx(expected, rel=1e-9 if "fmpy" in key else 1e-6), (key, angle)
    assert len(angles) == 5 and set(large_start_times["gaps"]) == {H.ERROR}, large_start_times["gaps"]
    assert large_start_times["simulate_fmu rows"] == 51


@pytest.mark.parametrize("steps", [10 ** 6, pytest.param(10 ** 7, marks=pytest.mark.slow)])
def test_the_clock_is_exact_over_many_steps(steps):
    """The glue's clock (fmu_src/slave.py Clock) from 1e9 s over many steps of 1 ms, with the communication points
    and step sizes of three masters (t += h; t0 + n h; libcosim's integer nanoseconds converted to seconds, its step
    size the difference of two converted points): every point continues, and the model time is the exact sum of
    the step sizes."""
    from fractions import Fraction

    from rotary_vane.fmu_src.slave import Clock
    h, ns0, dns = 1e-3, 10 ** 18, 10 ** 6
    for master in ("sum", "product", "nanoseconds"):
        start = ns0 / 1e9 if master == "nanoseconds" else 1e9
        clock, t = Clock(start), start
        for k in range(steps):
            if master == "nanoseconds":
                following = (ns0 + (k + 1) * dns) / 1e9
                step = following - t
            else:
                following, step = (t + h if master == "sum" else start + (k + 1) * h), h
            assert clock.discontinuity(t) is None, (master, k, t, clock.next_point)
            clock.commit(t, step, clock.end_of(step))
            t = following
        expected = Fraction(t) - Fraction(start) if master == "nanoseconds" else steps * Fraction(h)
        assert clock.elapsed == expected, master


@pytest.mark.slow
def test_without_a_c_compiler_the_build_keeps_pythonfmu_and_says_what_is_lost(tmp_path, env):
    """CC pointing to a compiler that does not exist: the FMU is built with pythonfmu's binary, the build says why
    and what the FMU cannot report, and the FMU runs (a bad parameter is then fmi2OK at initialization)."""
    import subprocess
    import sys
    import zipfile
    done = subprocess.run([sys.executable, "-m", "rotary_vane.fmu_src.build", "--out", str(tmp_path)],
                          env={**env, "CC": str(tmp_path / "no-such-cc")}, capture_output=True, text=True,
                          timeout=300, cwd=H.PROJECT_DIR)
    assert done.returncode == 0, done.stderr
    assert "keeps pythonfmu's binary" in done.stderr and "cannot answer fmi2Error or fmi2Warning" in done.stderr
    assert "no-such-cc" in done.stderr
    fmu = tmp_path / "RotaryVaneCompressor.fmu"
    with zipfile.ZipFile(fmu) as archive:
        names = archive.namelist()
    assert "binaries/linux64/RotaryVaneCompressor.so" in names and not any("_pythonfmu" in n for n in names)
    run = H.run_host(script("""
import fmu_helpers as H
host = H.Host($fmu)
H.emit({"good": host.initialize(**H.OPERATING_POINT), "step": host.step(0.0, 1e-3)})
host.fmu.reset()
H.emit({"bad": host.initialize(restitution=5.0), "messages": [m for _, _, m in host.messages()]})
host.fmu.freeInstance()
""", fmu=fmu), env=env).check()
    assert run.results[0] == {"good": H.OK, "step": H.OK}
    assert run.results[1]["bad"] == H.OK and any("'restitution' = 5.0" in m for m in run.results[1]["messages"])


LIBCOSIM_BAD_PARAMETER = """
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimSlave import CosimLocalSlave
log_output_level(CosimLogLevel.WARNING)
execution = CosimExecution.from_step_size(step_size=10 ** 6)
index = execution.add_local_slave(local_slave=CosimLocalSlave(fmu_path=$fmu, instance_name="compressor"))
refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
execution.real_initial_value(index, refs["restitution"], 5.0)
print("simulate_until returned", execution.simulate_until(10 ** 7), flush=True)
"""


def test_libcosim_shows_the_bad_parameter(fmu, env):
    """What libcosim 0.0.6 shows of a bad parameter (README): the FMU's message, then libcosim aborts the process
    (its thread pool lets the error of fmi2ExitInitializationMode escape); the message names the parameter."""
    run = H.run_host(script(LIBCOSIM_BAD_PARAMETER, fmu=fmu), env=env)
    text = run.stdout + run.stderr
    assert "initialization refused: parameter 'restitution' = 5.0 is out of range: allowed [0.1, 1]" in text
    assert "Model error: initialization refused: parameter 'restitution' = 5.0" in text, text[-2000:]
    print(f"\nlibcosim exit status {run.returncode}; simulate_until returned: "
          f"{'simulate_until returned' in run.stdout}")
