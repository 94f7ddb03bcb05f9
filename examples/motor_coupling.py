"""DriveMotor.fmu drives RotaryVaneCompressor.fmu from rest to steady state: three co-simulation masters written
with fmpy's low-level API, the same system in libcosim, a convergence study over the communication step and the
motor sizing figures.

The system (README "Coupling to a motor"): the motor integrates the shaft with its own
inertia plus the compressor's rotor inertia J2 (the motor's load_inertia = the compressor FMU's default
rotor_inertia; the compressor's rotor_inertia = 0, else its torque would contain J2 dw/dt a second time) and
outputs shaft_speed [rpm]; the compressor takes that speed as the speed at the end of each step (it moves the
speed linearly over the step) and returns shaft_torque_mean, the shaft work over the step divided by the angle
turned, which the motor holds as its load torque over its next step:

    (J_motor + J2) dw/dt = T_motor(w) - T_load,        T_load = shaft_torque_mean of the compressor

Masters (communication step h, both FMUs stepped from t_k to t_k + h):
* Jacobi: both take the other's outputs at t_k, then both step (libcosim's fixed-step algorithm does this);
* Gauss-Seidel, motor first: the motor steps with the last step-mean torque, then the compressor steps to the
  motor's new speed;
* iterative: Gauss-Seidel repeated within the step with FMU-state rollback (fmi2GetFMUstate/fmi2SetFMUstate)
  until the torque the compressor returns equals the torque the motor was given to --iteration-tolerance N.m.

Convergence study: each master at each step of --steps against the reference, the iterative master at the finest
step. Errors (see `errors_against`): speed = max over the scheme's communication steps of the difference in mean
speed over the step / steady reference speed; shaft energy = max over its communication points of the difference
in the compressor's cumulative shaft work / the reference's work at the stop time; also the energy balance of the
coupling (motor work - kinetic energy - compressor work, relative). A run diverges when the speed leaves
[0, 2 x synchronous speed], a step is refused or the iteration does not converge; that is a result of the study
(printed with the FMU's message), while a failed reference or sizing run is an error (exit 1).

libcosim (libcosimpy): OspSystemStructure.xml (fixed step, libcosim's Jacobi) and OspSystemStructure_ecco.xml
(ECCO adaptive step with a speed x torque power bond) as shipped next to the FMUs, with the start values changed to
this study's (from rest; the motor size), compared with fmpy's Jacobi at the file's base step and with the
reference.

Sizing (the iterative master at --sizing-step): start-up time to 95 % of the steady speed, peak motor torque,
steady electrical power (electrical energy over the last --steady-revolutions whole revolutions / their
duration), and stall yes/no (the shaft turned backwards, or too few revolutions for the steady window, or it
runs below half the synchronous speed), for the motor of --motor-power and an undersized one
(--undersized-power).

Writes under out/motor_coupling/: convergence.md (the table), summary.json, convergence.png (errors and wall
time vs step, log-log), startup.png (speed and motor torque vs time).

Usage:  python examples/motor_coupling.py [--steps 1e-4,2e-4,...] [--stop-time 0.5] [--motor-power 1500] [--quick]
"""
from __future__ import annotations

import argparse
import atexit
import gc
import importlib.util
import json
import math
import shutil
import sys
import time
import xml.etree.ElementTree as ElementTree
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")                      # files only, no window
import matplotlib.pyplot as plt            # noqa: E402
import numpy as np                         # noqa: E402

from rotary_vane.examples import fmu_harness as harness              # noqa: E402
from rotary_vane.examples.cli_types import number_parser  # noqa: E402

SCHEMES = ("jacobi", "gauss_seidel", "iterative")
SCHEME_NAMES = {"jacobi": "Jacobi", "gauss_seidel": "Gauss-Seidel", "iterative": "iterative"}
FULL_STEPS = (1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2)
FULL = dict(steps=FULL_STEPS, stop_time=0.5, steady_revolutions=4, sizing_step=1e-3)
QUICK = dict(steps=(2.5e-4, 5e-4, 1e-3, 2e-3, 5e-3), stop_time=0.2, steady_revolutions=2, sizing_step=1e-3)
MOTOR_RECORD = ("shaft_speed", "motor_torque", "electrical_power", "electrical_energy", "motor_work",
                "shaft_angle")
COMPRESSOR_RECORD = ("shaft_torque_mean", "shaft_work", "shaft_angle")
MAX_ITERATIONS = 30
ITERATION_UPDATES = ("fixed-point", "secant")    # the iterative master's next guess (CoupledSystem.evaluations)


class CouplingFailure(RuntimeError):
    """A coupled run that could not go on (a refused step, a speed out of bounds, no convergence)."""


def step_list(text: str) -> tuple[float, ...]:
    """'1e-4,1e-3' -> (0.0001, 0.001); each a finite step > 0 s."""
    parse = number_parser("s", 0.0, 1.0)
    try:
        values = tuple(sorted(parse(item) for item in text.split(",") if item.strip()))
    except argparse.ArgumentTypeError as error:
        raise argparse.ArgumentTypeError(f"--steps: {error}") from None
    if not values:
        raise argparse.ArgumentTypeError("--steps: give at least one communication step in s")
    return values


def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description="DriveMotor.fmu + RotaryVaneCompressor.fmu from rest: Jacobi, Gauss-Seidel and iterative "
                    "(state rollback) masters with fmpy, libcosim fixed step and ECCO, a convergence study over "
                    "the communication step and motor sizing figures.",
        formatter_class=harness.HelpFormatter)
    parser.add_argument("--steps", type=step_list, default=None,
                        help=f"comma-separated communication steps [s] of the study; the finest is the reference "
                             f"(iterative master); each must be a whole multiple of the finest "
                             f"(default {','.join(f'{h:g}' for h in FULL_STEPS)})")
    parser.add_argument("--stop-time", type=number_parser("s"), default=None,
                        help="simulated time [s] from rest (default 0.5; --quick 0.2)")
    parser.add_argument("--steady-revolutions", type=int, default=None,
                        help="the steady speed and powers are means over this many last whole revolutions "
                             f"(default {FULL['steady_revolutions']}; --quick {QUICK['steady_revolutions']})")
    parser.add_argument("--sizing-step", type=number_parser("s", 0.0, 0.1), default=None,
                        help="communication step [s] of the sizing runs (iterative master; default 1e-3)")
    parser.add_argument("--motor-power", type=number_parser("W"), default=1500.0,
                        help="rated power of the induction motor [W] (DriveMotor rated_power; the other nameplate "
                             "values stay at the FMU's defaults: 1440 rpm, 50 Hz, 2 pole pairs, T_b/T_r = 2.5)")
    parser.add_argument("--undersized-power", type=number_parser("W"), default=250.0,
                        help="rated power [W] of the undersized motor of the sizing comparison")
    parser.add_argument("--iteration-tolerance", type=number_parser("N.m"), default=1e-3,
                        help="iterative master: a step is converged when the compressor's step-mean torque "
                             "differs from the torque the motor was given by at most this [N.m] (0.04 %% of the "
                             "mean load). Below about 2e-4 N.m the step-mean torque is not a smooth function of "
                             "the speed (the compressor's adaptive integrator restarts at every step and takes "
                             "other step sequences), so tighter values can cycle without converging")
    parser.add_argument("--pressure-model", choices=("ideal_gas_table", "real_gas"), default="ideal_gas_table",
                        help="the compressor's pressure_model (the README's study figures: ideal_gas_table)")
    parser.add_argument("--no-libcosim", action="store_true", help="skip the libcosim runs")
    parser.add_argument("--quick", action="store_true",
                        help=f"short configuration for tests: steps {','.join(f'{h:g}' for h in QUICK['steps'])} s,"
                             f" stop time {QUICK['stop_time']:g} s, steady window {QUICK['steady_revolutions']} "
                             f"revolutions (explicit options win)")
    harness.add_common_options(parser, "motor_coupling")
    args = parser.parse_args(argv)
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    finest = args.steps[0]
    for h in args.steps:
        if abs(h / finest - round(h / finest)) > 1e-9:
            raise harness.InputError(f"step {h:g} s is not a whole multiple of the finest step {finest:g} s")
        if abs(args.stop_time / h - round(args.stop_time / h)) > 1e-9 or h > args.stop_time:
            raise harness.InputError(f"step {h:g} s does not divide the stop time {args.stop_time:g} s: allowed "
                                     f"steps stop_time/n")
    if abs(args.stop_time / args.sizing_step - round(args.stop_time / args.sizing_step)) > 1e-9:
        raise harness.InputError(f"--sizing-step = {args.sizing_step:g} s does not divide the stop time "
                                 f"{args.stop_time:g} s")
    if args.steady_revolutions < 1:
        raise harness.InputError(f"--steady-revolutions = {args.steady_revolutions} is invalid: allowed an integer "
                                 f">= 1")
    return args


# one FMU through fmpy's low-level API ----------------------------------------------------------------------
_UNPACKED: dict[str, str] = {}


def unpacked(fmu: Path) -> str:
    """The temporary folder `fmu` is unpacked into (fmpy's extract, about 40 MB), once per process and removed when
    the process exits. Not sooner: a Python FMU's code is imported from the first folder one of its instances uses
    and stays imported for the process, so every later instance reads its compiled kernels from that folder."""
    key = str(Path(fmu).resolve())
    if key not in _UNPACKED:
        from fmpy import extract
        _UNPACKED[key] = extract(key)
        atexit.register(shutil.rmtree, _UNPACKED[key], ignore_errors=True)
    return _UNPACKED[key]


class Slave:
    """One FMU instance (fmpy FMU2Slave, debug logging on), instantiated once and reset between runs."""

    def __init__(self, fmu: Path, name: str, log: harness.FmuLog):
        from fmpy import read_model_description
        from fmpy.simulation import instantiate_fmu
        self.name, self.log = name, log
        self.model_description = read_model_description(str(fmu))
        self.variables = harness.model_variables(self.model_description)
        self.fmu = instantiate_fmu(unpacked(fmu), self.model_description, "CoSimulation", debug_logging=True,
                                   logger=log)
        self.used = False

    def close(self) -> None:
        """fmi2Terminate (if the instance was used) and fmi2FreeInstance."""
        from fmpy.fmi1 import FMICallException
        try:
            if self.used:
                self.fmu.terminate()
        except FMICallException:
            pass                                 # an instance in the error state takes only fmi2FreeInstance
        finally:
            self.fmu.freeInstance()

    def start_value(self, name: str) -> float:
        return float(self.variables[name].start)

    def start(self, values: dict) -> None:
        """(Reset,) set up from t = 0, set the start values, initialize."""
        if self.used:
            self.fmu.reset()
        self.used = True
        harness.check_start_values(self.model_description, values)
        since = self.log.mark()
        self.fmu.setupExperiment(startTime=0.0)
        for name, value in values.items():
            reference = [self.variables[name].valueReference]
            if self.variables[name].type == "String":
                self.fmu.setString(reference, [value])
            elif self.variables[name].type == "Integer":
                self.fmu.setInteger(reference, [int(value)])
            else:
                self.fmu.setReal(reference, [float(value)])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        if self.log.errors(since):
            raise harness.HarnessError(f"{self.name} refused its start values: " + "; ".join(self.log.errors(since)))

    def get(self, *names: str) -> list[float]:
        return self.fmu.getReal([self.variables[name].valueReference for name in names])

    def set(self, name: str, value: float) -> None:
        self.fmu.setReal([self.variables[name].valueReference], [value])

    def step(self, t: float, h: float) -> None:
        """fmi2DoStep; a refused step raises CouplingFailure with the FMU's message."""
        from fmpy.fmi1 import FMICallException
        since = self.log.mark()
        try:
            self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        except FMICallException as error:
            raise CouplingFailure(f"{self.name} refused the step at t = {t:g} s ({error}):\n"
                                  f"{self.log.last(since=since)}") from None


# the masters ----------------------------------------------------------------------------------------------
@dataclass
class Run:
    """One coupled run: the outputs after every macro step (row 0: after initialization)."""
    scheme: str
    step: float
    columns: dict = field(default_factory=dict)        # name -> np.ndarray
    status: str = "ok"                                 # ok | diverged | backwards
    message: str = ""
    wall: float = 0.0
    iterations: float = 1.0                            # mean FMU evaluations per macro step (iterative)

    @property
    def ok(self) -> bool:
        return self.status == "ok"


class CoupledSystem:
    """The motor and compressor FMUs (one instance each) and the three masters; a context manager that frees both
    instances."""

    def __init__(self, fmu_dir: Path, log: harness.FmuLog, tolerance: float,
                 pressure_model: str = "ideal_gas_table"):
        self.motor = Slave(fmu_dir / f"{harness.MOTOR}.fmu", "motor", log)
        try:
            self.compressor = Slave(fmu_dir / f"{harness.COMPRESSOR}.fmu", "compressor", log)
        except BaseException:
            self.motor.close()
            raise
        self.tolerance = tolerance
        self.pressure_model = pressure_model
        self.rotor_inertia = self.compressor.start_value("rotor_inertia")       # J2 of the compressor FMU
        self.inertia = self.motor.start_value("motor_inertia") + self.rotor_inertia   # the shaft's [kg.m2]

    def __enter__(self) -> CoupledSystem:
        return self

    def __exit__(self, *exception) -> None:
        self.motor.close()
        self.compressor.close()

    def warm_up(self) -> float:
        """A few coupled steps before any timed run (the first step of a process loads or compiles the compressor's
        numba kernels); returns their wall time."""
        start = time.perf_counter()
        self.run("gauss_seidel", 1e-3, 3e-3, self.motor.start_value("rated_power"))
        return time.perf_counter() - start

    def motor_values(self, rated_power: float) -> dict:
        return {"motor_type": "induction", "rated_power": rated_power, "load_inertia": self.rotor_inertia,
                "initial_speed": 0.0}

    def compressor_values(self) -> dict:
        """The compressor's rotor inertia is in the motor's; the gas loads of the pressure model chosen (the study's
        figures in the README are of the Level 0.5 table; examples/coupling_convergence.py gives the iterative
        master's convergence with both)."""
        return {"rotor_inertia": 0.0, "shaft_speed": 0.0, "pressure_model": self.pressure_model}

    def synchronous_speed(self) -> float:
        """60 f / p [rpm] of the motor FMU's default supply frequency and pole pairs."""
        return 60.0 * self.motor.start_value("supply_frequency") / self.motor.start_value("pole_pairs")

    def record(self, rows: list) -> None:
        rows.append(self.motor.get(*MOTOR_RECORD) + self.compressor.get(*COMPRESSOR_RECORD))

    def check_speed(self, t: float) -> None:
        speed = self.motor.get("shaft_speed")[0]
        limit = 2.0 * self.synchronous_speed()
        if speed < 0.0:
            raise CouplingFailure(f"backwards: the shaft speed is {speed:.4g} rpm at t = {t:.6g} s (the motor "
                                  f"cannot hold the compressor; its FMU takes no negative speed)")
        if not speed <= limit:
            raise CouplingFailure(f"diverged: the shaft speed is {speed:.4g} rpm at t = {t:.6g} s, beyond twice "
                                  f"the synchronous speed ({limit:g} rpm)")

    # one macro step each; return the FMU evaluations used (compressor steps)
    def jacobi(self, t: float, h: float) -> int:
        torque = self.compressor.get("shaft_torque_mean")[0]
        speed = self.motor.get("shaft_speed")[0]
        self.motor.set("load_torque", torque)
        self.compressor.set("shaft_speed", speed)
        self.motor.step(t, h)
        self.compressor.step(t, h)
        return 1

    def gauss_seidel(self, t: float, h: float) -> int:
        self.motor.set("load_torque", self.compressor.get("shaft_torque_mean")[0])
        self.motor.step(t, h)
        self.check_speed(t + h)
        self.compressor.set("shaft_speed", self.motor.get("shaft_speed")[0])
        self.compressor.step(t, h)
        return 1

    def evaluations(self, t: float, h: float, most: int, update: str = "fixed-point"):
        """The iterative master's evaluations of one step from the states at t (saved, restored before each further
        evaluation, freed when the caller closes this generator): the motor steps with a load torque, the compressor
        to the motor's new speed; yields (iteration, that speed, the torque the motor was given, the torque the
        compressor returned). The first guess is the last step's torque; each next one is, by `update` (one of
        ITERATION_UPDATES), the torque returned ("fixed-point", the default) or the secant step on the residual
        returned - given through the last two evaluations ("secant": Newton's method with the slope of the last
        two; the torque returned while there is one evaluation only or the two residuals are equal)."""
        if update not in ITERATION_UPDATES:
            raise ValueError(f"update = {update!r} is invalid: allowed one of {ITERATION_UPDATES}")
        motor, compressor = self.motor.fmu, self.compressor.fmu
        states = (motor.getFMUstate(), compressor.getFMUstate())
        torque = self.compressor.get("shaft_torque_mean")[0]
        last = None                       # (given, residual) of the last evaluation
        try:
            for iteration in range(1, most + 1):
                if iteration > 1:
                    motor.setFMUstate(states[0])
                    compressor.setFMUstate(states[1])
                self.motor.set("load_torque", torque)
                self.motor.step(t, h)
                self.check_speed(t + h)
                speed = self.motor.get("shaft_speed")[0]
                self.compressor.set("shaft_speed", speed)
                self.compressor.step(t, h)
                returned = self.compressor.get("shaft_torque_mean")[0]
                yield iteration, speed, torque, returned
                residual, given = returned - torque, torque
                torque = returned
                if update == "secant" and last is not None and residual != last[1]:
                    torque = given - residual * (given - last[0]) / (residual - last[1])
                last = (given, residual)
        finally:
            motor.freeFMUstate(states[0])
            compressor.freeFMUstate(states[1])

    def iterative(self, t: float, h: float) -> int:
        history = [self.compressor.get("shaft_torque_mean")[0]]           # first guess: the last step's torque
        with closing(self.evaluations(t, h, MAX_ITERATIONS)) as evaluations:
            for iteration, _, given, returned in evaluations:
                history.append(returned)
                if abs(returned - given) <= self.tolerance:
                    return iteration
        raise CouplingFailure(f"diverged: no convergence to {self.tolerance:g} N.m within {MAX_ITERATIONS} "
                              f"iterations at t = {t:g} s (last step-mean torques "
                              f"{', '.join(f'{x:.9g}' for x in history[-4:])} N.m)")

    def run(self, scheme: str, step: float, stop_time: float, rated_power: float) -> Run:
        """One coupled run from rest; a failure ends the run and is kept in Run.status/message."""
        self.motor.start(self.motor_values(rated_power))
        self.compressor.start(self.compressor_values())
        master = getattr(self, scheme)
        rows, evaluations = [], 0
        self.record(rows)
        run = Run(scheme, step)
        count = round(stop_time / step)
        start = time.perf_counter()
        try:
            for k in range(count):
                t = k * step
                evaluations += master(t, step)
                self.check_speed(t + step)
                self.record(rows)
        except CouplingFailure as failure:
            run.message = str(failure)
            run.status = "backwards" if run.message.startswith("backwards") else "diverged"
        run.wall = time.perf_counter() - start
        run.iterations = evaluations / max(1, len(rows) - 1)
        data = np.array(rows)
        run.columns = {"time": step * np.arange(len(rows))}
        names = [*MOTOR_RECORD, *(f"compressor_{n}" for n in COMPRESSOR_RECORD)]
        run.columns.update({name: data[:, i] for i, name in enumerate(names)})
        return run


# figures of a run -----------------------------------------------------------------------------------------
def at_angle(columns: dict, angle: float) -> dict:
    """Every recorded column where the motor's shaft angle was `angle` (linear between communication points;
    the angle never decreases in a run that went on)."""
    return {name: float(np.interp(angle, columns["shaft_angle"], values)) for name, values in columns.items()}


def steady_figures(run: Run, revolutions: int, synchronous: float) -> dict:
    """Figures over the last `revolutions` whole revolutions, from the cumulative outputs (a whole number of
    revolutions holds whole periods of the torque ripple, so nothing aliases): steady speed = 2 pi N / time,
    steady shaft and electrical power = work and electrical energy over that time; the drift compares the mean
    speed of the first and last revolution of the window. Plus the start-up time to 95 % of the steady speed
    (linear between communication points), the peak motor torque and stall yes/no (the shaft turned backwards,
    or it runs below half the synchronous speed)."""
    c = run.columns
    figures = {"status": run.status, "end_time": float(c["time"][-1]),
               "peak_motor_torque": float(np.max(c["motor_torque"]))}
    if not run.ok:
        return dict(figures, stalled=run.status == "backwards", message=run.message)
    end = {name: float(values[-1]) for name, values in c.items()}
    turn = 2.0 * math.pi
    if c["shaft_angle"][-1] < turn * (revolutions + 1):
        return dict(figures, stalled=True, status="too slow",
                    message=f"the shaft turned only {c['shaft_angle'][-1] / turn:.2f} revolutions in "
                            f"{figures['end_time']:g} s: too few for a steady window of {revolutions} revolutions "
                            f"after the first")
    start = at_angle(c, end["shaft_angle"] - turn * revolutions)
    last = at_angle(c, end["shaft_angle"] - turn)
    first_end = at_angle(c, start["shaft_angle"] + turn)
    span = end["time"] - start["time"]
    steady = turn * revolutions / span / harness.RPM
    target = 0.95 * steady
    above = np.flatnonzero(c["shaft_speed"] >= target)
    k = int(above[0]) if above.size else 0
    t95 = None if k == 0 else float(np.interp(target, c["shaft_speed"][k - 1:k + 1], c["time"][k - 1:k + 1]))
    return dict(
        figures,
        stalled=bool(steady < 0.5 * synchronous),
        steady_speed=float(steady),
        steady_drift=float((first_end["time"] - start["time"]) / (end["time"] - last["time"]) - 1.0),
        startup_time_95=t95,
        steady_electrical_power=(end["electrical_energy"] - start["electrical_energy"]) / span,
        steady_shaft_power=(end["compressor_shaft_work"] - start["compressor_shaft_work"]) / span,
        steady_window=[start["time"], end["time"]],
        shaft_work=end["compressor_shaft_work"],
        electrical_energy=end["electrical_energy"],
    )


def step_mean_speed(columns: dict, stride: int = 1) -> np.ndarray:
    """Mean shaft speed [rpm] over each interval of `stride` communication steps, from the shaft angle."""
    angle, t = columns["shaft_angle"][::stride], columns["time"][::stride]
    return np.diff(angle) / np.diff(t) / harness.RPM


def errors_against(run: Run, reference: Run, steady_speed: float, inertia: float) -> dict:
    """Errors of a run against the reference at the run's communication points (all relative):

    * speed_error: max |mean speed over the step - reference's| / steady speed; the mean speed over a step is
      the shaft angle turned / step, the quantity a step-mean torque interface can represent (the end-of-step
      speed also carries the vane-passing speed ripple, which a torque held over the step cannot reproduce);
    * end_speed_error: the same with the end-of-step speeds (printed in summary.json only);
    * energy_error: max |W - W_ref| of the compressor's cumulative shaft work / W_ref at the stop time (the
      largest shaft-energy discrepancy along the run; at the stop time alone it depends on the ripple's phase);
    * energy_balance: (motor work - kinetic energy gained - compressor shaft work) / compressor shaft work at the
      stop time, the energy the coupling created (> 0) or lost (< 0); needs no reference.
    """
    if not run.ok:
        return dict.fromkeys(("speed_error", "end_speed_error", "energy_error", "energy_balance"), math.nan)
    stride = round(run.step / reference.step)
    c, r = run.columns, {name: values[::stride] for name, values in reference.columns.items()}
    difference = step_mean_speed(c) - step_mean_speed(r)
    work = c["compressor_shaft_work"]
    kinetic = 0.5 * inertia * ((c["shaft_speed"][-1] * harness.RPM) ** 2 - (c["shaft_speed"][0] * harness.RPM) ** 2)
    return {"speed_error": float(np.max(np.abs(difference)) / steady_speed),
            "end_speed_error": float(np.max(np.abs(c["shaft_speed"] - r["shaft_speed"])) / steady_speed),
            "energy_error": float(np.max(np.abs(work - r["compressor_shaft_work"])) / abs(r["compressor_shaft_work"][-1])),
            "energy_balance": float((c["motor_work"][-1] - kinetic - work[-1]) / work[-1])}


# libcosim -------------------------------------------------------------------------------------------------
def osp_base_step(path: Path) -> float:
    namespace = {"osp": "http://opensimulationplatform.com/MSMI/OSPSystemStructure"}
    return float(ElementTree.parse(path).getroot().find("osp:BaseStepSize", namespace).text)


def run_libcosim(path: Path, motor_values: dict, compressor_values: dict, stop_time: float, sample: float) -> Run:
    """The system file through libcosim with the start values replaced; outputs sampled every `sample` s
    (ECCO may end a little past a sample time: the actual times are kept)."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy._internal import get_last_error_message
    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_osp_config_file(str(path))
    index = {info.name.decode(): info.index for info in execution.slave_infos()}
    slaves = {"motor": (index["motor"], motor_values, MOTOR_RECORD),
              "compressor": (index["compressor"], compressor_values, COMPRESSOR_RECORD)}
    references = {name: {v.name.decode(): v.reference for v in execution.slave_variables(slave)}
                  for name, (slave, _, _) in slaves.items()}
    for name, (slave, values, _) in slaves.items():
        for variable, value in values.items():
            ok = execution.string_initial_value(slave, references[name][variable], value) if isinstance(value, str) \
                else execution.real_initial_value(slave, references[name][variable], float(value))
            if not ok:
                raise harness.HarnessError(f"libcosim refused the start value {name}.{variable} = {value!r}: "
                                           f"{get_last_error_message()}")
    observer = CosimObserver.create_last_value()       # also exposes the variables ECCO's power bond reads
    execution.add_observer(observer)
    rows, run = {}, Run(path.name, osp_base_step(path))
    start = time.perf_counter()
    try:
        for mark in np.arange(1, round(stop_time / sample) + 1) * sample:
            if not execution.simulate_until(round(mark * 1e9)):
                raise harness.HarnessError(f"libcosim ({path.name}) failed before t = {mark:g} s: "
                                           f"{get_last_error_message()}")
            now = execution.status().current_time         # ns; ECCO's steps may already be past the mark
            rows[now] = [now * 1e-9] + [value for name, (slave, _, recorded) in slaves.items()
                                        for value in observer.last_real_values(
                                            slave, [references[name][v] for v in recorded])]
        run.wall = time.perf_counter() - start
    finally:
        del observer, execution                 # before the interpreter exits (libcosim's threads)
        gc.collect()
    data = np.array(list(rows.values()))
    names = ["time", *MOTOR_RECORD, *(f"compressor_{n}" for n in COMPRESSOR_RECORD)]
    run.columns = {name: data[:, i] for i, name in enumerate(names)}
    return run


def libcosim_comparison(run: Run, partner: Run, revolutions: int, synchronous: float) -> dict:
    """libcosim's figures and their relative differences from an fmpy run: steady speed, shaft power and
    electrical power over the last whole revolutions, and the shaft work at the libcosim run's end time (ECCO
    may end a little after the stop time: the partner's work is interpolated to it)."""
    mine = steady_figures(run, revolutions, synchronous)
    theirs = steady_figures(partner, revolutions, synchronous)
    end_time = run.columns["time"][-1]
    theirs["shaft_work"] = float(np.interp(end_time, partner.columns["time"], partner.columns["compressor_shaft_work"]))
    keys = ("steady_speed", "steady_shaft_power", "steady_electrical_power", "shaft_work")
    return {"figures": {k: mine[k] for k in keys}, "end_time": float(end_time),
            "relative_difference": {k: float(mine[k] / theirs[k] - 1.0) for k in keys}}


# report ---------------------------------------------------------------------------------------------------
def percent(value) -> str:
    return "diverged" if value is None or not math.isfinite(value) else f"{100.0 * value:.2g} %"


def convergence_table(steps, study) -> str:
    """Markdown: one row per step; speed and shaft-energy error and wall time per scheme."""
    head = ("| step [s] | Jacobi speed err | Jacobi energy err | Gauss-Seidel speed err | Gauss-Seidel energy err "
            "| iterative speed err | iterative energy err | iterations / step | wall Jacobi / GS / iterative [s] |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for h in steps:
        cells = [f"{h:g}"]
        for scheme in SCHEMES:
            entry = study[scheme][h]
            if entry["reference"]:
                cells += ["reference", "reference"]
            else:
                cells += [percent(entry["speed_error"]), percent(entry["energy_error"])]
        cells.append(f"{study['iterative'][h]['iterations']:.2f}")
        cells.append(" / ".join(f"{study[s][h]['wall']:.2f}" for s in SCHEMES))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot_convergence(steps, study, path, title):
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.3))
    markers = {"jacobi": "s-", "gauss_seidel": "o-", "iterative": "^-"}
    for scheme in SCHEMES:
        rows = [(h, study[scheme][h]) for h in steps if not study[scheme][h]["reference"]]
        h = np.array([r[0] for r in rows])
        for ax, key in zip(axes[:2], ("speed_error", "energy_error")):
            values = np.array([r[1][key] for r in rows], dtype=float)
            shown = np.isfinite(values) & (values > 0)
            ax.loglog(h[shown], values[shown], markers[scheme], label=SCHEME_NAMES[scheme])
        axes[2].loglog(steps, [study[scheme][s]["wall"] for s in steps], markers[scheme],
                       label=SCHEME_NAMES[scheme])
    for ax, label in zip(axes, ("max error in step-mean speed / steady speed", "max shaft work error / final shaft work",
                                "wall time of the run [s]")):
        ax.set_xticks(steps)
        ax.set_xticklabels([f"{h:g}" for h in steps], rotation=45, fontsize=8)
        ax.xaxis.set_minor_formatter(plt.NullFormatter())
        ax.set_xlabel("communication step [s]")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_startup(curves, path, title):
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for label, run, style in curves:
        c = run.columns
        top.plot(c["time"], c["shaft_speed"], style, lw=1.0, label=label)
        bottom.plot(c["time"], c["motor_torque"], style, lw=1.0, label=label)
    top.set_ylabel("shaft speed [rpm]")
    bottom.set_ylabel("motor torque [N.m]")
    bottom.set_xlabel("time [s]")
    for ax in (top, bottom):
        ax.grid(True, alpha=0.4)
        ax.legend(fontsize=7, loc="best")
    top.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def describe_sizing(label, power, figures) -> str:
    if figures["status"] != "ok":
        return (f"{label} ({power:g} W): STALLS - {figures['message'].splitlines()[0]}; peak motor torque "
                f"{figures['peak_motor_torque']:.2f} N.m")
    t95 = "not reached" if figures["startup_time_95"] is None else f"{figures['startup_time_95']:.4f} s"
    return (f"{label} ({power:g} W): stall {'YES' if figures['stalled'] else 'no'}; steady speed "
            f"{figures['steady_speed']:.1f} rpm (drift over the window {100 * figures['steady_drift']:+.3f} %); "
            f"start-up to 95 % {t95}; peak motor torque {figures['peak_motor_torque']:.2f} N.m; steady electrical "
            f"power {figures['steady_electrical_power']:.1f} W (shaft power {figures['steady_shaft_power']:.1f} W)")


# main -----------------------------------------------------------------------------------------------------
def convergence_study(system: CoupledSystem, args, synchronous: float):
    """The reference run, then every master at every step; returns (reference, its figures, study, runs)."""
    steps, stop = args.steps, args.stop_time
    reference = system.run("iterative", steps[0], stop, args.motor_power)
    if not reference.ok:
        raise harness.HarnessError(f"the reference run (iterative, step {steps[0]:g} s) failed: {reference.message}")
    ref_figures = steady_figures(reference, args.steady_revolutions, synchronous)
    if "steady_speed" not in ref_figures:
        raise harness.HarnessError(f"the reference run has no steady state: {ref_figures['message']} (try a longer "
                                   f"--stop-time or a larger --motor-power)")
    print(f"reference: iterative at {steps[0]:g} s, {reference.wall:.1f} s wall, {reference.iterations:.2f} "
          f"evaluations per step, steady speed {ref_figures['steady_speed']:.2f} rpm")
    study, runs = {scheme: {} for scheme in SCHEMES}, {}
    for h in steps:
        for scheme in SCHEMES:
            is_reference = scheme == "iterative" and h == steps[0]
            run = reference if is_reference else system.run(scheme, h, stop, args.motor_power)
            runs[scheme, h] = run
            entry = dict(errors_against(run, reference, ref_figures["steady_speed"], system.inertia), wall=run.wall,
                         iterations=run.iterations, status=run.status, message=run.message, reference=is_reference)
            study[scheme][h] = entry
            note = "" if run.ok else f"  {run.message.splitlines()[0]}"
            print(f"  {SCHEME_NAMES[scheme]:>12} h = {h:<7g} speed err {percent(entry['speed_error']):>10}  energy "
                  f"err {percent(entry['energy_error']):>10}  energy balance {percent(entry['energy_balance']):>10}"
                  f"  wall {run.wall:6.2f} s{note}", flush=True)
    print("\n" + convergence_table(steps, study))
    for scheme in SCHEMES:
        failed = [h for h in steps if study[scheme][h]["status"] != "ok"]
        print(f"{SCHEME_NAMES[scheme]}: " + (f"unstable/diverged at steps {', '.join(f'{h:g}' for h in failed)} s"
                                             if failed else f"stable at every step up to {steps[-1]:g} s"))
    return reference, ref_figures, study, runs


def sizing_study(system: CoupledSystem, args, synchronous: float):
    """The iterative master at --sizing-step for the motor and the undersized motor; returns (runs, figures)."""
    runs = {label: system.run("iterative", args.sizing_step, args.stop_time, power)
            for label, power in (("motor", args.motor_power), ("undersized", args.undersized_power))}
    for label, run in runs.items():
        if run.status == "diverged":
            raise harness.HarnessError(f"the sizing run of the {label} motor failed: {run.message}")
    figures = {label: steady_figures(run, args.steady_revolutions, synchronous) for label, run in runs.items()}
    print(f"\nmotor sizing (iterative master, step {args.sizing_step:g} s):")
    print("  " + describe_sizing("motor", args.motor_power, figures["motor"]))
    print("  " + describe_sizing("undersized motor", args.undersized_power, figures["undersized"]))
    return runs, figures


def libcosim_study(system: CoupledSystem, args, fmu_dir: Path, synchronous: float, reference: Run, runs: dict):
    """The shipped OSP files through libcosim, compared with fmpy's Jacobi at their base step and with the
    reference; returns ({label: comparison}, {label: run}) (empty if skipped)."""
    if args.no_libcosim:
        print("\nlibcosim: skipped (--no-libcosim)")
        return {}, {}
    if importlib.util.find_spec("libcosimpy") is None:
        print("\nlibcosim: skipped, libcosimpy is not installed (pip install libcosimpy)")
        return {}, {}
    comparisons, libcosim_runs = {}, {}
    for file, label in (("OspSystemStructure.xml", "fixed step"), ("OspSystemStructure_ecco.xml", "ECCO")):
        path = fmu_dir / file
        base = osp_base_step(path)
        run = run_libcosim(path, system.motor_values(args.motor_power), system.compressor_values(), args.stop_time,
                           sample=base)
        jacobi = runs.get(("jacobi", base)) or system.run("jacobi", base, args.stop_time, args.motor_power)
        if not jacobi.ok:
            raise harness.HarnessError(f"fmpy's Jacobi master at {base:g} s failed: {jacobi.message}")
        libcosim_runs[label] = run
        comparisons[label] = {
            "file": file, "base_step": base, "wall": run.wall,
            "vs_reference": libcosim_comparison(run, reference, args.steady_revolutions, synchronous),
            "vs_fmpy_jacobi": libcosim_comparison(run, jacobi, args.steady_revolutions, synchronous)}
    print(f"\nlibcosim vs fmpy (relative differences; steady figures over the last {args.steady_revolutions} "
          f"revolutions):")
    for label, entry in comparisons.items():
        for partner in ("vs_fmpy_jacobi", "vs_reference"):
            difference = entry[partner]["relative_difference"]
            print(f"  {label:>10} {partner:>15}: " + ", ".join(f"{k} {100 * v:+.4f} %" for k, v in difference.items())
                  + f"  (wall {entry['wall']:.2f} s)")
    return comparisons, libcosim_runs


def main(argv=None) -> int:
    args = parse_arguments(argv)
    fmu_dir = harness.ensure_fmus(args.fmu_dir)
    out = harness.output_folder(args.out)
    with CoupledSystem(fmu_dir, harness.FmuLog(args.verbose), args.iteration_tolerance,
                       args.pressure_model) as system:
        return studies(system, args, fmu_dir, out)


def studies(system: CoupledSystem, args, fmu_dir: Path, out: Path) -> int:
    """The convergence, sizing and libcosim studies, their figures and summary.json."""
    synchronous = system.synchronous_speed()
    steps, stop = args.steps, args.stop_time
    for power in (args.motor_power, args.undersized_power):
        harness.check_start_values(system.motor.model_description, system.motor_values(power))
    wall = system.warm_up()
    print(f"first FMU steps (numba kernels loaded or compiled): {wall:.1f} s, not counted in the costs below")
    print(f"motor {args.motor_power:g} W induction, J = {system.inertia:g} kg.m2 (motor + compressor rotor "
          f"{system.rotor_inertia:g}); from rest to {stop:g} s; steps {', '.join(f'{h:g}' for h in steps)} s")

    reference, ref_figures, study, runs = convergence_study(system, args, synchronous)
    sizing_runs, sizing = sizing_study(system, args, synchronous)
    libcosim, libcosim_runs = libcosim_study(system, args, fmu_dir, synchronous, reference, runs)

    (out / "convergence.md").write_text(convergence_table(steps, study) + "\n")
    plot_convergence(steps, study, out / "convergence.png",
                     f"DriveMotor ({args.motor_power:g} W) + RotaryVaneCompressor from rest to {stop:g} s: error "
                     f"against the iterative master at {steps[0]:g} s")
    curves = [(f"reference (iterative, {steps[0]:g} s)", reference, "k-")]
    curves += [(f"libcosim {label} ({libcosim[label]['file']})", run, "C1--" if label == "ECCO" else "C0:")
               for label, run in libcosim_runs.items()]
    curves += [(f"{SCHEME_NAMES[scheme]}, {steps[-1]:g} s", runs[scheme, steps[-1]], style)
               for scheme, style in (("jacobi", "C2-"), ("gauss_seidel", "C4-")) if runs[scheme, steps[-1]].ok]
    curves.append((f"undersized motor {args.undersized_power:g} W (iterative, {args.sizing_step:g} s)",
                   sizing_runs["undersized"], "C3-"))
    plot_startup(curves, out / "startup.png", f"start-up from rest, motor {args.motor_power:g} W")
    summary = {"steps": list(steps), "stop_time": stop, "steady_revolutions": args.steady_revolutions,
               "reference_step": steps[0], "reference": ref_figures,
               "study": {s: {f"{h:g}": e for h, e in study[s].items()} for s in SCHEMES},
               "sizing": {"motor": dict(sizing["motor"], rated_power=args.motor_power),
                          "undersized": dict(sizing["undersized"], rated_power=args.undersized_power),
                          "step": args.sizing_step},
               "libcosim": libcosim}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(f"\nwrote {out}/convergence.md, convergence.png, startup.png, summary.json")
    return 0


if __name__ == "__main__":
    sys.exit(harness.run_main(main))
