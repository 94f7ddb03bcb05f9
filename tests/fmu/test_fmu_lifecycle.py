"""Lifecycle fuzz of the built compressor FMU: seeded random walks over FMI calls, each sequence in its own process.

Each sequence is a random walk over the FMI 2.0 calls a master can make, in any order and with good and bad
arguments: setupExperiment, enter/exitInitializationMode, terminate, reset, setReal of the input and of parameters
(valid and out of range), setReal of an output, getReal of the outputs and of an unknown value reference, a
non-UTF-8 setString, doStep (valid, bad step sizes, a bad input, a gap in time), get/set/free FMU state,
serialize and deserialize (good and corrupted bytes). While the walk is generated, an oracle written from the
README's contract table (not from fmu_src) predicts each call's status: the state machine (instantiated,
initialization mode, initialized, terminated), the error state after any fmi2Error, which parameters and inputs are
valid, the communication point each step must start at, what a restored state brings back.

A worker process (this file run as a script) makes the calls on one instance through fmpy's FMU2Slave and, around
every call that returns fmi2Error or fmi2Discard, serializes the model state before and after. Checked for every
sequence: the process exits normally (no crash, also not at fmi2FreeInstance and interpreter exit) within its time
limit (no hang); no call returns fmi2Fatal; every status is the oracle's; after every fmi2Error or fmi2Discard the
serialized state equals the one before the call (the last good one).
"""
from __future__ import annotations

import json
import math
import random
import subprocess
import sys
import time
import zipfile
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

SEED = 20251125
SEQUENCES = 40
SAMPLE_SEQUENCES = 10                # the default test run's share (the first ten of the same seeded draw)
LENGTH = 60
TIMEOUT = 180.0                     # s per sequence (process start, kernels from the cache, the calls)
OK, WARNING, DISCARD, ERROR, FATAL = range(5)
NAMES = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL"]

# the oracle's knowledge of the FMU's interface, from the modelDescription and the README
PARAMETERS = {  # name -> (valid values, values out of the declared range)
    "restitution": ([0.5, 0.9, 1.0], [5.0, -1.0]),
    "lobes": ([3, 4], [0, 13]),
    "slot_clearance": ([0.0, 5e-5], [-1e-5, 0.5]),
}
SPEEDS = ([0.0, 1500.0, 3000.0], [-5.0, math.nan, 1e6])      # shaft_speed: allowed [0, 30000] rpm
STEPS = ([1e-4, 5e-4, 1e-3], [0.0, -1e-4, math.nan, math.inf])
START_TIMES = [0.0, 1e5, 1e9]
DEFAULTS = {"restitution": 0.9, "lobes": 3, "slot_clearance": 0.0, "shaft_speed": 1500.0}


# =====================================================================================================================
# the oracle: the README's contract table as a model
# =====================================================================================================================
class Oracle:
    def __init__(self):
        self.reset()
        self.states, self.blobs = {}, {}

    def reset(self):
        self.phase, self.error, self.failure = "instantiated", False, False
        self.values = dict(DEFAULTS)
        self.start = self.point = 0.0

    def snapshot(self):
        return dict(phase=self.phase, failure=self.failure, values=dict(self.values), start=self.start,
                    point=self.point)

    def restore(self, saved):
        self.phase, self.failure, self.values = saved["phase"], saved["failure"], dict(saved["values"])
        self.start, self.point, self.error = saved["start"], saved["point"], False

    def valid(self):
        speed = self.values["shaft_speed"]
        return (all(self.values[name] in PARAMETERS[name][0] for name in PARAMETERS)
                and math.isfinite(speed) and 0.0 <= speed <= 30000.0)

    def refuse(self):
        self.error = True
        return ERROR

    def apply(self, op) -> int | None:
        """The status the contract prescribes for `op` (None: the op makes no FMI call), and the oracle's new
        state."""
        kind = op[0]
        free_in_error = kind in ("get_outputs", "get_unknown", "get_state", "set_state", "free_state", "serialize",
                                 "deserialize", "deserialize_bad", "reset")
        if self.error and not free_in_error:
            return ERROR                                                  # C8
        if kind == "setup":
            if self.phase != "instantiated":
                return self.refuse()
            self.start = self.point = op[1]
            return OK
        if kind == "enter":
            if self.phase != "instantiated":
                return self.refuse()
            self.phase = "initialization mode"
            return OK
        if kind == "exit":
            if self.phase != "initialization mode":
                return self.refuse()
            if not self.valid():
                return self.refuse()                                      # C2: nothing changes but the error state
            self.phase, self.point = "initialized", self.start
            return OK
        if kind == "terminate":
            if self.phase != "initialized":
                return self.refuse()
            self.phase = "terminated"
            return OK
        if kind == "reset":
            self.reset()
            return OK
        if kind in ("set_speed", "set_parameter"):
            name, value = ("shaft_speed", op[1]) if kind == "set_speed" else op[1:]
            allowed = ("instantiated", "initialization mode") + (("initialized",) if kind == "set_speed" else ())
            if self.phase not in allowed:
                return self.refuse()                                      # C3, C4
            self.values[name] = value
            return OK
        if kind in ("set_output", "get_unknown", "set_string_bad"):
            return self.refuse()                                          # C4, C5
        if kind == "get_outputs":
            return self.refuse() if self.phase == "instantiated" else OK
        if kind in ("step", "step_gap"):
            if self.phase != "initialized" or self.failure or kind == "step_gap":
                return self.refuse()                                      # C3, C7
            h = op[1]
            if not (math.isfinite(h) and h > 0.0):
                return self.refuse()                                      # C6
            speed = self.values["shaft_speed"]
            if not (math.isfinite(speed) and 0.0 <= speed <= 30000.0):
                return DISCARD                                            # C10
            self.point = self.point + h
            return OK
        if kind == "get_state":
            self.states[op[1]] = self.snapshot()
            return OK
        if kind == "set_state":
            if op[1] not in self.states:
                return None
            self.restore(self.states[op[1]])
            return OK
        if kind == "free_state":
            return OK if self.states.pop(op[1], None) is not None else None
        if kind == "serialize":
            if op[1] not in self.states:
                return None
            self.blobs[op[1]] = self.states[op[1]]
            return OK
        if kind == "deserialize":
            if op[1] not in self.blobs:
                return None
            self.states[op[2]] = self.blobs[op[1]]
            return OK
        if kind == "deserialize_bad":
            return self.refuse()                                          # C12
        raise ValueError(kind)


def generate(rng: random.Random, length: int):
    """A sequence of (op, expected status), the ops carrying the communication points the oracle expects."""
    oracle, sequence = Oracle(), []
    menu = [
        (3, lambda: ("setup", rng.choice(START_TIMES))), (4, lambda: ("enter",)), (4, lambda: ("exit",)),
        (1, lambda: ("terminate",)), (1, lambda: ("reset",)),
        (4, lambda: ("set_speed", rng.choice(SPEEDS[0] * 3 + SPEEDS[1]))),
        (3, lambda: ("set_parameter", (n := rng.choice(list(PARAMETERS))),
                     rng.choice(PARAMETERS[n][0] * 2 + PARAMETERS[n][1]))),
        (1, lambda: ("set_output",)), (3, lambda: ("get_outputs",)), (1, lambda: ("get_unknown",)),
        (1, lambda: ("set_string_bad",)),
        (12, lambda: ("step", rng.choice(STEPS[0] * 4 + STEPS[1]))), (1, lambda: ("step_gap",)),
        (3, lambda: ("get_state", rng.choice("ab"))), (3, lambda: ("set_state", rng.choice("ab"))),
        (1, lambda: ("free_state", rng.choice("ab"))), (3, lambda: ("serialize", rng.choice("ab"))),
        (4, lambda: ("deserialize", rng.choice("ab"), rng.choice("ab"))),
        (1, lambda: ("deserialize_bad", rng.choice(["junk", "truncated", "changed", "version"]))),
    ]
    weights = [w for w, _ in menu]
    # half of the calls are what a master would do next (so that the walks reach deep states), half are random
    natural = {"instantiated": lambda: rng.choice([("setup", rng.choice(START_TIMES)), ("enter",)]),
               "initialization mode": lambda: ("exit",), "terminated": lambda: ("reset",),
               "initialized": lambda: ("step", rng.choice(STEPS[0]))}
    while len(sequence) < length:
        if oracle.error and rng.random() < 0.7:
            op = ("set_state", rng.choice(sorted(oracle.states))) if oracle.states and rng.random() < 0.6 \
                else ("reset",)
        elif rng.random() < 0.5:
            op = natural[oracle.phase]()
        else:
            op = rng.choices(menu, weights)[0][1]()
        if op[0] in ("step", "step_gap"):
            op = (op[0], op[1] if op[0] == "step" else 1e-4, oracle.point)
        expected = oracle.apply(op)
        if expected is not None:
            sequence.append((op, expected))
    return sequence


# =====================================================================================================================
# the worker: `python test_fmu_lifecycle.py worker UNZIPDIR SEQUENCE.json`
# =====================================================================================================================
def worker(unzipdir: str, sequence_file: str) -> int:
    from ctypes import c_char_p, c_double, c_uint

    from fmpy import read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    description = read_model_description(unzipdir)
    vr = {v.name: v.valueReference for v in description.modelVariables}
    outputs = [v.valueReference for v in description.modelVariables if v.causality == "output" and v.type == "Real"]
    fmu = FMU2Slave(guid=description.guid, unzipDirectory=unzipdir,
                    modelIdentifier=description.coSimulation.modelIdentifier, instanceName="lifecycle")
    fmu.instantiate(loggingOn=True, callbacks=None)
    states, blobs, record = {}, {}, []

    def status(call):
        try:
            call()
            return OK
        except FMICallException as error:
            return int(error.status)

    def serialized():
        state = fmu.getFMUstate()
        data = bytes(fmu.serializeFMUstate(state))
        fmu.freeFMUstate(state)
        return data

    def bad_blob(kind):
        good = serialized()
        return {"junk": b"junk" * 30, "truncated": good[:-7], "changed": good[:150] + bytes([good[150] ^ 4]) + good[151:],
                "version": good[:10] + (9).to_bytes(2, "little") + good[12:]}[kind]

    for op, _ in json.loads(Path(sequence_file).read_text()):
        kind = op[0]
        before = serialized()
        if kind == "setup":
            code = status(lambda: fmu.setupExperiment(startTime=op[1]))
        elif kind == "enter":
            code = status(fmu.enterInitializationMode)
        elif kind == "exit":
            code = status(fmu.exitInitializationMode)
        elif kind == "terminate":
            code = status(fmu.terminate)
        elif kind == "reset":
            code = status(fmu.reset)
        elif kind == "set_speed":
            code = status(lambda: fmu.setReal([vr["shaft_speed"]], [op[1]]))
        elif kind == "set_parameter":
            setter = fmu.setInteger if isinstance(op[2], int) else fmu.setReal
            code = status(lambda: setter([vr[op[1]]], [op[2]]))
        elif kind == "set_output":
            code = status(lambda: fmu.setReal([vr["shaft_torque"]], [1.0]))
        elif kind == "get_outputs":
            values = (c_double * len(outputs))()
            code = status(lambda: fmu.fmi2GetReal(fmu.component, (c_uint * len(outputs))(*outputs), len(outputs),
                                                  values))
            if code == OK and not all(math.isfinite(v) for v in values):
                code = -1                                  # NaN with fmi2OK: never allowed
        elif kind == "get_unknown":
            code = status(lambda: fmu.getReal([987654]))
        elif kind == "set_string_bad":
            code = status(lambda: fmu.fmi2SetString(fmu.component, (c_uint * 1)(vr["displacement_law"]), 1,
                                                    (c_char_p * 1)(b"\xff\xfe")))
        elif kind in ("step", "step_gap"):
            h, point = op[1], op[2]
            code = status(lambda: fmu.doStep(point + (5e-3 if kind == "step_gap" else 0.0), h))
        elif kind == "get_state":
            if op[1] in states:
                fmu.freeFMUstate(states.pop(op[1]))
            code = status(lambda: states.__setitem__(op[1], fmu.getFMUstate()))
        elif kind == "set_state":
            code = status(lambda: fmu.setFMUstate(states[op[1]]))
        elif kind == "free_state":
            code = status(lambda: fmu.freeFMUstate(states.pop(op[1])))
        elif kind == "serialize":
            code = status(lambda: blobs.__setitem__(op[1], bytes(fmu.serializeFMUstate(states[op[1]]))))
        elif kind == "deserialize":
            if op[2] in states:
                fmu.freeFMUstate(states.pop(op[2]))
            code = status(lambda: states.__setitem__(op[2], fmu.deSerializeFMUstate(blobs[op[1]])))
        elif kind == "deserialize_bad":
            data = bad_blob(op[1])
            code = status(lambda: fmu.deSerializeFMUstate(data))
        else:
            raise ValueError(kind)
        unchanged = serialized() == before if code in (ERROR, DISCARD) else None
        record.append([code, unchanged])
    for state in states.values():
        fmu.freeFMUstate(state)
    fmu.freeInstance()
    print("@@RECORD@@ " + json.dumps(record), flush=True)
    return 0


# =====================================================================================================================
# the tests
# =====================================================================================================================
def run_sequence(unzipdir: Path, sequence, folder: Path, index: int) -> dict:
    path = folder / f"sequence_{index}.json"
    path.write_text(json.dumps(sequence))
    started = time.monotonic()
    try:
        done = subprocess.run([sys.executable, __file__, "worker", str(unzipdir), str(path)], capture_output=True,
                              text=True, timeout=TIMEOUT, cwd=folder)
    except subprocess.TimeoutExpired:
        return {"index": index, "crash": f"hang: no exit within {TIMEOUT} s", "record": None}
    lines = [line for line in done.stdout.splitlines() if line.startswith("@@RECORD@@ ")]
    result = {"index": index, "returncode": done.returncode, "seconds": time.monotonic() - started,
              "record": json.loads(lines[-1].split(" ", 1)[1]) if lines else None,
              "stderr": done.stderr[-1500:], "crash": None}
    if done.returncode != 0 or not lines:
        result["crash"] = f"exit status {done.returncode}"
    return result


@pytest.fixture(scope="module", params=[SAMPLE_SEQUENCES, pytest.param(SEQUENCES, marks=pytest.mark.slow)],
                ids=lambda count: f"{count} walks")
def walks(built_fmus, tmp_path_factory, request):
    """The first `request.param` seeded walks (the default run a sample, the slow run all), each in its own process."""
    folder = tmp_path_factory.mktemp("lifecycle")
    unzipdir = folder / "unzipped"
    with zipfile.ZipFile(built_fmus / "RotaryVaneCompressor.fmu") as archive:
        archive.extractall(unzipdir)
    rng = random.Random(SEED)
    sequences = [generate(rng, LENGTH) for _ in range(request.param)]
    started = time.monotonic()
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda item: run_sequence(unzipdir, item[1], folder, item[0]), enumerate(sequences)))
    seconds = time.monotonic() - started
    outcomes = Counter(NAMES[code] if 0 <= code < 5 else "NaN with OK" for result in results
                       for code, _ in result["record"] or [])
    calls = sum(len(result["record"] or []) for result in results)
    print(f"\nlifecycle fuzz: {len(sequences)} sequences, {calls} calls in {seconds:.0f} s; outcomes "
          f"{dict(sorted(outcomes.items()))}; ops {dict(Counter(op[0] for s in sequences for op, _ in s))}")
    return sequences, results


def test_no_crash_no_hang_no_fatal(walks):
    sequences, results = walks
    crashes = [f"sequence {r['index']}: {r['crash']}\n{r.get('stderr', '')}" for r in results if r["crash"]]
    assert not crashes, "\n".join(crashes)
    fatal = [r["index"] for r in results if any(code == FATAL for code, _ in r["record"])]
    assert not fatal, f"fmi2Fatal in sequences {fatal}"


def test_every_status_is_the_contracts(walks):
    sequences, results = walks
    wrong = []
    for sequence, result in zip(sequences, results):
        for k, ((op, expected), (code, _)) in enumerate(zip(sequence, result["record"] or [])):
            if code != expected:
                wrong.append(f"sequence {result['index']} call {k} {op}: "
                             f"{NAMES[code] if 0 <= code < 5 else 'NaN with fmi2OK'}, the contract says "
                             f"{NAMES[expected]} (before: {[o for o, _ in sequence[max(0, k - 4):k]]})")
                break                                     # the rest of the sequence follows from a wrong guess
    assert not wrong, "\n".join(wrong[:10])


def test_after_error_or_discard_the_state_is_the_last_good_one(walks):
    sequences, results = walks
    changed = [(r["index"], k) for r in results for k, (code, same) in enumerate(r["record"] or [])
               if code in (ERROR, DISCARD) and same is not True]
    assert not changed, f"state changed by a refused call (sequence, call): {changed}"
    refused = sum(1 for r in results for code, _ in r["record"] or [] if code in (ERROR, DISCARD))
    assert refused >= len(sequences), refused             # the walks do exercise refusals


def test_the_walks_cover_the_contract(walks):
    """Every kind of call and every status the contract uses occur in the walks."""
    sequences, results = walks
    kinds = {op[0] for sequence in sequences for op, _ in sequence}
    assert kinds >= {"setup", "enter", "exit", "terminate", "reset", "set_speed", "set_parameter", "step",
                     "step_gap", "get_state", "set_state", "serialize", "deserialize", "deserialize_bad"}
    assert {expected for sequence in sequences for _, expected in sequence} == {OK, DISCARD, ERROR}


if __name__ == "__main__" and len(sys.argv) > 1 and sys.argv[1] == "worker":
    sys.exit(worker(*sys.argv[2:]))
