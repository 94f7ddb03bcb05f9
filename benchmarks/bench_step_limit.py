"""What sets Dormand-Prince's step (issue 25): which state components' error estimates limit and reject the steps, and
whether the dominant Jacobian eigenvalues make it stiffness or accuracy (z = 3, 1500 rpm, one revolution from a state
settled for 0.2 s). Prints tables only; asserts nothing.

Run from anywhere:  python benchmarks/bench_step_limit.py [--clearances 0 0.05 0.2] [--models real_gas ...]

Two processes per case: a compiled one settles the run, samples the Jacobian of the states that feed back (vane pose
and velocities, and under real gas T_L, m_L, T_T, m_T) by central differences at 200 points of the next revolution
and saves the settled state; a pure-Python one (NUMBA_DISABLE_JIT=1, the same source) continues for the revolution
with Dormand-Prince's attempt wrapped, so that each attempt's scaled error is split into the state components'
shares of the RMS norm. The wrapper only reads what the attempt left in the workspace; the loop is the shipped one.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

from report import heading, table  # benchmarks/ is the script's folder

SPEED, SETTLE, REVOLUTION = 1500.0, 0.2, 0.04
SAMPLES = 200
GROUP_NAMES = {0: "x3", 1: "y3", 2: "phi3", 3: "vx3", 4: "vy3", 5: "omega3", 6: "W_in", 7: "W_out", 8: "W_fric",
               9: "W_damp", 10: "W_el", 11: "T_L", 12: "m_L", 13: "T_T", 14: "m_T", 15: "m_suction",
               16: "m_discharge", 17: "E_suction", 18: "E_discharge", 19: "W_chambers", 20: "m_back", 21: "E_back"}


def parameters(model, clearance, extra):
    from rotary_vane.mechanics import CompressorParameters
    return CompressorParameters(slot_clearance=clearance, stator_clearance=clearance, pressure_model=model, **extra)


def settle(model, clearance, extra, path):
    """Compiled: settle, save the state, sample the feed-back Jacobian's dominant eigenvalues over one revolution."""
    from rotary_vane.mechanics import Simulation, constant_speed
    from rotary_vane.mechanics.loop.layout import GAS_BLOCK
    from rotary_vane.thermo.chamber_state import CHAMBER_STATES
    simulation = Simulation(parameters(model, clearance, extra), constant_speed(SPEED), keep_history=False)
    simulation.advance(SETTLE)
    saved = simulation.get_state()
    np.savez(path, time=saved.time, **{k: getattr(saved, k) for k in saved.__dataclass_fields__ if k != "time"})
    columns = list(range(6)) + (list(range(GAS_BLOCK, GAS_BLOCK + CHAMBER_STATES)) if model == "real_gas" else [])
    dominant, gas_share, real = [], [], []
    for k in range(SAMPLES):
        simulation.advance(SETTLE + REVOLUTION * (k + 1) / SAMPLES)
        y = simulation.state.copy()
        jac = np.empty((len(columns), len(columns)))
        for j, col in enumerate(columns):
            step = 1e-7 * max(abs(y[col]), 1e-3)
            plus, minus = y.copy(), y.copy()
            plus[col] += step
            minus[col] -= step
            jac[:, j] = (simulation.evaluate(simulation.time, plus)[1][columns]
                         - simulation.evaluate(simulation.time, minus)[1][columns]) / (2.0 * step)
        values, vectors = np.linalg.eig(jac)
        top = int(np.argmax(np.abs(values)))
        dominant.append(abs(values[top]))
        real.append(abs(values[top].imag) < 1e-6 * abs(values[top]))
        # eigenvector weight on the gas states, each state scaled by its absolute tolerance
        scale = np.array([1e-9, 1e-9, 1e-8, 1e-6, 1e-6, 1e-4] + [1e-4, 1e-9, 1e-4, 1e-9][:len(columns) - 6])
        weights = np.abs(vectors[:, top]) / scale
        gas_share.append(float(np.sum(weights[6:] ** 2) / np.sum(weights ** 2)))
    return dict(median_dominant=float(np.median(dominant)), max_dominant=float(np.max(dominant)),
                real_fraction=float(np.mean(real)), gas_share=float(np.median(gas_share)))


def trace(model, clearance, extra, path):
    """Pure Python: one revolution with the Dormand-Prince attempt wrapped to split its error by component."""
    from rotary_vane.mechanics import Simulation, constant_speed
    from rotary_vane.mechanics.simulation import SimulationState
    from rotary_vane.mechanics.loop import integrators
    from rotary_vane.mechanics.loop.layout import GAS_BLOCK, MEM_LOBE_START
    from rotary_vane.thermo.chamber_state import CHAMBER_STATES
    records, where = [], []
    original = integrators.dopri5_attempt

    def attempt(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters):
        failure, err = original(t, h, event, y, ctx, memory, control, history, work, work_rows, out, counters)
        m, c, n = ctx.machine[0], ctx.chambers[0], y.size
        shares = np.empty(n)
        for i in range(n):
            error = sum(integrators.DOPRI5_E[j] * work[j, i] for j in range(integrators.STAGES))
            shares[i] = (h * error / integrators._tolerance(i, max(abs(y[i]), abs(work[integrators.W_Y_NEW, i])),
                                                            m, c)) ** 2
        shares = shares / max(shares.sum(), 1e-300)
        records.append((h, err, event, shares, gas_stiffness(t, y, memory, h, shares, err, ctx.law)))
        return failure, err

    def gas_stiffness(t, y, memory, h, shares, err, law):
        """h max|lambda| of the chambers' T, m block (the explicit method is stable for h |lambda| < 3.3 on the
        real axis) at steps whose error the chamber masses and temperatures hold near the limit, else NaN."""
        top = int(np.argmax(shares))
        if not (err > 0.2 and GAS_BLOCK <= top < GAS_BLOCK + CHAMBER_STATES):
            return np.nan
        columns = range(GAS_BLOCK, GAS_BLOCK + CHAMBER_STATES)
        jac = np.empty((CHAMBER_STATES, CHAMBER_STATES))
        base = simulation.evaluate(t, y, memory)[1]
        for j, col in enumerate(columns):
            plus = np.array(y)
            plus[col] += 1e-7 * abs(y[col])
            jac[:, j] = (simulation.evaluate(t, plus, memory)[1][list(columns)] - base[list(columns)]) \
                / (1e-7 * abs(y[col]))
        lobe = 2.0 * np.pi / simulation.params.lobes
        where.append((integrators.rotor_motion(t, law)[0] - memory[MEM_LOBE_START]) / lobe)
        return h * float(np.max(np.abs(np.linalg.eigvals(jac))))

    integrators.dopri5_attempt = attempt
    data = np.load(path)
    simulation = Simulation(parameters(model, clearance, extra), constant_speed(SPEED), keep_history=False)
    simulation.set_state(SimulationState(float(data["time"]), **{k: data[k] for k in data.files if k != "time"}))
    simulation.advance(SETTLE + REVOLUTION)
    steps = np.array([r[0] for r in records])
    errs = np.array([r[1] for r in records])
    shares = np.array([r[3] for r in records])
    accepted = errs <= 1.0
    unclipped = np.array([r[2] == integrators.NO_EVENT for r in records])
    limiting = accepted & unclipped & (errs > 0.2)     # steps the error control held near its limit
    summary = {}
    for label, mask in (("rejected_by", ~accepted), ("limited_by", limiting)):
        top = np.argmax(shares[mask], axis=1) if mask.any() else np.array([], dtype=int)
        counts = np.bincount(top, minlength=shares.shape[1])
        summary[label] = {GROUP_NAMES[i]: int(counts[i]) for i in np.argsort(counts)[::-1][:4] if counts[i]}
        summary[label + "_share"] = {GROUP_NAMES[i]: float(shares[mask][:, i].mean()) for i in
                                     np.argsort(shares[mask].mean(axis=0))[::-1][:4]} if mask.any() else {}
    stiffness = np.array([r[4] for r in records])
    stiffness = stiffness[np.isfinite(stiffness)]
    summary.update(gas_lobe_position=[float(q) for q in np.percentile(where, [10, 50, 90])] if where else [],
                   gas_h_lambda=[float(q) for q in np.percentile(stiffness, [50, 90, 100])] if stiffness.size else [],
                   accepted=int(accepted.sum()), rejected=int((~accepted).sum()),
                   median_step_us=float(np.median(steps[accepted]) * 1e6))
    return summary


def case(model, clearance, extra):
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "state.npz")
        spec = json.dumps(dict(model=model, clearance=clearance, extra=extra, path=path))
        compiled = subprocess.run([sys.executable, __file__, "--settle", spec], capture_output=True, text=True,
                                  check=True)
        python = subprocess.run([sys.executable, __file__, "--trace", spec], capture_output=True, text=True,
                                check=True, env={**os.environ, "NUMBA_DISABLE_JIT": "1"})
    return json.loads(compiled.stdout.splitlines()[-1]), json.loads(python.stdout.splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clearances", type=float, nargs="+", default=[0.0, 0.05, 0.2], help="mm")
    parser.add_argument("--models", nargs="+", default=["ideal_gas_table", "real_gas"])
    parser.add_argument("--extra", default="{}", help="further CompressorParameters as JSON, e.g. "
                                                      "'{\"onset_velocity_floor\": 0.1}'")
    parser.add_argument("--settle", help=argparse.SUPPRESS)
    parser.add_argument("--trace", help=argparse.SUPPRESS)
    args = parser.parse_args()
    for flag, function in (("settle", settle), ("trace", trace)):
        spec = getattr(args, flag)
        if spec:
            spec = json.loads(spec)
            print(json.dumps(function(spec["model"], spec["clearance"], spec["extra"], spec["path"])))
            return
    extra = json.loads(args.extra)
    heading(f"Dormand-Prince's step limit over one revolution at {SPEED:g} rpm (extra parameters: {extra})")
    rows = []
    for model in args.models:
        for clearance in args.clearances:
            eig, steps = case(model, clearance * 1e-3, extra)
            rows.append([model, f"{clearance:g}", f"{steps['accepted']} / {steps['rejected']}",
                         f"{steps['median_step_us']:.1f}", f"{eig['median_dominant']:.3g} / {eig['max_dominant']:.3g}",
                         f"{eig['real_fraction']:.2f}", f"{eig['gas_share']:.2f}",
                         ", ".join(f"{k} {v}" for k, v in steps["limited_by"].items()),
                         ", ".join(f"{k} {v}" for k, v in steps["rejected_by"].items()),
                         " / ".join(f"{q:.2g}" for q in steps["gas_h_lambda"]),
                         " / ".join(f"{q:.2f}" for q in steps["gas_lobe_position"])])
            print(rows[-1], flush=True)
    print(table(["model", "c [mm]", "accepted / rejected", "median h [us]", "|lambda| median / max [1/s]",
           "dominant real", "dominant on gas", "largest share, steps at err > 0.2", "largest share, rejected",
           "h |lambda_gas| at gas-held steps: median / 90 % / max",
           "their position in the lobe (0: start valley, 1: end valley): 10 / 50 / 90 %"],
          rows))


if __name__ == "__main__":
    main()
