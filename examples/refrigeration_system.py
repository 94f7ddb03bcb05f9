"""DriveMotor.fmu, RotaryVaneCompressor.fmu and RefrigerationLoop.fmu as one refrigeration system, started from
standstill (README "Refrigeration system", docs/model.md §12.3, §16).

The system is the shipped OspSystemStructure_refrigeration.xml (fmu_src/systems/; RefrigerationSystem.ssd is the same
system as SSP): the motor at rest drives the compressor (speed -> compressor, step-mean shaft torque -> motor; the
rotor inertia on the motor's shaft), the loop at standstill (its charge at one temperature: equal pressures) gives
the compressor its suction pressure, suction enthalpy and discharge pressure, and the compressor gives the loop its
cumulative drawn and delivered mass and enthalpy. The script reads the file's start values and connections and runs
them with a fixed-step master in fmpy: motor and compressor take the others' outputs at t_k and step to t_k + h
(Jacobi, as libcosim's fixed-step algorithm), then the loop takes the compressor's cumulative exchange at t_k + h
and steps (Gauss-Seidel in that direction only), so that what the compressor drew and delivered in a step is in
the loop's balance at the same communication point. With --libcosim the file goes to libcosim (libcosimpy), Jacobi
throughout: the loop takes each step's exchange one step later, and the charge balance counts the compressor's
exchange of the step before (what the loop has taken). The
compressor is the real-gas model (its Level 0/0.5 pressure tables are built for one operating point and refuse a
changed pressure input, README "Suction and discharge conditions as inputs"), detailed by default or, with
--fidelity periodic_map, its periodic map over speed x p_s x p_d (docs/model.md §12.4), which follows
the loop's pressures at a fraction of the cost (its table is built at initialization unless the FMU ships it:
`python -m rotary_vane.fmu_src.build --map` with the system's compressor parameters, README "Periodic map").

Figures (means over windows of --window-revolutions whole shaft revolutions, from the cumulative outputs
interpolated in the shaft angle, so nothing of the vane-passing ripple aliases): mass flow (delivered mass /
window), capacity (the loop's evaporator_heat_flow, a step mean), electrical power (the motor's electrical energy
/ window), COP = capacity / electrical power, shaft power. Peak motor torque
(and current for the DC motor). Charge balance: the loop's refrigerant_charge_in_loop plus what the chambers gained,
drawn_mass - delivered_mass, against the loop's charge at the start (relative). Time to steady state: the first
time after which the window means of p_s, p_d, mass flow and capacity all stay within --settle of the run's last
window mean; reported as reached only if none of them drifted by more than a tenth of --settle over the last 10 %
of the run. The cycle on a p-h diagram (last window): suction (p_s, h_s), discharge (p_d, delivered enthalpy /
delivered mass), condenser outlet (p_d, h_d - Q_c / m), evaporator inlet (p_s, same enthalpy: the valve is
isenthalpic), on CoolProp's R134a saturation dome (CoolProp only draws the dome; the FMUs use none). A run that
reached steady state is checked against an independent steady cycle from CoolProp states (examples/steady_cycle.py,
docs/model.md §16.7): its capacity and COP, the system's and their relative differences go into summary.json.

Writes under --out: refrigeration_system.csv (every communication point, or every --csv-stride-th),
refrigeration_system.png (speed, torques, pressures, mass flow, capacity and COP over time), cycle_ph.png,
summary.json.

--motor dc runs the same system with the motor FMU's DC motor (its armature circuit at its parameters' defaults:
48 V, 0.3 Ohm, 1 mH, 0.28 N.m/A) instead of the file's induction motor, and --fidelity periodic_map the compressor's
periodic map over speed x p_s x p_d (README "Rating maps and periodic-map tables"): each overrides a start value in
both engines (fmpy: the start values given; libcosim: an initial value set on the execution before it starts).
The summary's peak current is the DC motor's armature current.

Usage:  python examples/refrigeration_system.py [--duration 5] [--step 1e-3] [--fidelity periodic_map] [--motor dc]
        [--libcosim] [--out DIR]
"""
from __future__ import annotations

import argparse
import csv
import gc
import json
import math
import sys
import time
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import matplotlib

matplotlib.use("Agg")                      # files only, no window
import matplotlib.pyplot as plt            # noqa: E402
import numpy as np                         # noqa: E402

from rotary_vane.examples import fmu_harness as harness                   # noqa: E402
from rotary_vane.examples.cli_types import number_parser                  # noqa: E402
from rotary_vane.examples.motor_coupling import CouplingFailure, Slave     # noqa: E402
from rotary_vane.examples.steady_cycle import independent_cycle, swept_volume  # noqa: E402

SYSTEM_FILE = "OspSystemStructure_refrigeration.xml"
OSP = {"osp": "http://opensimulationplatform.com/MSMI/OSPSystemStructure"}
TYPES = {"Real": float, "Integer": int, "Boolean": lambda text: text == "true", "String": str}
RECORDED = {
    "motor": ("shaft_speed", "motor_torque", "current", "electrical_energy", "motor_work"),
    "compressor": ("shaft_torque_mean", "shaft_work", "shaft_angle", "drawn_mass", "drawn_enthalpy", "delivered_mass",
                   "delivered_enthalpy"),
    "loop": ("suction_pressure", "discharge_pressure", "suction_enthalpy", "suction_temperature",
             "evaporator_temperature", "condenser_temperature", "evaporator_heat_flow", "condenser_heat_flow",
             "valve_mass_flow", "refrigerant_charge_in_loop"),
}
COLUMNS = ("time", *(f"{component}.{name}" for component, names in RECORDED.items() for name in names))
FLUID = "R134a"
MOTORS = ("induction", "dc")            # the motor FMU's motor_type choices (--motor)
DEFAULT_STEP = 1e-3                     # s, fmpy's communication step


# the system file ------------------------------------------------------------------------------------------------
def read_system(path: Path) -> dict:
    """The OSP file's base step, simulators (name -> FMU file, start values) and connections (source -> target)."""
    root = ElementTree.parse(path).getroot()
    simulators = {}
    for simulator in root.iterfind("osp:Simulators/osp:Simulator", OSP):
        values = {value.get("variable"): TYPES[value[0].tag.rsplit("}", 1)[-1]](value[0].get("value"))
                  for value in simulator.iterfind("osp:InitialValues/osp:InitialValue", OSP)}
        simulators[simulator.get("name")] = (simulator.get("source"), values)
    connections = []
    for connection in root.iterfind("osp:Connections/osp:VariableConnection", OSP):
        ends = {variable.get("causality"): (variable.get("simulator"), variable.get("name"))
                for variable in connection.iterfind("osp:Variable", OSP)}
        connections.append((ends["output"], ends["input"]))
    return dict(step=float(root.find("osp:BaseStepSize", OSP).text), simulators=simulators, connections=connections)


# fmpy: a fixed-step master over the file's connections -----------------------------------------------------------
def run_fmpy(fmu_dir: Path, system: dict, duration: float, step: float, log: harness.FmuLog,
             step_seconds: dict) -> np.ndarray:
    """The system in fmpy from the file's start values: motor and compressor Jacobi on the outputs at t_k (the loop's
    to the compressor included), then the loop with the compressor's exchange of the step (module docstring); the
    recorded columns after initialization and after every step; `step_seconds` (per FMU name) gets the wall time
    of its doStep calls. A refused step raises CouplingFailure with the FMU's message."""
    slaves = {name: Slave(fmu_dir / source, name, log) for name, (source, _) in system["simulators"].items()}
    for name, (_, values) in system["simulators"].items():
        slaves[name].start(values)
    progress = harness.ProgressBar(duration, "fmpy")
    rows = [record_fmpy(0.0, slaves)]
    exchange = [(source, target) for source, target in system["connections"] if target[0] == "loop"]
    jacobi = [(source, target) for source, target in system["connections"] if target[0] != "loop"]
    clock = time.perf_counter
    for k in range(round(duration / step)):
        t = k * step
        outputs = {source: slaves[source[0]].get(source[1])[0] for source, _ in jacobi}
        for source, (target, name) in jacobi:
            slaves[target].set(name, outputs[source])
        for name in ("motor", "compressor"):
            started = clock()
            slaves[name].step(t, step)
            step_seconds[name] += clock() - started
        for (source, output), (target, name) in exchange:       # the exchange of this step (module docstring)
            slaves[target].set(name, slaves[source].get(output)[0])
        started = clock()
        slaves["loop"].step(t, step)
        step_seconds["loop"] += clock() - started
        rows.append(record_fmpy((k + 1) * step, slaves))
        progress((k + 1) * step, None)
    for slave in slaves.values():
        slave.fmu.terminate()
        slave.fmu.freeInstance()
    return np.array(rows)


def record_fmpy(t: float, slaves: dict) -> list[float]:
    return [t, *(value for component, names in RECORDED.items() for value in slaves[component].get(*names))]


# libcosim: the file as it is ----------------------------------------------------------------------------------------
def run_libcosim(path: Path, duration: float, overrides: dict) -> np.ndarray:
    """The OSP file through libcosim's fixed-step algorithm, recorded after every base step; `overrides`
    (component -> {variable: value}) are set as initial values over the file's before the run starts."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy._internal import get_last_error_message
    log_output_level(CosimLogLevel.WARNING)
    step = read_system(path)["step"]
    execution = CosimExecution.from_osp_config_file(str(path))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    index = {info.name.decode(): info.index for info in execution.slave_infos()}
    references = {component: [next(v.reference for v in execution.slave_variables(index[component])
                                   if v.name.decode() == name) for name in names]
                  for component, names in RECORDED.items()}
    setters = {str: execution.string_initial_value, float: execution.real_initial_value,
               int: execution.integer_initial_value, bool: execution.boolean_initial_value}
    for component, values in overrides.items():
        variables = {v.name.decode(): v.reference for v in execution.slave_variables(index[component])}
        for name, value in values.items():
            if not setters[type(value)](index[component], variables[name], value):
                raise harness.HarnessError(f"libcosim refused {component}.{name} = {value!r}: "
                                           f"{get_last_error_message()}")
    progress = harness.ProgressBar(duration, "libcosim (fixed step)")
    rows = []
    try:
        for k in range(1, round(duration / step) + 1):
            if not execution.simulate_until(round(k * step * 1e9)):
                raise harness.HarnessError(f"libcosim ({path.name}) failed before t = {k * step:g} s: "
                                           f"{get_last_error_message()}")
            rows.append([k * step, *(value for component in RECORDED
                                     for value in observer.last_real_values(index[component], references[component]))])
            progress(k * step, None)
    finally:
        del observer, execution                 # before the interpreter exits (libcosim's threads)
        gc.collect()
    return np.array(rows)


# figures --------------------------------------------------------------------------------------------------------
def window_means(c: dict, revolutions: int) -> dict:
    """Means over consecutive windows of `revolutions` whole shaft revolutions (module docstring), from the
    cumulative outputs interpolated in the shaft angle to the windows' bounds, so that every window holds whole
    periods of the vane-passing ripple; "time" and the pressures are at each window's end."""
    angle, t = c["compressor.shaft_angle"], c["time"]
    turn = 2.0 * math.pi * revolutions
    bounds = np.arange(0, math.floor(angle[-1] / turn) + 1) * turn
    if bounds.size < 3:
        raise harness.HarnessError(f"the shaft turned {angle[-1] / (2.0 * math.pi):.3g} revolutions: too few for "
                                   f"two windows of {revolutions} revolutions (a longer --duration, or a smaller "
                                   f"--window-revolutions)")
    heats = {name: np.concatenate(([0.0], np.cumsum(c[name][1:] * np.diff(t))))      # step means x step
             for name in ("loop.evaporator_heat_flow", "loop.condenser_heat_flow")}

    def at(series):
        return np.interp(bounds, angle, series)

    times = at(t)
    span = np.diff(times)

    def rate(series):
        return np.diff(at(series)) / span

    delivered, drawn = np.diff(at(c["compressor.delivered_mass"])), np.diff(at(c["compressor.drawn_mass"]))
    means = {"time": times[1:], "speed": turn / span / harness.RPM,
             "mass_flow": delivered / span, "drawn_mass_flow": rate(c["compressor.drawn_mass"]),
             "electrical_power": rate(c["motor.electrical_energy"]), "shaft_power": rate(c["compressor.shaft_work"]),
             "load_torque": np.diff(at(c["compressor.shaft_work"])) / turn,
             "capacity": rate(heats["loop.evaporator_heat_flow"]),
             "condenser_heat_flow": rate(heats["loop.condenser_heat_flow"]),
             "suction_pressure": at(c["loop.suction_pressure"])[1:],
             "discharge_pressure": at(c["loop.discharge_pressure"])[1:],
             "suction_enthalpy": at(c["loop.suction_enthalpy"])[1:],
             "drawn_enthalpy": np.divide(np.diff(at(c["compressor.drawn_enthalpy"])), drawn,
                                         out=np.full(span.size, np.nan), where=drawn > 0.0),
             "discharge_enthalpy": np.divide(np.diff(at(c["compressor.delivered_enthalpy"])), delivered,
                                             out=np.full(span.size, np.nan), where=delivered > 0.0)}
    means["cop"] = np.divide(means["capacity"], means["electrical_power"], out=np.full(span.size, np.nan),
                             where=means["electrical_power"] > 0.0)
    return means


def settling(means: dict, tolerance: float) -> tuple[float | None, bool, dict]:
    """(time to steady state or None, whether it was reached, the last-10 % drift of each watched figure)."""
    watched = ("suction_pressure", "discharge_pressure", "mass_flow", "capacity")
    t = means["time"]
    outside = np.zeros(t.size, dtype=bool)
    drift = {}
    tail = max(1, t.size // 10)
    for name in watched:
        values, final = means[name], means[name][-1]
        outside |= np.abs(values / final - 1.0) > tolerance
        drift[name] = float(abs(values[-1] / values[-1 - tail] - 1.0)) if t.size > tail else math.nan
    last_outside = np.flatnonzero(outside)
    settled = float(t[last_outside[-1] + 1]) if last_outside.size and last_outside[-1] + 1 < t.size else \
        (float(t[0]) if not last_outside.size else None)
    reached = settled is not None and all(value <= 0.1 * tolerance for value in drift.values())
    return settled, reached, drift


def summary_of(c: dict, means: dict, args, wall: float) -> dict:
    initial_charge = c["loop.refrigerant_charge_in_loop"][0]
    chambers = c["compressor.drawn_mass"] - c["compressor.delivered_mass"]
    taken = np.concatenate(([0.0], chambers[:-1])) if args.libcosim else chambers     # module docstring
    charge_error = np.abs(c["loop.refrigerant_charge_in_loop"] + taken - initial_charge) / initial_charge
    settled, reached, drift = settling(means, args.settle)
    last = {name: float(values[-1]) for name, values in means.items()}
    return {
        "engine": "libcosim" if args.libcosim else "fmpy", "fidelity": args.fidelity, "duration [s]": args.duration,
        "communication step [s]": args.step, "wall time [s]": wall,
        "window [revolutions]": args.window_revolutions,
        "peak motor torque [N.m]": float(np.max(c["motor.motor_torque"])),
        "peak motor current [A] (dc motor; 0: induction)": float(np.max(np.abs(c["motor.current"]))),
        "time to steady state [s]": settled if reached else None, "steady state reached": reached,
        "last-10 % drift of p_s, p_d, mass flow, capacity (relative)": drift,
        "last window": {"speed [rpm]": last["speed"], "suction pressure [Pa]": last["suction_pressure"],
                        "discharge pressure [Pa]": last["discharge_pressure"],
                        "suction enthalpy [J/kg]": last["suction_enthalpy"],
                        "drawn energy / drawn mass [J/kg]": last["drawn_enthalpy"],
                        "mass flow [kg/s]": last["mass_flow"],
                        "capacity [W]": last["capacity"], "electrical power [W]": last["electrical_power"],
                        "shaft power [W]": last["shaft_power"], "COP": last["cop"]},
        "charge balance: max |loop + chambers - start| / start": float(np.max(charge_error)),
        "refrigerant in the chambers at the end [kg]": float(chambers[-1]),
    }


def cross_check(means: dict, displacement: float) -> dict:
    """The last window against the independent steady cycle of examples/steady_cycle.py (README "Refrigeration
    system", docs/model.md §16.7): the cycle's capacity and COP, the system's, and their relative differences."""
    last = {name: float(values[-1]) for name, values in means.items()}
    cycle = independent_cycle(FLUID, last["suction_pressure"], last["suction_enthalpy"], last["discharge_pressure"],
                              last["mass_flow"], last["speed"] * harness.RPM / (2.0 * math.pi), last["shaft_power"],
                              last["electrical_power"], displacement, last["drawn_enthalpy"])
    return {**cycle, "swept volume [m3]": displacement,
            "system capacity [W] (evaporator + suction line)": last["capacity"], "system COP": last["cop"],
            "capacity: system / cycle - 1": last["capacity"] / cycle["capacity [W]"] - 1.0,
            "COP: system / cycle - 1": last["cop"] / cycle["COP"] - 1.0,
            "capacity: system / textbook cycle - 1":
                last["capacity"] / cycle["textbook capacity m_dot (h_s - h_valve,in) [W]"] - 1.0}


# plots ----------------------------------------------------------------------------------------------------------
def plot_time(c: dict, means: dict, path: Path, title: str) -> None:
    t, tm = c["time"], means["time"]
    figure, axes = plt.subplots(5, 1, figsize=(9, 13), sharex=True)
    axes[0].plot(t, c["motor.shaft_speed"], lw=0.6, label="shaft speed (end of step)")
    axes[0].plot(tm, means["speed"], label="window mean")
    axes[0].set_ylabel("rpm")
    axes[1].plot(t, c["motor.motor_torque"], lw=0.6, label="motor torque")
    axes[1].plot(t, c["compressor.shaft_torque_mean"], lw=0.3, alpha=0.6, label="compressor torque, step mean")
    axes[1].plot(tm, means["load_torque"], label="compressor torque, window mean")
    axes[1].set_ylabel("N m")
    axes[2].plot(t, c["loop.suction_pressure"] / 1e5, label="suction p_s")
    axes[2].plot(t, c["loop.discharge_pressure"] / 1e5, label="discharge p_d")
    axes[2].set_ylabel("bar")
    axes[3].plot(tm, means["mass_flow"] * 1e3, label="delivered (compressor)")
    axes[3].plot(tm, means["drawn_mass_flow"] * 1e3, ls="--", label="drawn (compressor)")
    axes[3].plot(t, c["loop.valve_mass_flow"] * 1e3, lw=0.8, label="expansion valve")
    axes[3].set_ylabel("g/s")
    axes[4].plot(tm, means["capacity"], label="capacity (evaporator + suction line)")
    axes[4].plot(tm, means["electrical_power"], label="motor electrical power")
    axes[4].set_ylabel("W")
    cop = axes[4].twinx()
    cop.plot(tm, means["cop"], color="k", lw=1.0, label="COP (right)")
    cop.set_ylabel("COP")
    cop.legend(fontsize=8, loc="lower right")
    axes[4].set_xlabel("time [s]")
    for axis in axes:
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8, loc="best")
    axes[0].set_title(title)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def cycle_points(means: dict) -> dict:
    """(p, h) of the cycle's four points from the last window (module docstring)."""
    p_s, p_d = means["suction_pressure"][-1], means["discharge_pressure"][-1]
    h_d = means["discharge_enthalpy"][-1]
    h_out = h_d - means["condenser_heat_flow"][-1] / means["mass_flow"][-1]
    return {"suction": (p_s, means["suction_enthalpy"][-1]), "discharge": (p_d, h_d),
            "condenser outlet": (p_d, h_out), "evaporator inlet": (p_s, h_out)}


def plot_cycle(points: dict, path: Path, title: str) -> None:
    from CoolProp.CoolProp import PropsSI
    critical = PropsSI("Tcrit", FLUID)
    temperatures = np.linspace(PropsSI("Tmin", FLUID) + 20.0, critical - 0.01, 200)
    figure, axis = plt.subplots(figsize=(8, 6))
    for quality, style in ((0.0, "b-"), (1.0, "r-")):
        axis.plot([PropsSI("H", "T", T, "Q", quality, FLUID) / 1e3 for T in temperatures],
                  [PropsSI("P", "T", T, "Q", quality, FLUID) / 1e5 for T in temperatures], style, lw=1.0,
                  label="saturated liquid" if quality == 0.0 else "saturated vapour")
    order = ("suction", "discharge", "condenser outlet", "evaporator inlet", "suction")
    axis.plot([points[name][1] / 1e3 for name in order], [points[name][0] / 1e5 for name in order], "ko-",
              label="cycle (last window)")
    for name, (p, h) in points.items():
        axis.annotate(name, (h / 1e3, p / 1e5), textcoords="offset points", xytext=(5, 5), fontsize=8)
    axis.set_yscale("log")
    axis.set_xlabel("specific enthalpy [kJ/kg]")
    axis.set_ylabel("pressure [bar]")
    axis.set_title(title)
    axis.grid(alpha=0.3, which="both")
    axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


# main -----------------------------------------------------------------------------------------------------------
def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=harness.HelpFormatter)
    harness.add_common_options(parser, "refrigeration_system")
    parser.add_argument("--duration", type=number_parser("s"), default=5.0, help="simulated time from standstill [s]")
    parser.add_argument("--step", type=number_parser("s", 0.0, 0.1), default=None,
                        help="communication step [s] of the fmpy master (default 1e-3 s; libcosim takes the file's "
                             "base step, so --step with --libcosim is refused)")
    parser.add_argument("--window-revolutions", type=int, default=5,
                        help="window of the means (speed, mass flow, capacity, powers, COP) in whole shaft "
                             "revolutions")
    parser.add_argument("--settle", type=number_parser("1", 0.0, 1.0), default=0.01,
                        help="relative band of the time to steady state")
    parser.add_argument("--csv-stride", type=int, default=1,
                        help="write every N-th communication point to the CSV (long runs)")
    parser.add_argument("--motor", choices=MOTORS, default=None,
                        help="the motor FMU's motor_type for this run (default: the system file's, induction)")
    parser.add_argument("--fidelity", choices=("detailed", "periodic_map"), default="detailed",
                        help="the compressor's fidelity")
    parser.add_argument("--libcosim", action="store_true",
                        help=f"run {SYSTEM_FILE} through libcosim (libcosimpy) instead of fmpy")
    args = parser.parse_args(argv)
    if args.window_revolutions < 1:
        raise harness.InputError(f"--window-revolutions = {args.window_revolutions} is out of range: allowed an "
                                 f"integer >= 1")
    if args.libcosim and args.step is not None:
        raise harness.InputError(f"--step = {args.step:g} s with --libcosim: libcosim takes the base step of "
                                 f"{SYSTEM_FILE}; edit the file to change it")
    if args.step is None and not args.libcosim:
        args.step = DEFAULT_STEP
    if args.csv_stride < 1:
        raise harness.InputError(f"--csv-stride = {args.csv_stride} is out of range: allowed an integer >= 1")
    return args


def main(argv=None) -> int:
    args = parse_arguments(argv)
    fmu_dir = harness.ensure_fmus(args.fmu_dir)
    out = harness.output_folder(args.out)
    system = read_system(fmu_dir / SYSTEM_FILE)
    overrides = {"compressor": {"fidelity": args.fidelity}}
    if args.motor:
        overrides["motor"] = {"motor_type": args.motor}
    for component, values in overrides.items():
        system["simulators"][component][1].update(values)
    log = harness.FmuLog(args.verbose)
    started = time.perf_counter()
    step_seconds = dict.fromkeys(system["simulators"], 0.0)
    if args.libcosim:
        args.step = system["step"]
        rows = run_libcosim(fmu_dir / SYSTEM_FILE, args.duration, overrides)
    else:
        try:
            rows = run_fmpy(fmu_dir, system, args.duration, args.step, log, step_seconds)
        except CouplingFailure as failure:
            raise harness.HarnessError(str(failure)) from None
    wall = time.perf_counter() - started
    columns = {name: rows[:, i] for i, name in enumerate(COLUMNS)}
    means = window_means(columns, args.window_revolutions)
    summary = summary_of(columns, means, args, wall)
    summary["motor"] = system["simulators"]["motor"][1]["motor_type"]
    if not args.libcosim:
        steps = round(args.duration / args.step)
        summary["doStep wall time per step [us]"] = {name: 1e6 * seconds / steps for name, seconds in
                                                     step_seconds.items()}
    engine = "libcosim" if args.libcosim else "fmpy"
    with open(out / "refrigeration_system.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(COLUMNS)
        writer.writerows([repr(float(value)) for value in row] for row in rows[::args.csv_stride])
    plot_time(columns, means, out / "refrigeration_system.png",
              f"{summary['motor']} motor + compressor + loop from standstill ({engine}, {args.fidelity}, "
              f"{args.step * 1e3:g} ms steps)")
    points = cycle_points(means)
    summary["cycle (p [Pa], h [J/kg]), last window"] = {name: [float(p), float(h)] for name, (p, h) in points.items()}
    state = "" if summary["steady state reached"] else ", not steady"
    plot_cycle(points, out / "cycle_ph.png", f"R134a cycle at t = {args.duration:g} s ({engine}{state})")
    if summary["steady state reached"]:
        summary["independent steady cycle (CoolProp), last window"] = cross_check(
            means, swept_volume(system["simulators"]["compressor"][1]))
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary, indent=1))
    print(f"wrote {out / 'refrigeration_system.csv'}, refrigeration_system.png, cycle_ph.png, summary.json")
    return 0


if __name__ == "__main__":
    sys.exit(harness.run_main(main))
