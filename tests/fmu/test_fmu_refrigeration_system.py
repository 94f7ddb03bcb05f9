"""Motor + compressor + refrigeration loop as one system (fmu_src/systems/OspSystemStructure_refrigeration.xml and
RefrigerationSystem.ssd, examples/refrigeration_system.py), with the FMUs built once per session:

* the SSD passes the SSP 1.0 schema (pyssp-standard), its connections are legal and complete, and they are the OSP
  file's (one system in two formats);
* libcosim loads each file and runs it a few steps from standstill: the compressor accepts the loop's equal
  pressures, the motor turns, the pressures start to separate;
* examples/refrigeration_system.py runs the system in fmpy for 0.12 s (a subprocess, as a user runs it):
  the refrigerant in loop + chambers (drawn - delivered) stays the start's to 1e-9, the motor turns the shaft, p_d
  rises and p_s falls from the equal pressures of the start;
* (slow) the system run to steady state agrees with an independent steady cycle from CoolProp states
  (examples/steady_cycle.py) on capacity and COP within 1 %.
* (slow) the start-up with the compressor's fluid periodic map shipped reaches the detailed model's steady
  p_s, p_d, mass flow, capacity and COP within 1 %.
"""
from __future__ import annotations

import csv
import json
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

import fmu_helpers as H

OSP_FILE, SSD_FILE = "OspSystemStructure_refrigeration.xml", "RefrigerationSystem.ssd"
OSP = {"osp": "http://opensimulationplatform.com/MSMI/OSPSystemStructure"}


def osp_connections(path) -> set:
    root = ElementTree.parse(path).getroot()
    found = set()
    for connection in root.iterfind("osp:Connections/osp:VariableConnection", OSP):
        ends = {variable.get("causality"): (variable.get("simulator"), variable.get("name"))
                for variable in connection.iterfind("osp:Variable", OSP)}
        found.add((*ends["output"], *ends["input"]))
    return found


def test_ssd_is_valid_ssp_and_is_the_osp_files_system(built_fmus):
    from pyssp_standard.ssd import SSD
    with SSD(built_fmus / SSD_FILE) as ssd:
        ssd.__check_compliance__()                       # raises on a schema violation
        assert ssd.check_connections(unconnected_inputs=True, connector_not_in_system=True) == []
        connections = {(c.start_element, c.start_connector, c.end_element, c.end_connector)
                       for c in ssd.connections()}
    assert connections == osp_connections(built_fmus / OSP_FILE)
    fluid = {("loop", name, "compressor", name) for name in ("suction_pressure", "suction_enthalpy",
                                                              "discharge_pressure")} | \
            {("compressor", name, "loop", name) for name in ("drawn_mass", "drawn_enthalpy", "delivered_mass",
                                                              "delivered_enthalpy")}
    assert fluid <= connections and ("motor", "shaft_speed", "compressor", "shaft_speed") in connections


LIBCOSIM = r'''
import gc, json, sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver
spec = json.loads(sys.argv[1])
log_output_level(CosimLogLevel.WARNING)
result = {}
for file in spec["files"]:
    path = f"{spec['folder']}/{file}"
    execution = CosimExecution.from_ssp_file(path) if path.endswith(".ssd") else \
        CosimExecution.from_osp_config_file(path)
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    index = {info.name.decode(): info.index for info in execution.slave_infos()}
    def read(component, *names):
        references = {v.name.decode(): v.reference for v in execution.slave_variables(index[component])}
        return observer.last_real_values(index[component], [references[n] for n in names])
    ok = execution.simulate_until(round(spec["stop_time"] * 1e9))
    result[file] = dict(ok=bool(ok), speed=read("motor", "shaft_speed")[0],
                        pressures=read("loop", "suction_pressure", "discharge_pressure"),
                        flows=read("compressor", "drawn_mass", "delivered_mass"))
    del observer, execution
    gc.collect()
print("RESULT " + json.dumps(result))
'''


def test_libcosim_runs_both_files_from_standstill(built_fmus):
    result, _ = H.run_json_script(LIBCOSIM, dict(folder=str(built_fmus), files=[OSP_FILE, SSD_FILE],
                                                 stop_time=0.02), built_fmus)
    for file, run in result.items():
        assert run["ok"], file
        assert run["speed"] > 10.0, (file, run)                          # the motor started the shaft
        p_s, p_d = run["pressures"]
        assert p_d > p_s, (file, run)                                      # the compressor lifts the pressure
    assert result[OSP_FILE] == result[SSD_FILE]                           # one system, one result


@pytest.fixture(scope="module")
def example_run(built_fmus, tmp_path_factory):
    out = tmp_path_factory.mktemp("refrigeration_system")
    done = subprocess.run([sys.executable, str(H.PROJECT_DIR / "examples" / "refrigeration_system.py"),
                           "--fmu-dir", str(built_fmus), "--out", str(out), "--duration", "0.12",
                           "--window-revolutions", "1"], cwd=out, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    with open(out / "refrigeration_system.csv") as stream:
        rows = list(csv.reader(stream))
    columns = {name: np.array([float(row[i]) for row in rows[1:]]) for i, name in enumerate(rows[0])}
    return columns, json.loads((out / "summary.json").read_text()), out


def test_example_keeps_the_charge_and_moves_the_pressures_apart(example_run):
    c, summary, out = example_run
    for name in ("refrigeration_system.png", "cycle_ph.png"):
        assert (out / name).stat().st_size > 10_000
    chambers = c["compressor.drawn_mass"] - c["compressor.delivered_mass"]
    charge = c["loop.refrigerant_charge_in_loop"] + chambers
    assert np.max(np.abs(charge / charge[0] - 1.0)) < 1e-9
    assert np.max(np.abs(chambers)) > 1e-8                                # the chambers' content did change
    assert summary["charge balance: max |loop + chambers - start| / start"] < 1e-9
    p_s, p_d = c["loop.suction_pressure"], c["loop.discharge_pressure"]
    assert p_s[0] == p_d[0]                                               # standstill: equal pressures
    assert p_d[-1] > p_d[0] and p_s[-1] < p_s[0], (p_s[-1], p_d[-1])
    assert c["motor.shaft_speed"][-1] > 100.0 and c["motor.motor_torque"].max() > 0.0


def run_example(fmus, out, *options) -> dict:
    done = subprocess.run([sys.executable, str(H.PROJECT_DIR / "examples" / "refrigeration_system.py"),
                           "--fmu-dir", str(fmus), "--out", str(out), *options], cwd=out.parent,
                          capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return json.loads((out / "summary.json").read_text())


def test_dc_motor_replaces_the_files_induction_motor_in_both_engines(built_fmus, tmp_path):
    """--motor dc overrides the file's motor_type in fmpy and in libcosim (an initial value set on the execution):
    the run reports an armature current, and its peak torque is the torque constant (0.28 N.m/A, the motor FMU's
    default) times its peak current, T = K i, through the inrush from standstill (L/R = 3.3 ms). 0.1 s: two shaft
    revolutions, the fewest the summary's windows need."""
    for engine in ("fmpy", "libcosim"):
        summary = run_example(built_fmus, tmp_path / engine, "--duration", "0.1", "--window-revolutions", "1",
                              "--motor", "dc", *(("--libcosim",) if engine == "libcosim" else ()))
        assert summary["motor"] == "dc", engine
        current = summary["peak motor current [A] (dc motor; 0: induction)"]
        assert current > 50.0, (engine, current)
        assert summary["peak motor torque [N.m]"] == pytest.approx(0.28 * current, rel=1e-9), engine


@pytest.mark.slow
def test_fmpy_and_libcosim_agree_over_the_first_seconds(built_fmus, tmp_path):
    """3 s from standstill (p_d about 2.6 p_s by then): the example's fmpy master and libcosim running the OSP file
    give the same last-window figures within 0.5 % (measured: within 0.03 %), and both keep the charge."""
    fmpy = run_example(built_fmus, tmp_path / "fmpy", "--duration", "3")
    libcosim = run_example(built_fmus, tmp_path / "libcosim", "--duration", "3", "--libcosim")
    for summary in (fmpy, libcosim):
        assert summary["charge balance: max |loop + chambers - start| / start"] < 1e-9
    for name, value in fmpy["last window"].items():
        assert libcosim["last window"][name] == pytest.approx(value, rel=5e-3), name
    last = fmpy["last window"]
    assert last["discharge pressure [Pa]"] > 2.0 * last["suction pressure [Pa]"] and last["capacity [W]"] > 500.0


STEADY_DURATION = 60.0          # s from standstill: steady from about 40 s (README "Refrigeration system")


@pytest.mark.slow
def test_steady_state_matches_an_independent_steady_cycle(built_fmus, tmp_path):
    """The system run to steady state in libcosim: its last-window capacity (evaporator + suction line) and COP
    against the cycle of examples/steady_cycle.py at the same p_s, h_s, p_d with the compressor's own eta_v, eta_is
    and drawn energy per drawn mass (CoolProp states, saturated liquid at the valve), within 1 %; the summary
    reports that same cycle. (The textbook cycle, drawing h_s, is 1.4 % above: the compressor's back-flow returns
    that energy to the evaporator, docs/model.md §16.5, §16.7.)"""
    from rotary_vane.examples.steady_cycle import independent_cycle, swept_volume
    summary = run_example(built_fmus, tmp_path / "steady", "--duration", str(STEADY_DURATION), "--libcosim",
                          "--window-revolutions", "25", "--csv-stride", "1000")
    assert summary["steady state reached"], summary["last-10 % drift of p_s, p_d, mass flow, capacity (relative)"]
    last = summary["last window"]
    start_values = {element.get("variable"): float(element[0].get("value"))
                    for element in ElementTree.parse(built_fmus / OSP_FILE).getroot().iterfind(
                        "osp:Simulators/osp:Simulator[@name='compressor']/osp:InitialValues/osp:InitialValue", OSP)
                    if element[0].tag.endswith("Real") or element[0].tag.endswith("Integer")}
    cycle = independent_cycle("R134a", last["suction pressure [Pa]"], last["suction enthalpy [J/kg]"],
                              last["discharge pressure [Pa]"], last["mass flow [kg/s]"], last["speed [rpm]"] / 60.0,
                              last["shaft power [W]"], last["electrical power [W]"], swept_volume(start_values),
                              last["drawn energy / drawn mass [J/kg]"])
    print(f"steady at {STEADY_DURATION:g} s: capacity {last['capacity [W]']:.6g} W vs cycle "
          f"{cycle['capacity [W]']:.6g} W, COP {last['COP']:.6g} vs {cycle['COP']:.6g}, eta_v {cycle['volumetric efficiency']:.4f}, eta_is "
          f"{cycle['isentropic efficiency']:.4f}, textbook cycle (h_s drawn) "
          f"{cycle['textbook capacity m_dot (h_s - h_valve,in) [W]']:.6g} W, COP {cycle['textbook COP']:.6g}, wall "
          f"{summary['wall time [s]']:.0f} s")
    assert last["capacity [W]"] == pytest.approx(cycle["capacity [W]"], rel=1e-2)
    assert last["COP"] == pytest.approx(cycle["COP"], rel=1e-2)
    reported = summary["independent steady cycle (CoolProp), last window"]
    assert reported["capacity [W]"] == pytest.approx(cycle["capacity [W]"], rel=1e-12)
    assert reported["COP"] == pytest.approx(cycle["COP"], rel=1e-12)


# the detailed model's steady figures of the 150 s start-up (README "Refrigeration system", fmpy, 1 ms)
DETAILED_STEADY = {"suction pressure [Pa]": 271.7e3, "discharge pressure [Pa]": 1.159e6, "mass flow [kg/s]": 8.711e-3,
                   "capacity [W]": 1190.0, "COP": 3.04}


@pytest.mark.slow
def test_start_up_in_map_mode_reaches_the_detailed_steady_state(map_fmus, tmp_path):
    """The compressor FMU built with its fluid periodic map shipped (`build --map`, the system's parameters: the
    session's `map_fmus`), the system from standstill in fmpy with --fidelity periodic_map: steady, with the charge
    kept, and its steady p_s, p_d, mass flow, capacity and COP within 1 % of the detailed model's. Then that FMU
    alone loads the table it ships, and refuses a discharge pressure outside the table's box (fmi2Discard, the state
    untouched)."""
    summary = run_example(map_fmus, tmp_path / "map", "--duration", str(STEADY_DURATION), "--fidelity",
                          "periodic_map", "--window-revolutions", "25", "--csv-stride", "1000")
    assert summary["steady state reached"], summary["last-10 % drift of p_s, p_d, mass flow, capacity (relative)"]
    assert summary["charge balance: max |loop + chambers - start| / start"] < 1e-9
    for name, value in DETAILED_STEADY.items():
        assert summary["last window"][name] == pytest.approx(value, rel=1e-2), name
    # the same FMU alone (README contract row C27): the table is the one it ships, and a discharge pressure outside
    # its box is refused with fmi2Discard naming the input, the state untouched; back inside, the step runs
    run = H.run_host(BOX_CHECK.format(fmu=str(map_fmus / "RotaryVaneCompressor.fmu"))).check()
    loaded = [line for line in H.periodic_map_messages(run.stderr) if line.startswith("[periodic map] loaded")]
    assert len(loaded) == 1 and "/resources/" in loaded[0] and "/periodic_maps/" in loaded[0], run.stderr[-2000:]
    result = run.result
    assert result["statuses"] == [H.DISCARD, H.OK], result
    assert "input 'discharge_pressure' = 2000000.0 Pa is outside the periodic map's box" in result["message"]
    assert result["after"] == result["before"], result


BOX_CHECK = """
import fmu_helpers as H
host = H.Host({fmu!r})
assert host.initialize(fidelity="periodic_map", rotor_inertia=0.0, shaft_speed=1500.0) == H.OK, host.messages()
host.run(0.0, 1e-3, 20)
before = host.outputs()
host.set(discharge_pressure=2.0e6)
refused = host.step(0.02, 1e-3)
after = host.outputs()
message = [m for _, _, m in host.messages()][-1]
host.set(discharge_pressure=1317900.0)
H.emit(dict(statuses=[refused, host.step(0.02, 1e-3)], message=message,
            before=[before[n] for n in ("shaft_work", "delivered_mass", "shaft_angle")],
            after=[after[n] for n in ("shaft_work", "delivered_mass", "shaft_angle")]))
host.close()
"""
