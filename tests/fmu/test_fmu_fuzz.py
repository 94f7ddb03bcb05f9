"""Robustness fuzz of the built compressor FMU through fmpy's low-level FMI 2 API (`fmpy.fmi2.FMU2Slave`).

Every FMI call is made on the raw `fmi2*` function and its status is recorded (fmpy raises `FMICallException` for
statuses above fmi2Warning; the status is taken from the exception). The cases run in worker subprocesses (this
file run as a script), many cases per process on one FMU instance with `fmi2Reset` between them; two workers run
in parallel. A worker that dies (signal, non-zero exit) or whose instance returned fmi2Fatal is replaced by a new
one for the remaining cases, so that every case is run and reported.

The cases (seeded, bounded: about 940; the default test run takes a sample of about 270, every large group thinned
evenly (SAMPLE_EVERY), and the slow run all of them; 3 min on a busy 2-core machine for all): bad parameter values and relations, bad
inputs, odd step sizes and communication points, odd call orders, FMU-state misuse, host contract violations
(wrong types, unknown value references, corrupted state bytes), random call sequences, and state blobs with a valid
envelope and crafted content (every field of the state tree). Checked: no call returns
fmi2Fatal; no worker process crashes, also not at its teardown (fmi2FreeInstance, unloading, exit); a refused
parameter, input or step size is named with its value in a message and its step returns fmi2Error (fmi2Discard for
an input value); the valid steps after a refused input (or, after fmi2SetFMUstate, a refused step size) are fmi2OK.
A separate process makes a second fmi2Instantiate and sets a state of one instance into the other.

`python tests/fmu/test_fmu_fuzz.py report --fmu X.fmu [--json OUT]` prints the table of every case and its statuses.
"""
from __future__ import annotations

import json
import math
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

import pytest

MODEL = "RotaryVaneCompressor"
STATUS_NAMES = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"]
OK, WARNING, DISCARD, ERROR, FATAL = range(5)
SEED = 20240611
CASE_TIMEOUT = 90.0          # s; a case running longer is killed and reported as a hang
SMALL_STEP = 1e-4            # s; the communication step of the short runs after each bad value
LANES = 2                    # worker processes run in parallel


# =====================================================================================================================
# Worker: runs in a subprocess, `python test_fmu_fuzz.py worker UNZIPDIR CASES.json RESULTS.jsonl INSTANCE_NAME`.
# Each case is a list of operations; the worker writes one JSON line per event and flushes it, so that a crash still
# leaves a record of the case it happened in.
# =====================================================================================================================


class Harness:
    """One FMU instance driven through the raw fmi2* functions, with every status and log message recorded."""

    def __init__(self, unzipdir: str, instance_name: str):
        from ctypes import byref

        from fmpy import calloc, free, read_model_description
        from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
        from fmpy.logging import addLoggerProxy

        self.unzipdir = unzipdir
        self.description = read_model_description(unzipdir)
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.messages: list[list] = []
        self.time = 0.0
        self.states = {}          # slot -> fmi2FMUstate (owned by the instance, freed with fmi2FreeFMUstate)
        self.blobs = {}           # slot -> serialized state bytes
        self.state_times = {}     # slot -> communication point at which the state (or blob) was taken
        self.blob_times = {}
        self.dead = False
        # a logger that records instead of printing; fmpy's native proxy formats the printf-style message first
        self._logger = fmi2CallbackLoggerTYPE(self._log)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(byref(self.callbacks))
        self.fmu = FMU2Slave(guid=self.description.guid, unzipDirectory=unzipdir, modelIdentifier=MODEL,
                             instanceName=instance_name)
        try:
            self.fmu.instantiate(callbacks=self.callbacks, loggingOn=True)
        except Exception as error:                  # fmi2Instantiate returned NULL
            raise RuntimeError(f"fmi2Instantiate returned NULL; messages: {self.messages}") from error

    def _log(self, environment, instance, status, category, message):
        self.messages.append([int(status), message.decode("utf-8", "replace")])

    # raw calls --------------------------------------------------------------------------------------------------
    def call(self, function: str, *args) -> int:
        from fmpy.fmi1 import FMICallException
        try:
            return int(getattr(self.fmu, function)(self.fmu.component, *args))
        except FMICallException as error:
            return int(error.status)

    def _typed(self, kind):
        from ctypes import c_char_p, c_double, c_int
        return {"Real": c_double, "Integer": c_int, "Boolean": c_int, "String": c_char_p}[kind]

    def set_raw(self, kind: str, reference: int, value) -> int:
        from ctypes import c_uint
        if kind == "String" and isinstance(value, str):
            value = value.encode("utf-8")
        elif kind == "String" and isinstance(value, dict):          # {"bytes_hex": ...}: raw (maybe invalid) bytes
            value = bytes.fromhex(value["bytes_hex"])
        if isinstance(reference, str):              # by name, with the type given by the caller
            reference = self.variables[reference].valueReference
        references = (c_uint * 1)(reference)
        values = (self._typed(kind) * 1)(value)
        return self.call(f"fmi2Set{kind}", references, 1, values)

    def get_raw(self, kind: str, references: list[int]):
        from ctypes import c_uint
        references = [self.variables[r].valueReference if isinstance(r, str) else r for r in references]
        refs = (c_uint * len(references))(*references)
        values = (self._typed(kind) * len(references))()
        status = self.call(f"fmi2Get{kind}", refs, len(references), values)
        out = list(values)
        if kind == "String":
            out = [None if v is None else v.decode("utf-8", "replace") for v in out]
        return status, out

    # operations -------------------------------------------------------------------------------------------------
    def op(self, name: str, *args):
        """Run one operation; return (status or a string for a skipped/no-call op, detail)."""
        from ctypes import byref, c_size_t, create_string_buffer
        from fmpy.fmi2 import fmi2FMUstate
        if name == "reset":
            status = self.call("fmi2Reset")
            self.time = 0.0
            return status, None
        if name == "setup":
            self.time = args[0]
            return self.call("fmi2SetupExperiment", 0, 0.0, args[0], 0, 0.0), None
        if name == "enter":
            return self.call("fmi2EnterInitializationMode"), None
        if name == "exit":
            return self.call("fmi2ExitInitializationMode"), None
        if name == "terminate":
            return self.call("fmi2Terminate"), None
        if name == "advance":                       # a step from the current communication point
            step = args[0]
            status = self.call("fmi2DoStep", self.time, step, 1)
            if status == OK:
                self.time += step
            return status, self.time
        if name == "run":                           # n steps of h; stops at the first refused one
            count, step = args
            statuses = []
            for _ in range(count):
                status = self.call("fmi2DoStep", self.time, step, 1)
                statuses.append(status)
                if status != OK:
                    break
                self.time += step
            return max(statuses), {"steps": len(statuses), "time": self.time}
        if name == "step":                          # a step at an explicit communication point
            return self.call("fmi2DoStep", args[0], args[1], 1), None
        if name == "set":                           # by variable name
            variable = self.variables[args[0]]
            return self.set_raw(variable.type, variable.valueReference, args[1]), None
        if name == "set_as":                        # raw: kind, value reference, value
            return self.set_raw(*args), None
        if name == "get_as":
            status, values = self.get_raw(args[0], args[1])
            return status, values
        if name == "get_all":                       # every variable, per type; returns the non-finite outputs
            worst, bad = OK, []
            for kind in ("Real", "Integer", "Boolean", "String"):
                names = [v.name for v in self.variables.values() if v.type == kind]
                status, values = self.get_raw(kind, [self.variables[n].valueReference for n in names])
                worst = max(worst, status)
                if kind == "Real":
                    bad += [n for n, v in zip(names, values)
                            if not math.isfinite(v) and self.variables[n].causality == "output"]
            return worst, {"nonfinite_outputs": bad}
        if name == "get_outputs":
            names = ["shaft_torque_mean", "input_power", "shaft_angle"]
            status, values = self.get_raw("Real", [self.variables[n].valueReference for n in names])
            return status, dict(zip(names, values))
        if name == "state_get":
            state = self.states.get(args[0], fmi2FMUstate())
            status = self.call("fmi2GetFMUstate", byref(state))
            self.states[args[0]] = state
            self.state_times[args[0]] = self.time
            return status, None
        if name in ("state_set", "state_free", "serialize") and args[0] not in self.states:
            return "skipped", f"no state in slot {args[0]!r}"
        if name == "state_set":                     # the host continues from the state's communication point
            self.time = self.state_times.get(args[0], self.time)
            return self.call("fmi2SetFMUstate", self.states[args[0]]), None
        if name == "state_free":
            state = self.states.pop(args[0])
            return self.call("fmi2FreeFMUstate", byref(state)), None
        if name == "serialize":
            size = c_size_t()
            status = self.call("fmi2SerializedFMUstateSize", self.states[args[0]], byref(size))
            if status > WARNING:
                return status, None
            buffer = create_string_buffer(size.value)
            status = max(status, self.call("fmi2SerializeFMUstate", self.states[args[0]], buffer, size))
            self.blobs[args[0]] = buffer.raw
            self.blob_times[args[0]] = self.state_times.get(args[0], self.time)
            return status, {"bytes": size.value}
        if name == "craft":                         # a serialized state with its content changed: slot, edit, new
            source, edit, target = args
            if source not in self.blobs:
                return "skipped", f"no serialized state in slot {source!r}"
            self.blobs[target] = craft_blob(self.blobs[source], edit)
            self.blob_times[target] = self.blob_times[source]
            return "no call", {"bytes": len(self.blobs[target])}
        if name == "same_blobs":                    # are two serialized states byte for byte the same
            same = self.blobs.get(args[0]) is not None and self.blobs.get(args[0]) == self.blobs.get(args[1])
            return "no call", {"same": same}
        if name == "deserialize":                   # source: {"hex": ...} or {"blob": slot, "truncate": n}
            source, slot = args
            if "hex" in source:
                data = bytes.fromhex(source["hex"])
            elif source["blob"] in self.blobs:
                data = self.blobs[source["blob"]][:source.get("truncate")]
            else:
                return "skipped", f"no serialized state in slot {source['blob']!r}"
            buffer = create_string_buffer(data, len(data))
            state = fmi2FMUstate()
            status = self.call("fmi2DeSerializeFMUstate", buffer, len(data), byref(state))
            if status <= WARNING:
                self.states[slot] = state
                if "blob" in source:
                    self.state_times[slot] = self.blob_times[source["blob"]]
            return status, None
        raise ValueError(f"unknown operation {name!r}")

    def run(self, operations):
        record = []
        for operation in operations:
            self.messages = []
            try:
                status, detail = self.op(*operation)
            except Exception as error:              # a harness problem, not an FMU status
                status, detail = "harness-error", f"{type(error).__name__}: {error}"
            record.append({"op": operation, "status": status, "detail": detail, "messages": self.messages})
            if status == FATAL:
                self.dead = True                    # the instance must not be used any more
                break
        return record

    def free(self):
        self.fmu.freeInstance()                     # fmi2FreeInstance + unloading the library


def craft_blob(blob: bytes, edit) -> bytes:
    """`blob` (fmu_src/state_format.py) with one edit of its content, its length and CRC-32 recomputed so that the
    envelope is valid: ["set", path, value] sets the JSON node at `path` (keys of the state tree) to `value` (raw
    JSON: {"f": "nan"} is a NaN, {"f": []} a malformed node); ["nan", path, index] writes NaN into element `index`
    of the array at `path`, ["step", path, value] the value into its first element; ["entries", path, n] sets the
    dict at `path` to n entries k0..k{n-1} = 0.0."""
    import struct
    import zlib
    header, payload = blob[:96], blob[96:]
    (length,) = struct.unpack_from("<I", payload)
    description = json.loads(payload[4:4 + length])
    data = bytearray(payload[4 + length:])
    kind, path, argument = edit
    parent, key = None, None
    node = description
    for part in path:
        parent, key = (node["d"], part) if isinstance(node, dict) and "d" in node else (node, part)
        node = parent[key]
    if kind == "set":
        parent[key] = argument
    elif kind == "nan":             # a negative index counts from the end, as in Python
        struct.pack_into("<d", data, node["offset"] + 8 * (argument % math.prod(node["shape"])), math.nan)
    elif kind == "step":
        struct.pack_into("<d", data, node["offset"], argument)
    elif kind == "entries":
        parent[key] = {"d": {f"k{i}": 0.0 for i in range(argument)}}
    text = json.dumps(description, separators=(",", ":")).encode()
    body = struct.pack("<I", len(text)) + text + bytes(data)
    magic, version, _, _, tag = struct.unpack("<10sHQI72s", header)
    return struct.pack("<10sHQI72s", magic, version, len(body), zlib.crc32(body), tag) + body


def worker_main(unzipdir, cases_path, results_path, instance_name):
    cases = json.loads(Path(cases_path).read_text())
    with open(results_path, "a", encoding="utf-8") as out:
        def write(event):
            out.write(json.dumps(event) + "\n")
            out.flush()
        harness = Harness(unzipdir, instance_name)
        write({"event": "instantiated"})
        for case in cases:
            write({"event": "start", "id": case["id"]})
            write({"event": "result", "id": case["id"], "record": harness.run(case["ops"])})
            if harness.dead:
                write({"event": "dead", "id": case["id"]})
                return 0
        if os.environ.get("FUZZ_SKIP_FREE") != "1":
            harness.free()
        write({"event": "done"})
    return 0


def cross_instance_main(unzipdir, results_path):
    """Two instances in one process: a state of instance B set into instance A (the fuzz's one multi-instance case).
    Also the plain second instantiation that any host running two compressors, or fmpy's simulate_fmu called twice
    in one process, makes."""
    with open(results_path, "a", encoding="utf-8") as out:
        def write(event):
            out.write(json.dumps(event) + "\n")
            out.flush()
        first = Harness(unzipdir, "first")
        write({"event": "instantiated", "which": "first"})
        write({"event": "result", "id": "first", "record": first.run(
            [("set", "lobes", 4), ("setup", 0.0), ("enter",), ("exit",), ("run", 3, 1e-4), ("state_get", "b")])})
        write({"event": "start", "id": "instantiate-second"})
        try:
            second = Harness(unzipdir, "second")    # a second fmi2Instantiate in the same process
        except RuntimeError as error:
            write({"event": "result", "id": "instantiate-second",
                   "record": [{"op": ["instantiate"], "status": FATAL, "detail": str(error), "messages": []}]})
            first.free()
            write({"event": "done"})
            return 0
        write({"event": "result", "id": "instantiate-second",
               "record": [{"op": ["instantiate"], "status": OK, "detail": None, "messages": second.messages}]})
        second.states["from_first"] = first.states["b"]
        second.state_times["from_first"] = first.state_times["b"]
        record = second.run([("setup", 0.0), ("enter",), ("exit",), ("run", 2, 1e-4),
                             ("state_set", "from_first"), ("run", 2, 1e-4), ("get_all",)])
        write({"event": "result", "id": "set-state-from-first", "record": record})
        second.free()
        first.free()
        write({"event": "done"})
    return 0


# =====================================================================================================================
# Parent side: case generation, running the workers, and the tests.
# =====================================================================================================================


def is_numeric(meta):
    """A number parameter (not a choice or a fluid name), as mechanics.parameters.is_numeric says."""
    from rotary_vane.mechanics.parameters import is_numeric as declared_numeric
    return declared_numeric(meta)


def _declarations():
    """The declared parameters that are FMU parameters (the operating point's are the FMU's boundary inputs,
    fmu_src.boundary_inputs)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from rotary_vane.fmu_src.boundary_inputs import BOUNDARY_INPUTS
    from rotary_vane.mechanics.parameters import declarations
    return {name: (default, meta) for name, default, meta in declarations() if name not in BOUNDARY_INPUTS}


def _init_ops(*sets, steps=2, step=SMALL_STEP):
    return [("reset",), ("setup", 0.0), *[("set", n, v) for n, v in sets], ("enter",), ("exit",),
            ("run", steps, step), ("get_all",)]


def _bad_values(meta, rng):
    """Values outside a numeric parameter's declared range (and the non-finite ones)."""
    low, high = meta["min"], meta["max"]
    if meta["integer"]:
        return sorted({low - 1, high + 1, -1, 0, -2 ** 31, 2 ** 31 - 1} - set(range(low, high + 1)))
    values = [math.nan, math.inf, -math.inf, -1e300, 1e300, high * 10 if high else 1.0,
              high + abs(high) * 1e-9 + 1e-300]
    values.append(low - max(abs(low) * 1e-6, 1e-12))
    if low > 0:
        values += [-low, low * 0.5]
    values.append(-rng.uniform(1e-9, 1.0) * max(abs(high), 1e-3))
    return values


def _good_values(meta, rng):
    low, high = meta["min"], meta["max"]
    if meta["integer"]:
        return [low, high]
    return [low, high, low + (high - low) * rng.random()]          # FMI min and max are inclusive


BAD_STRINGS = ["", "unknown", "HARMONIC", " harmonic", "harmonic\n", "%s%s%n%d", "50 %", "é" * 5, "x" * 10000, None]


def parameter_cases(rng):
    """Every numeric parameter with each out-of-range value, every choice parameter with bad strings, the valid
    extremes, a few relations, and seeded random combinations of valid values (which may break a relation)."""
    declared = _declarations()
    cases, expect = [], {}

    def add(case_id, sets, invalid, named=None, steps=2):
        cases.append({"id": case_id, "group": "parameters", "ops": _init_ops(*sets, steps=steps)})
        expect[case_id] = {"invalid": invalid, "named": named}

    for name, (default, meta) in declared.items():
        if meta.get("fluid"):
            for value in BAD_STRINGS:
                add(f"{name}={value!r:.30}", [(name, value)], True if value is not None else "at set",
                    (name, value))
            add(f"{name}='Air'", [(name, "Air")], None)
            continue
        if "choices" in meta:
            for value in BAD_STRINGS:
                add(f"{name}={value!r:.30}", [(name, value)], True if value is not None else "at set",
                    (name, value))
            for value in meta["choices"]:
                add(f"{name}={value!r}", [(name, value)], None)
            continue
        for value in _bad_values(meta, rng):
            add(f"{name}={value!r}", [(name, value)], True, (name, value))
        for value in _good_values(meta, rng):
            add(f"{name}={value!r} (in range)", [(name, value)], None)
    for name, low, high in (("pressure_table_speed", 1.0, 1e5), ("initial_rotor_angle", -1e3, 1e3)):
        for value in (math.nan, math.inf, -math.inf, low - 1.0, high * 2, -1e300):
            add(f"{name}={value!r}", [(name, value)], True, (name, value))
        for value in (low, high):
            add(f"{name}={value!r} (in range)", [(name, value)], None)
    for value in (2, -1, 0, 1):
        add(f"interpolate_speed={value}", [("interpolate_speed", value)], None)
    # relations between parameters (each message must name the parameter it reports)
    add("discharge_pressure < suction_pressure", [("discharge_pressure", 2e5)], True, ("discharge_pressure", 2e5))
    add("discharge_pressure == suction_pressure", [("discharge_pressure", 292800.0)], None)   # a start at rest
    # the boundary inputs' start values at initialization (fmu_src.boundary_inputs)
    for name, value in (("suction_pressure", math.nan), ("suction_pressure", -1.0), ("discharge_pressure", math.inf),
                        ("suction_temperature", -5.0), ("suction_pressure", 5e6)):
        add(f"{name}={value!r}", [(name, value)], True, (name, value))
    add("suction_temperature below the dew point", [("suction_temperature", 250.0)], True,
        ("suction_temperature", 250.0))
    add("suction_state_input='enthalpy' (in range)", [("suction_state_input", "enthalpy")], None)
    add("initial_step > max_step", [("initial_step", 1e-4)], True, ("initial_step", None))
    add("stroke >= base radius", [("stroke", 0.02)], True, ("stroke", 0.02))
    add("slot wider than rotor", [("vane_thickness", 0.02), ("rotor_radius", 0.015)], True, (None, None))
    add("ambrosio with v0 >= v1", [("friction_model", "ambrosio"), ("friction_velocity", 0.1)], True,
        ("friction_velocity_full", None))
    add("harmonic_dwell with no free angle", [("displacement_law", "harmonic_dwell"), ("lobes", 12),
                                              ("bottom_dwell", 0.4), ("top_dwell", 0.4)], True, ("bottom_dwell", 0.4))
    add("vane too short", [("vane_length", 0.002)], True, ("vane_length", 0.002))
    add("slot bottom above vane bottom", [("slot_bottom_radius", 0.02)], True, ("slot_bottom_radius", 0.02))
    add("lobes=1 harmonic_dwell", [("displacement_law", "harmonic_dwell"), ("lobes", 1)], True, ("lobes", 1))
    add("lobes=13 cycloidal", [("displacement_law", "cycloidal"), ("lobes", 13)], True, ("lobes", 13))
    add("negative clearances", [("slot_clearance", -1e-5), ("stator_clearance", -1e-5)], True,
        ("slot_clearance", -1e-5))
    # seeded random combinations of in-range values (they may break a relation)
    numeric = [n for n, (_, m) in declared.items() if is_numeric(m)]
    choice = [n for n, (_, m) in declared.items() if "choices" in m]
    for k in range(40):
        sets = []
        for name in rng.sample(numeric, rng.randint(1, 4)):
            sets.append((name, rng.choice(_good_values(declared[name][1], rng))))
        if rng.random() < 0.5:
            name = rng.choice(choice)
            sets.append((name, rng.choice(declared[name][1]["choices"])))
        add(f"random in-range combination {k}: " + ", ".join(f"{n}={v!r:.12}" for n, v in sets), sets, None)
    return cases, expect


BAD_SPEEDS = [-1.0, -1e-300, -math.inf, math.nan, math.inf, 1e12, 1e300, -0.0, 5e-324, 0.0, 1e5, 1e6]


def input_cases():
    cases, expect = [], {}
    for speed in BAD_SPEEDS:
        case_id = f"shaft_speed={speed!r}"
        ops = _init_ops(steps=2)[:-1] + [("set", "shaft_speed", speed), ("advance", 1e-3), ("get_all",),
                                         ("set", "shaft_speed", 1500.0), ("run", 2, SMALL_STEP), ("get_all",)]
        cases.append({"id": case_id, "group": "inputs", "ops": ops})
        invalid = not (math.isfinite(speed) and speed >= 0.0)
        expect[case_id] = {"invalid": invalid, "named": ("shaft_speed", speed), "recover": invalid,
                           "absurd": speed in (1e12, 1e300), "status": DISCARD}
        # the same bad speed before initialization (the start value of the input)
        case_id = f"shaft_speed={speed!r} before initialization"
        cases.append({"id": case_id, "group": "inputs", "ops": _init_ops(("shaft_speed", speed), steps=1)})
        expect[case_id] = {"invalid": invalid, "named": ("shaft_speed", speed)}
    return cases, expect


STEP_SIZES = [0.0, -1e-3, -math.inf, math.nan, math.inf, 1e-300, 1e-12, 1e-9, 1e-2, 1.0, 10.0]


def step_cases():
    cases, expect = [], {}
    for step in STEP_SIZES:
        case_id = f"step size {step!r}"
        ops = _init_ops(steps=1)[:-1] + [("state_get", "g"), ("advance", step), ("get_all",), ("state_set", "g"),
                                         ("run", 2, SMALL_STEP), ("get_all",)]
        cases.append({"id": case_id, "group": "step sizes", "ops": ops})
        expect[case_id] = {"invalid": not (math.isfinite(step) and step > 0.0), "named": ("step size", step),
                           "recover": True}
    for label, point in (("communication point in the past", 0.0), ("communication point in the future", 5.0),
                         ("communication point nan", math.nan), ("communication point -inf", -math.inf)):
        ops = _init_ops(steps=2)[:-1] + [("state_get", "g"), ("step", point, SMALL_STEP), ("get_all",),
                                         ("state_set", "g"), ("run", 1, SMALL_STEP)]
        cases.append({"id": label, "group": "step sizes", "ops": ops})
        expect[label] = {"invalid": True, "named": ("communication point", None), "recover": True}
    ops = [("reset",), ("setup", 5.0), ("enter",), ("exit",), ("run", 3, SMALL_STEP), ("step", 0.0, SMALL_STEP)]
    cases.append({"id": "start time 5 s, then a step at t = 0", "group": "step sizes", "ops": ops})
    ops = [("reset",), ("setup", math.nan), ("enter",), ("exit",), ("step", 0.0, SMALL_STEP), ("get_all",)]
    cases.append({"id": "start time nan", "group": "step sizes", "ops": ops})
    ops = [("reset",), ("setup", -1e300), ("enter",), ("exit",), ("step", -1e300, SMALL_STEP), ("get_all",)]
    cases.append({"id": "start time -1e300", "group": "step sizes", "ops": ops})
    return cases, expect


def order_cases():
    """Calls out of the FMI state machine's order, and FMU-state misuse on one instance."""
    run = [("enter",), ("exit",), ("run", 2, SMALL_STEP)]
    table = {
        "doStep before initialization": [("reset",), ("advance", SMALL_STEP), ("setup", 0.0), ("advance", SMALL_STEP),
                                         *run],
        "doStep in initialization mode": [("reset",), ("setup", 0.0), ("enter",), ("advance", SMALL_STEP), ("exit",),
                                          ("run", 2, SMALL_STEP)],
        "getReal/Integer/Boolean/String before initialization": [("reset",), ("get_all",), ("setup", 0.0),
                                                                 ("get_all",), ("enter",), ("get_all",), ("exit",)],
        "two exitInitializationMode": [("reset",), ("setup", 0.0), ("enter",), ("exit",), ("exit",),
                                       ("run", 2, SMALL_STEP), ("exit",), ("run", 2, SMALL_STEP)],
        "two enterInitializationMode": [("reset",), ("setup", 0.0), ("enter",), ("enter",), ("exit",),
                                        ("run", 2, SMALL_STEP)],
        "exitInitializationMode without enter": [("reset",), ("setup", 0.0), ("exit",), ("run", 2, SMALL_STEP)],
        "no setupExperiment": [("reset",), ("enter",), ("exit",), ("run", 2, SMALL_STEP), ("get_all",)],
        "reset then run": [("reset",), ("setup", 0.0), *run, ("reset",), ("reset",), ("setup", 0.0), *run,
                           ("get_all",)],
        "reset in the middle of a run": [("reset",), ("setup", 0.0), *run, ("reset",), ("run", 1, SMALL_STEP),
                                         ("setup", 0.0), *run],
        "reset after a bad parameter": [("reset",), ("setup", 0.0), ("set", "lobes", 0), *run, ("reset",),
                                        ("setup", 0.0), *run, ("get_outputs",)],
        "terminate then doStep": [("reset",), ("setup", 0.0), *run, ("terminate",), ("run", 2, SMALL_STEP),
                                  ("get_all",)],
        "terminate twice, then reset and run": [("reset",), ("setup", 0.0), *run, ("terminate",), ("terminate",),
                                                ("reset",), ("setup", 0.0), *run],
        "terminate before initialization": [("reset",), ("terminate",), ("setup", 0.0), *run],
        "set a parameter after initialization": [("reset",), ("setup", 0.0), *run, ("set", "lobes", 0),
                                                 ("set", "stroke", math.nan), ("set", "displacement_law", "bad"),
                                                 ("run", 2, SMALL_STEP), ("get_all",)],
        "getFMUstate before initialization, set after a run": [("reset",), ("state_get", "pre"), ("setup", 0.0),
                                                               *run, ("state_set", "pre"), ("run", 2, SMALL_STEP),
                                                               ("state_free", "pre")],
        "setFMUstate of a running state into a fresh (reset) instance": [
            ("reset",), ("setup", 0.0), *run, ("state_get", "mid"), ("reset",), ("state_set", "mid"),
            ("run", 1, SMALL_STEP), ("setup", 0.0), ("enter",), ("exit",), ("state_set", "mid"),
            ("run", 2, SMALL_STEP), ("state_free", "mid")],
        "setFMUstate of a state taken before fmi2Reset with other parameters (lobes=4)": [
            ("reset",), ("setup", 0.0), ("set", "lobes", 4), *run, ("state_get", "z4"), ("serialize", "z4"),
            ("reset",), ("setup", 0.0), *run, ("state_set", "z4"), ("run", 2, SMALL_STEP), ("get_all",),
            ("deserialize", {"blob": "z4"}, "z4d"), ("state_set", "z4d"), ("run", 2, SMALL_STEP),
            ("state_free", "z4"), ("state_free", "z4d")],
        "setFMUstate of a failed instance into a good one": [
            ("reset",), ("setup", 0.0), ("set", "stroke", -1.0), *run, ("state_get", "bad"), ("reset",),
            ("setup", 0.0), *run, ("state_set", "bad"), ("run", 2, SMALL_STEP), ("state_free", "bad")],
        "setFMUstate with the same state twice, free, get again into the slot": [
            ("reset",), ("setup", 0.0), *run, ("state_get", "s"), ("run", 2, SMALL_STEP), ("state_set", "s"),
            ("state_set", "s"), ("run", 2, SMALL_STEP), ("state_get", "s"), ("state_free", "s")],
        "serialize / deserialize round trip": [
            ("reset",), ("setup", 0.0), *run, ("state_get", "r"), ("serialize", "r"),
            ("deserialize", {"blob": "r"}, "r2"), ("run", 2, SMALL_STEP), ("state_set", "r2"), ("run", 2, SMALL_STEP),
            ("state_free", "r"), ("state_free", "r2")],
    }
    return [{"id": k, "group": "call order", "ops": v} for k, v in table.items()], {}


def contract_cases():
    """Host contract violations: wrong variable types, unknown value references, corrupted state bytes, a string
    that is not UTF-8. FMI 2.0 wants fmi2Error for these; fmi2Fatal kills the instance."""
    init = [("reset",), ("setup", 0.0), ("enter",), ("exit",), ("run", 1, SMALL_STEP)]
    table = {
        "getReal of an unknown value reference (99999)": init + [("get_as", "Real", [99999])],
        "setReal of an unknown value reference (99999)": init + [("set_as", "Real", 99999, 1.0)],
        "getReal of a String variable (displacement_law)": init + [("get_as", "Real", ["displacement_law"])],
        "setReal on an Integer parameter (lobes)": [("reset",), ("setup", 0.0), ("set_as", "Real", "lobes", 2.5)],
        "setInteger on the Real input (shaft_speed)": init + [("set_as", "Integer", "shaft_speed", 1500)],
        "setBoolean on a String parameter (displacement_law)": [("reset",),
                                                                ("set_as", "Boolean", "displacement_law", 1)],
        "getString of a Real output (input_power)": init + [("get_as", "String", ["input_power"])],
        "deserialize garbage bytes": init + [("deserialize", {"hex": "67617262616765"}, "g"), ("state_set", "g")],
        "deserialize a truncated state": init + [("state_get", "t"), ("serialize", "t"),
                                                 ("deserialize", {"blob": "t", "truncate": 40}, "t2"),
                                                 ("state_set", "t2"), ("state_free", "t")],
        "setString with bytes that are not UTF-8": [("reset",), ("setup", 0.0),
                                                    ("set_as", "String", "displacement_law", {"bytes_hex": "fffe80"}),
                                                    ("enter",), ("exit",), ("run", 1, SMALL_STEP)],
    }
    return [{"id": k, "group": "contract", "ops": v} for k, v in table.items()], {}


def random_sequence_cases(rng, count=60, length=30):
    declared = _declarations()
    numeric = [n for n, (_, m) in declared.items() if is_numeric(m)]
    speeds = [1500.0, 1500.0, 0.0, 3000.0, 1e4, -5.0, math.nan, math.inf, 1e12]
    steps = [SMALL_STEP, SMALL_STEP, 1e-3, 0.0, -1e-4, 1e-9, math.nan, 2e-2]
    menu = [
        (12, lambda: ("advance", rng.choice(steps))),
        (8, lambda: ("set", "shaft_speed", rng.choice(speeds))),
        (5, lambda: ("get_all",)),
        (3, lambda: ("step", rng.choice([0.0, 1.0, -1.0, math.nan]), SMALL_STEP)),
        (3, lambda: ("state_get", rng.choice("ab"))),
        (3, lambda: ("state_set", rng.choice("ab"))),
        (2, lambda: ("state_free", rng.choice("ab"))),
        (2, lambda: ("serialize", rng.choice("ab"))),
        (2, lambda: ("deserialize", {"blob": rng.choice("ab")}, rng.choice("ab"))),
        (2, lambda: ("reset",)),
        (2, lambda: ("setup", rng.choice([0.0, 0.0, 1.0]))),
        (3, lambda: ("enter",)),
        (3, lambda: ("exit",)),
        (1, lambda: ("terminate",)),
        (3, lambda: ("set", (n := rng.choice(numeric)),
                     rng.choice(_good_values(declared[n][1], rng) + _bad_values(declared[n][1], rng)))),
        (1, lambda: ("set", rng.choice(["displacement_law", "integrator", "friction_model"]),
                     rng.choice(BAD_STRINGS[:6] + ["harmonic", "abm4", "ambrosio"]))),
    ]
    weights = [w for w, _ in menu]
    cases = []
    for k in range(count):
        ops = [("reset",), ("setup", 0.0), ("enter",), ("exit",)]
        for _ in range(length):
            ops.append(rng.choices(menu, weights)[0][1]())
        ops += [("state_free", "a"), ("state_free", "b")]
        cases.append({"id": f"random sequence {k}", "group": "random sequences", "ops": ops})
    return cases, {}


def _schema_leaves(spec, path=()):
    """(path, spec) of every field of a state schema (fmu_src/state_schema.py), records descended into."""
    from rotary_vane.fmu_src import state_schema
    inner = spec.spec if isinstance(spec, state_schema.Nullable) else spec
    if isinstance(inner, state_schema.Record):
        for name, item in inner.fields.items():
            yield from _schema_leaves(item, (*path, name))
    if path:
        yield path, spec


CRAFTED_PER_CASE = 8        # crafted blobs tried one after the other on one initialized instance


def crafted_state_edits() -> dict:
    """label -> edit (craft_blob) of a state serialized after 2 steps of the detailed model: a malformed node
    ({"f": []}) and a value of the wrong type in every field of the state tree (the compressor's schema,
    fmu_src/compressor.py; the periodic-map run's fields are absent from a detailed state), and the contents of
    issue 22: an inconsistent clock, NaN / zero / 5e-324 integrator step sizes, a NaN start time,
    initial_rotor_angle = 1e300, fidelity "bogus", 5 and null, NaN in the window and last-output arrays, a map_values
    of 1e6 entries."""
    from rotary_vane.fmu_src import state_schema
    from rotary_vane.fmu_src.compressor import CompressorSlave
    from rotary_vane.fmu_src.slave import CLOCK_SCHEMA
    tree = state_schema.Record({"phase": state_schema.Text(), "clock": CLOCK_SCHEMA,
                                "failure": state_schema.Nullable(state_schema.Text()),
                                "model": CompressorSlave.model_schema()})
    edits = {}
    for path, spec in _schema_leaves(tree):
        if path[:2] == ("model", "map_run") and len(path) > 2:
            continue
        inner = spec.spec if isinstance(spec, state_schema.Nullable) else spec
        label = ".".join(path)
        edits[f"{label} = {{'f': []}}"] = ["set", list(path), {"f": []}]
        edits[f"{label} of another type"] = ["set", list(path), 5 if isinstance(inner, state_schema.Text) else "x"]
    clock, control = ["clock"], ["model", "simulation", "control"]
    edits.update({
        "clock elapsed [1e6, 1] (the model stays at its time)": ["set", [*clock, "elapsed"], [1000000, 1]],
        "clock start_time nan": ["set", [*clock, "start_time"], {"f": "nan"}],
        "clock stop_time before the start time": ["set", [*clock, "stop_time"], -1.0],
        "initial_rotor_angle = 1e300": ["set", ["model", "parameters", "initial_rotor_angle"], 1e300],
        "fidelity 'bogus'": ["set", ["model", "parameters", "fidelity"], "bogus"],
        "fidelity 5": ["set", ["model", "parameters", "fidelity"], 5],
        "fidelity null": ["set", ["model", "parameters", "fidelity"], None],
        "lobes = 1000000 (sizes follow the parameters)": ["set", ["model", "parameters", "lobes"], 1000000],
        "NaN in the window": ["nan", ["model", "simulation", "window"], -1],
        "NaN in the window's start row": ["nan", ["model", "simulation", "window"], 3],
        "NaN in the last output row": ["nan", ["model", "simulation", "last_output"], 0],
        "NaN in the state vector": ["nan", ["model", "simulation", "state"], 0],
        "map_values of 1e6 entries": ["entries", ["model", "map_values"], 1000000],
        "simulation time 1e6 s (not the clock's)": ["set", ["model", "simulation", "time"], 1e6],
        "integrator step size nan": ["nan", control, 0],
        **{f"integrator step size {value!r}": ["step", control, value] for value in (0.0, 5e-324, -1e-3, 1.0)},
    })
    return edits


def crafted_state_cases():
    """The crafted state blobs (crafted_state_edits), CRAFTED_PER_CASE per case: each set into a running instance by
    fmi2DeSerializeFMUstate, its serialized state compared with the one before, and fmi2SetFMUstate of the saved
    state to leave the error state; then two steps. Expected for each: fmi2Error, the state byte for byte as
    before, and the steps after it fmi2OK."""
    edits = list(crafted_state_edits().items())
    cases = []
    for first in range(0, len(edits), CRAFTED_PER_CASE):
        batch = edits[first:first + CRAFTED_PER_CASE]
        ops = [("reset",), ("setup", 0.0), ("set", "pressure_model", "ideal_gas_table"), ("enter",), ("exit",),
               ("run", 2, SMALL_STEP), ("state_get", "g"), ("serialize", "g")]
        for label, edit in batch:
            ops += [("craft", "g", edit, "bad"), ("deserialize", {"blob": "bad"}, "x"), ("state_get", "after"),
                    ("serialize", "after"), ("same_blobs", "g", "after"), ("state_set", "g")]
        ops += [("run", 2, SMALL_STEP), ("get_outputs",), ("state_free", "g"), ("state_free", "after")]
        cases.append({"id": f"crafted states: {'; '.join(label for label, _ in batch)}", "group": "crafted states",
                      "ops": ops})
    return cases, {}


def all_cases():
    rng = random.Random(SEED)
    cases, expect = [], {}
    for make in (lambda: parameter_cases(rng), input_cases, step_cases, order_cases, contract_cases,
                 lambda: random_sequence_cases(rng), crafted_state_cases):
        more, more_expect = make()
        cases += more
        expect.update(more_expect)
    ids = [c["id"] for c in cases]
    assert len(ids) == len(set(ids)), "case ids must be unique"
    return cases, expect


# ---------------------------------------------------------------------------------------------------------------------
def _worker_env():
    env = dict(os.environ)
    env["PYTHONFAULTHANDLER"] = "1"
    return env


def run_lane(cases, unzipdir, workdir: Path, lane: int):
    """Run `cases` in worker processes, replacing a worker that crashed or whose instance went fatal."""
    results, processes = {}, []
    remaining = list(cases)
    attempt = 0
    while remaining:
        attempt += 1
        tag = f"lane{lane}-{attempt}"
        cases_file, results_file = workdir / f"{tag}.json", workdir / f"{tag}.jsonl"
        cases_file.write_text(json.dumps(remaining))
        stderr_file = workdir / f"{tag}.stderr"
        started = time.monotonic()
        with open(stderr_file, "wb") as stderr:
            process = subprocess.Popen([sys.executable, __file__, "worker", str(unzipdir), str(cases_file),
                                        str(results_file), f"fuzz{lane}"], stdout=stderr, stderr=stderr,
                                       env=_worker_env(), cwd=workdir)
            current, since, timed_out = None, time.monotonic(), False
            while process.poll() is None:
                time.sleep(0.05)
                events = _read_events(results_file)
                running = _running_case(events)
                if running != current:
                    current, since = running, time.monotonic()
                if current is not None and time.monotonic() - since > CASE_TIMEOUT:
                    process.kill()
                    timed_out = True
            process.wait()
        events = _read_events(results_file)
        info = {"tag": tag, "returncode": process.returncode, "seconds": time.monotonic() - started,
                "stderr_tail": stderr_file.read_bytes()[-3000:].decode("utf-8", "replace"),
                "done": any(e["event"] == "done" for e in events)}
        processes.append(info)
        finished = {e["id"]: e["record"] for e in events if e["event"] == "result"}
        for case_id, record in finished.items():
            results[case_id] = {"record": record, "process": tag}
        index = {c["id"]: i for i, c in enumerate(remaining)}
        running = _running_case(events)
        if running is not None:                 # the process died (or hung) inside this case
            results[running] = {"record": None, "process": tag,
                                "crash": "timeout" if timed_out else _describe_exit(process.returncode)}
            remaining = remaining[index[running] + 1:]
        elif any(e["event"] == "dead" for e in events):
            last = [e["id"] for e in events if e["event"] == "dead"][-1]
            remaining = remaining[index[last] + 1:]
        elif not any(e["event"] == "instantiated" for e in events):
            for case in remaining:
                results[case["id"]] = {"record": None, "process": tag,
                                       "crash": "worker failed to instantiate: " + _describe_exit(process.returncode)}
            remaining = []
        else:
            remaining = []
    return results, processes


def _read_events(path: Path):
    if not path.exists():
        return []
    events = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            events.append(json.loads(line))
        except json.JSONDecodeError:            # a line cut by a crash
            pass
    return events


def _running_case(events):
    started = [e["id"] for e in events if e["event"] == "start"]
    finished = {e["id"] for e in events if e["event"] == "result"}
    return started[-1] if started and started[-1] not in finished else None


def _describe_exit(returncode):
    if returncode is None:
        return "still running"
    if returncode < 0:
        import signal
        return f"killed by signal {signal.Signals(-returncode).name}"
    return f"exit status {returncode}"


def run_fuzz(unzipdir: Path, workdir: Path, cases):
    lanes = [cases[i::LANES] for i in range(LANES)]
    outputs = [None] * LANES

    def target(i):
        outputs[i] = run_lane(lanes[i], unzipdir, workdir, i)

    threads = [threading.Thread(target=target, args=(i,)) for i in range(LANES)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    results, processes = {}, []
    for lane_results, lane_processes in outputs:
        results.update(lane_results)
        processes += lane_processes
    return results, processes


# ---------------------------------------------------------------------------------------------------------------------
def statuses(result):
    """All numeric statuses of a case's calls."""
    return [op["status"] for op in result["record"] or [] if isinstance(op["status"], int)]


def summary(result):
    if result.get("crash"):
        return "CRASH (" + result["crash"] + ")"
    parts = []
    for op in result["record"]:
        status = op["status"]
        name = op["op"][0]
        label = STATUS_NAMES[status] if isinstance(status, int) else str(status)
        if status != OK:
            parts.append(f"{name}:{label}")
    return "all OK" if not parts else " ".join(parts)


def messages(result):
    return [m for op in result["record"] or [] for m in op["messages"]]


def _value_texts(value):
    """How the FMU's message may write a value (Python repr, or the float repr of an int)."""
    if value is None:
        return ["None"]
    if isinstance(value, float) and math.isnan(value):
        return ["nan"]
    if isinstance(value, str):
        return [repr(value)[:60]]
    texts = [repr(value)]
    if isinstance(value, int):
        texts.append(repr(float(value)))
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e16:
        texts.append(repr(int(value)))
    return texts


def table(cases, results):
    lines = [f"{'group':16s} | {'case':60s} | statuses (non-OK calls)"]
    for case in cases:
        result = results.get(case["id"])
        text = "NOT RUN" if result is None else summary(result)
        lines.append(f"{case['group']:16s} | {case['id'][:60]:60s} | {text}")
    return "\n".join(lines)


# =====================================================================================================================
# pytest part
# =====================================================================================================================
PROJECT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def fuzz_fmu(built_fmus, tmp_path_factory):
    """The compressor FMU built once per session, unzipped."""
    fmu = built_fmus / f"{MODEL}.fmu"
    import zipfile
    unzipdir = tmp_path_factory.mktemp("fuzz_fmu") / "unzipped"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unzipdir)
    return fmu, unzipdir


# The default test run takes every SAMPLE_EVERY[group]-th case of the large groups (the other groups whole); the slow
# run takes every case. Both check the same contract.
SAMPLE_EVERY = {"parameters": 8, "random sequences": 3}


def sampled(cases):
    """Every SAMPLE_EVERY-th case of each large group, in order (deterministic: the cases are drawn with a seed)."""
    seen = Counter()
    kept = []
    for case in cases:
        group = case["group"]
        if seen[group] % SAMPLE_EVERY.get(group, 1) == 0:
            kept.append(case)
        seen[group] += 1
    return kept


@pytest.fixture(scope="module", params=["sample", pytest.param("every case", marks=pytest.mark.slow)])
def fuzz(fuzz_fmu, tmp_path_factory, request):
    """Run the cases once (in parallel worker processes): a sample in the default run, every case in the slow run;
    the tests below check their groups."""
    cases, expect = all_cases()
    if request.param == "sample":
        cases = sampled(cases)
    workdir = tmp_path_factory.mktemp("fuzz_work")
    started = time.monotonic()
    results, processes = run_fuzz(fuzz_fmu[1], workdir, cases)
    seconds = time.monotonic() - started
    (workdir / "table.txt").write_text(table(cases, results))
    print(f"\nfuzz: {len(cases)} cases in {len(processes)} worker processes, {seconds:.1f} s; "
          f"table in {workdir / 'table.txt'}")
    return cases, expect, results, processes, workdir


def _group(fuzz, group):
    cases, expect, results, processes, workdir = fuzz
    return [(c, expect.get(c["id"], {}), results.get(c["id"])) for c in cases if c["group"] == group]


def _assert_no_fatal_or_crash(rows):
    problems = []
    for case, _, result in rows:
        if result is None:
            problems.append(f"{case['id']}: NOT RUN")
        elif result.get("crash"):
            problems.append(f"{case['id']}: {result['crash']} (process {result['process']})")
        elif FATAL in statuses(result) or "harness-error" in [op["status"] for op in result["record"]]:
            fatal = [op for op in result["record"] if op["status"] in (FATAL, "harness-error")][0]
            problems.append(f"{case['id']}: {fatal['op'][0]} returned {fatal['status']}: "
                            f"{[m[1][:300] for m in fatal['messages']]} {fatal['detail'] or ''}")
    assert not problems, "fmi2Fatal or crash:\n" + "\n".join(problems)


def _assert_refusals_named(rows):
    """A refused bad value: the step that meets it returns fmi2Error (a bad parameter, step size or communication
    point: misuse) or fmi2Discard (a bad input value: the master may retry with another), and a message names the
    variable and value."""
    problems = []
    for case, expected, result in rows:
        if not expected.get("invalid") or result is None or result.get("crash"):
            continue
        if expected["invalid"] == "at set":           # a null string pointer: the set call itself is refused
            sets = [op for op in result["record"] if op["op"][0] == "set"]
            if not sets or sets[0]["status"] != ERROR:
                problems.append(f"{case['id']}: the set call returned {sets[0]['status'] if sets else 'nothing'}, "
                                f"expected ERROR")
            continue
        # the step that meets the bad value: a single probe step if the case has one, else the first run
        steps = ([op for op in result["record"] if op["op"][0] in ("advance", "step")]
                 or [op for op in result["record"] if op["op"][0] == "run"])
        status = expected.get("status", ERROR)
        if not steps or steps[0]["status"] != status:
            problems.append(f"{case['id']}: first step returned "
                            f"{steps[0]['status'] if steps else 'no step'}, expected {STATUS_NAMES[status]}")
        name, value = expected["named"]
        text = "\n".join(m[1] for m in messages(result) if m[0] >= WARNING)
        if name is not None and name not in text:
            problems.append(f"{case['id']}: no error message names {name!r}: {text[:300]!r}")
        if value is not None and not any(t in text for t in _value_texts(value)):
            problems.append(f"{case['id']}: no error message gives the value {_value_texts(value)}: "
                            f"{text[:300]!r}")
    assert not problems, "\n".join(problems)


def test_bad_parameters(fuzz):
    rows = _group(fuzz, "parameters")
    _assert_no_fatal_or_crash(rows)
    _assert_refusals_named(rows)


def test_bad_inputs(fuzz):
    rows = _group(fuzz, "inputs")
    _assert_no_fatal_or_crash(rows)
    _assert_refusals_named(rows)


def test_bad_step_sizes_and_communication_points(fuzz):
    rows = _group(fuzz, "step sizes")
    _assert_no_fatal_or_crash(rows)
    _assert_refusals_named(rows)


def test_odd_call_orders_and_state_misuse(fuzz):
    _assert_no_fatal_or_crash(_group(fuzz, "call order"))


def test_random_call_sequences(fuzz):
    _assert_no_fatal_or_crash(_group(fuzz, "random sequences"))


def test_crafted_state_contents_are_refused_and_the_state_is_kept(fuzz):
    """Every crafted state blob (crafted_state_cases): fmi2DeSerializeFMUstate returns fmi2Error, no call returns
    fmi2Fatal, no process crashes or hangs; the model state after each refusal is byte for byte the one before it;
    after fmi2SetFMUstate of the saved state the next steps are fmi2OK, with the same outputs in every case (as
    without the bad calls: each case steps the same saved state)."""
    rows = _group(fuzz, "crafted states")
    _assert_no_fatal_or_crash(rows)
    problems, outputs, refused = [], {}, 0
    for case, _, result in rows:
        record = result["record"]
        refusals = [op["status"] for op in record if op["op"][0] == "deserialize"]
        kept = [op["detail"]["same"] for op in record if op["op"][0] == "same_blobs"]
        runs = [op["status"] for op in record if op["op"][0] == "run"]
        if set(refusals) != {ERROR} or not all(kept) or len(kept) != len(refusals) or runs != [OK, OK]:
            problems.append(f"{case['id']}: deserialize {refusals}, state kept {kept}, runs {runs}")
        refused += refusals.count(ERROR)
        final = [op["detail"] for op in record if op["op"][0] == "get_outputs"][-1]
        outputs.setdefault(json.dumps(final, sort_keys=True), []).append(case["id"])
    assert not problems, "\n".join(problems)
    assert refused == len(crafted_state_edits())
    assert len(outputs) == 1, f"the steps after the rollback differ between cases: {list(outputs.values())[:3]}"
    print(f"\ncrafted states: {refused} blobs in {len(rows)} cases, each fmi2Error with the state kept")


NON_UTF8 = "setString with bytes that are not UTF-8"


def test_host_contract_violations(fuzz):
    _assert_no_fatal_or_crash([row for row in _group(fuzz, "contract") if row[0]["id"] != NON_UTF8])


def test_non_utf8_string_is_not_fatal(fuzz):
    """pythonfmu's C++ SetString would fail as fmi2Fatal on bytes that are not UTF-8; the status shim
    (fmu_src/c/fmi2_status_shim.c) refuses them with fmi2Error first."""
    _assert_no_fatal_or_crash([row for row in _group(fuzz, "contract") if row[0]["id"] == NON_UTF8])


def test_the_instance_recovers_after_a_refused_step(fuzz):
    """A bad input refuses that step only (fmi2Discard); a bad step size or communication point is fmi2Error, and
    after fmi2SetFMUstate of the state before it the valid steps are OK."""
    problems = []
    for group in ("inputs", "step sizes"):
        for case, expected, result in _group(fuzz, group):
            if not expected.get("recover") or result is None or result.get("crash"):
                continue
            last = [op for op in result["record"] if op["op"][0] == "run"][-1]
            if last["status"] != OK:
                problems.append(f"{case['id']}: the valid steps after it returned "
                                f"{STATUS_NAMES[last['status']]}: {[m[1][:200] for m in last['messages']]}")
    assert not problems, "\n".join(problems)


def test_absurd_speeds_are_refused_naming_the_input(fuzz):
    """1e12 and 1e300 rpm pass the input check (finite, >= 0); the step then fails in the integrator. The
    message must still name the input and its value."""
    problems = []
    for case, expected, result in _group(fuzz, "inputs"):
        if not expected.get("absurd"):
            continue
        step = [op for op in result["record"] if op["op"][0] == "advance"][0]
        text = "\n".join(m[1] for m in step["messages"])
        if step["status"] == OK:
            continue
        if "shaft_speed" not in text or not any(t in text for t in _value_texts(expected["named"][1])):
            problems.append(f"{case['id']}: {STATUS_NAMES[step['status']]} with {text[:200]!r}")
    assert not problems, "\n".join(problems)


def test_no_worker_process_crashed(fuzz):
    """Every worker that ran its cases to the end (fmi2FreeInstance, unloading, exit) exited with status 0."""
    cases, expect, results, processes, workdir = fuzz
    bad = [p for p in processes if p["done"] and p["returncode"] != 0]
    assert not bad, "\n".join(f"{p['tag']}: {_describe_exit(p['returncode'])} after its last case\n"
                              f"{p['stderr_tail'][-800:]}" for p in bad)


def test_state_from_another_instance_in_the_same_process(fuzz_fmu, tmp_path):
    """Two instances in one process; a state of the first set into the second. This needs a second
    fmi2Instantiate in the process (as any host running two compressors, or two fmpy.simulate_fmu calls)."""
    results_file = tmp_path / "cross.jsonl"
    process = subprocess.run([sys.executable, __file__, "cross", str(fuzz_fmu[1]), str(results_file)],
                             capture_output=True, timeout=300, cwd=tmp_path)
    events = _read_events(results_file)
    tail = (process.stdout + process.stderr)[-1500:].decode("utf-8", "replace")
    assert process.returncode == 0, (
        f"the process {_describe_exit(process.returncode)}; last event: {events[-1] if events else None}\n{tail}")
    for event in events:
        if event["event"] == "result":
            fatal = [op for op in event["record"] if op["status"] == FATAL]
            assert not fatal, f"{event['id']}: fmi2Fatal: {fatal[0]['detail'] or fatal[0]['messages']}"


# =====================================================================================================================
def main(argv):
    if argv[0] == "worker":
        return worker_main(*argv[1:])
    if argv[0] == "cross":
        return cross_instance_main(*argv[1:])
    if argv[0] == "report":                          # python tests/fmu/test_fmu_fuzz.py report --fmu X.fmu
        import argparse
        import zipfile
        parser = argparse.ArgumentParser()
        parser.add_argument("--fmu", type=Path, required=True)
        parser.add_argument("--json", type=Path)
        args = parser.parse_args(argv[1:])
        workdir = Path(tempfile.mkdtemp(prefix="fmu_fuzz_"))
        with zipfile.ZipFile(args.fmu) as archive:
            archive.extractall(workdir / "unzipped")
        cases, _ = all_cases()
        started = time.monotonic()
        results, processes = run_fuzz(workdir / "unzipped", workdir, cases)
        print(table(cases, results))
        print(f"\n{len(cases)} cases, {len(processes)} processes, {time.monotonic() - started:.1f} s")
        for p in processes:
            print(p["tag"], _describe_exit(p["returncode"]), "done" if p["done"] else "", f"{p['seconds']:.1f} s")
        if args.json:
            args.json.write_text(json.dumps({"cases": cases, "results": results, "processes": processes}))
        return 0
    raise SystemExit(f"unknown command {argv[0]!r}")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
