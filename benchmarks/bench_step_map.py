"""The one-step map of the compressor (issue 24 item 6): how `shaft_torque_mean` of one 1 ms step depends on each
held input (the shaft speed; under real gas also the suction and discharge pressures and the suction enthalpy),
from restored states, as an iterating co-simulation master sees it. Prints tables only; asserts nothing
(tests/mechanics/test_step_map.py checks a cheap version).

Run from anywhere:  python benchmarks/bench_step_map.py [--states N] [--speeds N] [--models real_gas ...]
                    [--rtol R] [--inputs shaft_speed suction_pressure ...] [--integrator dopri5|ark548]
                    [--fmu RotaryVaneCompressor.fmu]

A run at c = 0.05 mm, 1500 rpm, rotor_inertia = 0 (the defaults otherwise) settles for 0.1 s; then from N
consecutive states 1 ms apart (each saved with `get_state`), one 1 ms advance is made for each of the speeds
1500 + linspace(-0.01, 0.01, N_speeds) rpm (restored before each), and shaft_torque_mean = (W_in after - W_in before)
/ (angle turned) is read as the FMU computes it (fmu_src/compressor.py). The figure is the worst jump of
shaft_torque_mean between neighbouring speeds, over all states: a smooth map changes by O(1e-4 rpm x slope) between
neighbours, about 1e-7 N.m here; the table also gives the worst departure of a change from the median change of
its state (the map's slope taken out: what is left of a kink or a jump).

With --fmu the same measurement runs through fmpy's low-level API as a co-simulation master does it: 1 ms doSteps
at 1500 rpm to 0.1 s, then from each state fmi2GetFMUstate, and per speed fmi2SetFMUstate, the shaft_speed input,
one doStep and shaft_torque_mean (the FMU's defaults otherwise: interpolate_speed moves the speed over the step).

--inputs measures the map in other inputs the same way, the others held at the run's values: suction_pressure and
discharge_pressure +-10 Pa, suction_enthalpy +-10 J/kg (the suction state given by enthalpy; the FMU's
suction_state_input = "enthalpy"). They move only a real-gas run on fluid-wide tables (the pressure-table models
refuse any other boundary than their parameters').
"""
from __future__ import annotations

import argparse
import shutil
import time

import numpy as np

from rotary_vane.mechanics.loop.layout import WORK_IN
from rotary_vane.mechanics.parameters import CompressorParameters
from rotary_vane.mechanics.simulation import Simulation

from report import heading, table  # benchmarks/ is the script's folder

SPEED_RPM = 1500.0
STEP = 1e-3
SETTLE = 0.1
HALF_WIDTHS = {"shaft_speed": 0.01, "suction_pressure": 10.0, "discharge_pressure": 10.0, "suction_enthalpy": 10.0}
UNITS = {"shaft_speed": "rpm", "suction_pressure": "Pa", "discharge_pressure": "Pa", "suction_enthalpy": "J/kg"}


def held_inputs(simulation: Simulation) -> dict:
    """The inputs of the run's start (speed [rpm], boundary as set_boundary takes it, the suction state by
    enthalpy)."""
    boundary = simulation.boundary
    return {"shaft_speed": SPEED_RPM, "suction_pressure": boundary.suction.pressure,
            "discharge_pressure": boundary.back.pressure, "suction_enthalpy": boundary.suction.enthalpy}


def step_map(params: CompressorParameters, states: int, speeds: int, input_name: str = "shaft_speed",
             settle: float = SETTLE) -> tuple[np.ndarray, int]:
    """shaft_torque_mean [N.m] of one STEP advance for `speeds` values of `input_name` in +-HALF_WIDTHS around the
    run's, the other inputs held, shape (states, speeds); and how many of the advances that replayed a recorded
    step grid fell back to the step control (docs/model.md §8.2: the replayed steps' error exceeded its limit)."""
    simulation = Simulation(params, keep_history=False)
    simulation.advance(settle)
    held = held_inputs(simulation)
    offsets = np.linspace(-HALF_WIDTHS[input_name], HALF_WIDTHS[input_name], speeds)
    torques = np.empty((states, speeds))

    def advance(end_time, offset):
        inputs = {**held, input_name: held[input_name] + offset}
        speed = inputs.pop("shaft_speed")
        simulation.advance(end_time, speed_rpm=speed, boundary=inputs if input_name != "shaft_speed" else None)
    for i in range(states):
        saved = simulation.get_state()
        for j, offset in enumerate(offsets):
            simulation.set_state(saved)
            work, angle = simulation.state[WORK_IN], simulation.rotor_angle
            advance(saved.time + STEP, offset)
            torques[i, j] = (simulation.state[WORK_IN] - work) / (simulation.rotor_angle - angle)
        simulation.set_state(saved)
        advance(saved.time + STEP, 0.0)
    return torques, simulation.replay_fallbacks


def fmu_step_map(fmu: str, model: str, rtol: float, states: int, speeds: int, input_name: str = "shaft_speed",
                 settle: float = SETTLE, integrator: str = "dopri5") -> np.ndarray:
    """step_map through fmpy's FMU2Slave: shaft_torque_mean of one STEP doStep, shape (states, speeds)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    description = read_model_description(fmu)
    refs = {v.name: v.valueReference for v in description.modelVariables}
    folder = extract(fmu)
    slave = FMU2Slave(guid=description.guid, unzipDirectory=folder,
                      modelIdentifier=description.coSimulation.modelIdentifier, instanceName="step_map")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setReal([refs["stator_clearance"], refs["rotor_inertia"], refs["relative_tolerance"]], [0.05e-3, 0.0, rtol])
    slave.setString([refs["pressure_model"], refs["integrator"]], [model, integrator])
    if input_name == "suction_enthalpy":
        slave.setString([refs["suction_state_input"]], ["enthalpy"])
    slave.exitInitializationMode()
    speed, torque = refs["shaft_speed"], refs["shaft_torque_mean"]
    slave.setReal([speed], [SPEED_RPM])
    moved = refs[input_name]
    value = slave.getReal([moved])[0]
    t = 0.0
    for _ in range(round(settle / STEP)):
        slave.doStep(t, STEP)
        t += STEP
    torques = np.empty((states, speeds))
    for i in range(states):
        saved = slave.getFMUstate()
        for j, offset in enumerate(np.linspace(-HALF_WIDTHS[input_name], HALF_WIDTHS[input_name], speeds)):
            slave.setFMUstate(saved)
            slave.setReal([moved], [value + offset])
            slave.doStep(t, STEP)
            torques[i, j] = slave.getReal([torque])[0]
        slave.setFMUstate(saved)
        slave.setReal([moved], [value])
        slave.doStep(t, STEP)
        slave.freeFMUstate(saved)
        t += STEP
    slave.terminate()
    slave.freeInstance()
    shutil.rmtree(folder, ignore_errors=True)           # fmpy's extract made it (40 MB); nothing else removes it
    return torques


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=10)
    parser.add_argument("--speeds", type=int, default=201)
    parser.add_argument("--models", nargs="+", default=["ideal_gas_table", "real_gas"])
    parser.add_argument("--rtol", type=float, nargs="+", default=[3e-5, 1e-8])
    parser.add_argument("--inputs", nargs="+", default=["shaft_speed"], choices=list(HALF_WIDTHS))
    parser.add_argument("--integrator", default="dopri5", help="the integration method")
    parser.add_argument("--fmu", help="measure through this RotaryVaneCompressor.fmu with fmpy instead")
    args = parser.parse_args()
    heading(f"One-step map{' through fmpy' if args.fmu else ''} ({args.integrator}): {args.states} states x {args.speeds} values per "
            f"input, c = 0.05 mm, 1500 rpm, rotor_inertia = 0")
    rows = []
    for input_name in args.inputs:
        for model in args.models:
            if input_name != "shaft_speed" and model != "real_gas":
                continue                       # the pressure-table models take only their parameters' boundary
            for rtol in args.rtol:
                params = CompressorParameters(stator_clearance=0.05e-3, rotor_inertia=0.0, pressure_model=model,
                                              relative_tolerance=rtol, integrator=args.integrator)
                start = time.perf_counter()
                torques, fallbacks = ((fmu_step_map(args.fmu, model, rtol, args.states, args.speeds, input_name,
                                                    integrator=args.integrator), "-") if args.fmu else step_map(params, args.states, args.speeds, input_name))
                changes = np.diff(torques, axis=1)
                jumps = np.abs(changes)
                kinks = np.abs(changes - np.median(changes, axis=1, keepdims=True))     # the slope taken out
                rows.append([f"{input_name} +-{HALF_WIDTHS[input_name]:g} {UNITS[input_name]}", model, f"{rtol:g}",
                             f"{jumps.max():.2e}", f"{np.median(jumps):.2e}", f"{kinks.max():.2e}",
                             f"{(jumps > 1e-5).sum()}", f"{fallbacks}", f"{time.perf_counter() - start:.0f}"])
                print(rows[-1], flush=True)
    print(table(["input", "pressure model", "rtol", "worst jump [N.m]", "median jump",
                 "worst departure from the state's median change", "jumps > 1e-5", "replays fallen back",
                 "wall [s]"], rows))


if __name__ == "__main__":
    main()
