"""Shared FMI glue for the project's slaves (the Reference-FMUs way: one model a file, shared glue here).

Statuses. pythonfmu 0.7.0 turns any Python exception into fmi2Fatal (and drops the instance) and otherwise returns
fmi2OK, or fmi2Discard when `do_step` returns False. The FMU's binary is therefore a shim in front of pythonfmu's
(fmu_src/c/fmi2_status_shim.c) that returns, for each call, the worst status logged during it, and keeps the FMI
error state. So the slaves never let an exception escape; they log every refusal with the status the FMI 2.0
standard prescribes (the README's contract table lists them):

* fmi2Error for misuse: a call the current state does not allow (the message names the state), a bad parameter,
  a write to an output, to a fixed parameter after initialization or of the wrong type, an unknown value
  reference, a step size that is not finite and > 0, a communication point that does not continue the model time,
  a step past the stopTime of fmi2SetupExperiment, state bytes whose content is not a state this slave saves
  (checked in full against its schema, fmu_src/state_schema.py, before any of it is used); the shim then holds the
  instance in the error state until fmi2SetFMUstate or fmi2Reset;
* fmi2Discard for a step that was not taken and may be retried: an input value out of range, a step the
  integrator could not complete or that exceeded its work bound; the model is then exactly as before the call
  (`do_step` restores a snapshot);
* fmi2Warning for a value that is returned but has no defined value (NaN), with the reason.

The states of FMI 2.0 co-simulation this glue keeps: instantiated, initialization mode, initialized (FMI's
stepComplete; a discarded step leaves the instance there, at the communication point before the step),
terminated; the error state is the shim's. The model time is an exact sum of the step sizes (`Clock`), so start
times up to 1e9 s and any number of steps continue. The glue also completes the modelDescription (units,
InitialUnknowns, output dependencies) and saves the model state for fmi2GetFMUstate / fmi2SerializeFMUstate in a
data-only format (`state_format`).
"""
from __future__ import annotations

import functools
import math
import re
import sys
import weakref
from fractions import Fraction
from xml.etree.ElementTree import SubElement

from pythonfmu import Fmi2Slave as PythonFmuSlave
from pythonfmu.enums import Fmi2Causality, Fmi2Status, Fmi2Variability
from pythonfmu.variables import Boolean, Integer, Real, String

from . import state_format
from . import state_schema as schema
from .exit_guard import release_at_exit
from .variables import RealVariable, unit_definitions

AUTHOR = "Rotary vane compressor simulator team"
LICENSE = "MIT"
VERSION = "0.1.0"

INSTANTIATED, INITIALIZATION_MODE, INITIALIZED, TERMINATED = ("instantiated", "initialization mode", "initialized",
                                                              "terminated")
PHASES = (INSTANTIATED, INITIALIZATION_MODE, INITIALIZED, TERMINATED)
CONTINUITY_ULPS = 16          # a communication point continues if within 16 ulp of the previous point + step size
STOP_SLACK = 1e-6             # a step may end past stopTime by this fraction of its size (a master's rounding)


class StepFailed(Exception):
    """Raised by a slave's `advance` when the step could not be completed (numerical failure): the glue restores
    the state from before the step and answers fmi2Discard, so the master may retry."""


class SavedState:
    """What fmi2GetFMUstate hands out: a tree of plain data (the slave's snapshot), and its bytes once serialized
    (pythonfmu asks for them twice: size, then bytes)."""

    __slots__ = ("tree", "blob")

    def __init__(self, tree, blob: bytes | None = None):
        self.tree = tree
        self.blob = blob


class RefusedState:
    """What fmi2DeSerializeFMUstate made of bytes that are not a state of this FMU (the shim refuses it at once:
    its serialized size is 0; fmi2SetFMUstate of it is fmi2Error and logs the reason to the instance's logger)."""

    __slots__ = ("reason",)

    def __init__(self, reason: str):
        self.reason = reason


class Clock:
    """The model's time: the exact sum of the step sizes since the start (a Fraction of the binary doubles, so 1e7
    steps do not drift), and the communication point the master's next step must start at (its last point plus
    its step size, compared within a few ulp of the magnitudes involved: at a start time of 1e9 s a master's own
    clock is resolved to 1.2e-7 s)."""

    def __init__(self, start_time: float, stop_time: float | None = None):
        self.start_time = float(start_time)
        self.stop_time = stop_time            # fmi2SetupExperiment's stopTime, if defined
        self.elapsed = Fraction(0)
        self.next_point = self.start_time

    def discontinuity(self, point: float) -> str | None:
        """Why the communication point `point` does not continue the model time, or None."""
        scale = max(abs(point), abs(self.next_point), abs(self.start_time)) if math.isfinite(point) else 0.0
        if math.isfinite(point) and abs(point - self.next_point) <= CONTINUITY_ULPS * math.ulp(scale):
            return None
        return (f"communication point t = {point!r} s does not continue the model time: allowed "
                f"t = {self.next_point!r} s (the previous communication point plus its step size)")

    def end_of(self, step_size: float) -> Fraction:
        return self.elapsed + Fraction(step_size)

    def past_stop(self, point: float, step_size: float) -> str | None:
        """Why a step of `step_size` from `point` would end past the stop time, or None. A master's own clock may
        have drifted by its roundings (t += h): an end within 16 ulp or a millionth of the step past the stop time
        is taken as the stop time."""
        end = point + step_size
        slack = max(CONTINUITY_ULPS * math.ulp(max(abs(end), abs(self.stop_time or 0.0))), STOP_SLACK * step_size)
        if self.stop_time is None or end - self.stop_time <= slack:
            return None
        return (f"fmi2DoStep from t = {point!r} s of {step_size!r} s would end at t = {end!r} s, past the stopTime "
                f"= {self.stop_time!r} s given to fmi2SetupExperiment; nothing was done (FMI 2.0: a step beyond the "
                f"stop time is an error)")

    def commit(self, point: float, step_size: float, elapsed: Fraction) -> None:
        self.elapsed = elapsed
        self.next_point = point + step_size

    def get_state(self) -> dict:
        return dict(start_time=self.start_time, stop_time=self.stop_time,
                    elapsed=[self.elapsed.numerator, self.elapsed.denominator], next_point=self.next_point)

    @classmethod
    def from_state(cls, state: dict) -> "Clock":
        clock = cls(float(state["start_time"]), state["stop_time"])
        numerator, denominator = state["elapsed"]
        clock.elapsed = Fraction(int(numerator), int(denominator))
        clock.next_point = float(state["next_point"])
        return clock


# a saved clock (Clock.get_state): the elapsed time is a sum of doubles, a fraction with a power of two (at most
# 2**1074) as denominator; its numerator is below 2**2200 for any sum of fewer than 2**100 finite doubles
CLOCK_SCHEMA = schema.Record({"start_time": schema.Real(), "stop_time": schema.Nullable(schema.Real()),
                              "elapsed": schema.Sequence(schema.Integer(0, 2 ** 2200), 2), "next_point": schema.Real()})


def check_clock(clock: dict, model_time: float | None) -> None:
    """The saved clock against the model time of the saved model (None: no model built yet)."""
    numerator, denominator = clock["elapsed"]
    if denominator <= 0 or denominator & (denominator - 1) or denominator.bit_length() > 1075:
        raise ValueError(f"state field 'clock.elapsed' has the denominator {str(denominator)[:40]}: allowed a power "
                         f"of two up to 2**1074 (a sum of step sizes)")
    elapsed = Fraction(numerator, denominator)
    if clock["stop_time"] is not None and clock["stop_time"] < clock["start_time"]:
        raise ValueError(f"the state is inconsistent: its stop time {clock['stop_time']!r} s is before its start "
                         f"time {clock['start_time']!r} s")
    if model_time is None and (elapsed != 0 or clock["next_point"] != clock["start_time"]):
        raise ValueError(f"the state is inconsistent: no model is built, yet the clock has run (elapsed "
                         f"{float(elapsed)!r} s, next communication point {clock['next_point']!r} s, start time "
                         f"{clock['start_time']!r} s)")
    if model_time is not None and float(elapsed) != model_time:
        raise ValueError(f"the state is inconsistent: the clock's elapsed time {float(elapsed)!r} s is not the "
                         f"model's time {model_time!r} s")


def guarded(method):
    """Run an FMI callback so that no exception reaches pythonfmu (which would make it fmi2Fatal): report it as
    fmi2Error and refuse (return False)."""
    @functools.wraps(method)
    def call(self, *args):
        try:
            return method(self, *args)
        except Exception as error:          # noqa: BLE001 - the host must never see a Python exception
            self.report(f"{method.__name__}: {type(error).__name__}: {str(error)[:400]}")
            return False
    return call


TYPE_NAMES = {Real: "Real", Integer: "Integer", Boolean: "Boolean", String: "String"}


class GuardedSlave(PythonFmuSlave):
    """Base of the project's slaves; subclasses implement `initialize`, `input_error`, `advance`, `snapshot` and
    `restore`."""

    author = AUTHOR
    license = LICENSE
    version = VERSION

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.phase = INSTANTIATED
        self.clock = Clock(0.0)
        self.failure: str | None = None      # set when a failed step could not even be rolled back
        release_at_exit(self.resources, self.modelName)
        drop_repeated_path_entries()

    @property
    def start_time(self) -> float:
        return self.clock.start_time

    def register_variable(self, var, nested: bool = False):
        """pythonfmu's registration, with default accessors that hold the instance weakly (`owner`): pythonfmu's
        own capture the instance, a reference cycle that keeps every freed instance and its arrays in memory
        until the next full garbage collection (tens of MB over a few hundred instantiate/free cycles)."""
        if var.getter is None:
            var.getter = functools.partial(getattr, self.owner, var.local_name)
        if var.setter is None and hasattr(self, var.local_name) and var.variability != Fmi2Variability.constant:
            var.setter = functools.partial(setattr, self.owner, var.local_name)
        super().register_variable(var, nested=False)

    @property
    def owner(self):
        """A weak reference to this instance, for accessors stored on the instance (no reference cycle)."""
        return weakref.proxy(self)

    # reporting --------------------------------------------------------------------------------------------
    def report(self, message: str, status: Fmi2Status = Fmi2Status.error) -> None:
        """Log to the importer (with % escaped: the message is a printf format there) and to stderr."""
        self.log(message.replace("%", "%%"), status)
        print(f"[{type(self).__name__} {self.instance_name}] {status.name}: {message}", file=sys.stderr,
              flush=True)

    def refuse(self, message: str, status: Fmi2Status = Fmi2Status.error) -> bool:
        """Refuse this call: report `message` with `status` (fmi2Error, or fmi2Discard for a step that may be
        retried) and leave the model as it was."""
        self.report(message, status)
        return False

    def wrong_state(self, function: str, allowed: tuple[str, ...]) -> str | None:
        """The refusal of `function` if the current state is not one of `allowed`, else None."""
        if self.phase in allowed:
            return None
        return (f"{function} is not allowed in the {self.phase} state (allowed in: {', '.join(allowed)}); "
                f"nothing was done")

    # FMI callbacks ----------------------------------------------------------------------------------------
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        refusal = self.wrong_state("fmi2SetupExperiment", (INSTANTIATED,))
        if refusal is not None:
            return self.report(refusal)
        if not math.isfinite(start_time):
            return self.report(f"fmi2SetupExperiment: startTime = {start_time!r} s is invalid: allowed a finite "
                               f"time")
        if stop_time is not None and not (math.isfinite(stop_time) and stop_time >= start_time):
            return self.report(f"fmi2SetupExperiment: stopTime = {stop_time!r} s is invalid: allowed a finite time "
                               f">= startTime = {start_time!r} s")
        self.clock = Clock(start_time, stop_time)

    def enter_initialization_mode(self):
        refusal = self.wrong_state("fmi2EnterInitializationMode", (INSTANTIATED,))
        if refusal is not None:
            return self.report(refusal)
        self.phase = INITIALIZATION_MODE

    @guarded
    def exit_initialization_mode(self):
        refusal = self.wrong_state("fmi2ExitInitializationMode", (INITIALIZATION_MODE,))
        if refusal is not None:
            return self.report(refusal)
        before = self.snapshot()
        try:
            self.initialize()
        except Exception as error:        # noqa: BLE001 - refused: the instance stays as it was (the shim: error state)
            self._roll_back(before)
            return self.report(f"initialization refused: {blame_changed(str(error), self.changed_parameters())}"
                               if isinstance(error, ValueError) else
                               f"initialization failed ({type(error).__name__}: {str(error)[:400]})")
        self.phase = INITIALIZED
        self.clock = Clock(self.clock.start_time, self.clock.stop_time)

    def terminate(self):
        refusal = self.wrong_state("fmi2Terminate", (INITIALIZED,))
        if refusal is not None:
            return self.report(refusal)
        self.phase = TERMINATED

    @guarded
    def do_step(self, current_time, step_size):
        refusal = self.wrong_state("fmi2DoStep", (INITIALIZED,))
        if refusal is not None:
            return self.refuse(refusal)
        if self.failure is not None:
            return self.refuse(f"fmi2DoStep refused: {self.failure}")
        if not (math.isfinite(step_size) and step_size > 0.0):
            return self.refuse(f"communication step size = {step_size!r} s is invalid: allowed a finite value > 0")
        discontinuity = self.clock.discontinuity(current_time) or self.clock.past_stop(current_time, step_size)
        if discontinuity is not None:
            return self.refuse(discontinuity)
        bad_input = self.input_error()
        if bad_input is not None:
            return self.refuse(f"{bad_input}; step discarded (the state is as before the step; fix the input "
                               f"and retry)", Fmi2Status.discard)
        end = self.clock.end_of(step_size)
        before = self.snapshot()
        try:
            self.advance(float(end), float(step_size))
        except Exception as error:         # noqa: BLE001 - restore, then answer Discard or Error
            self._roll_back(before)
            if isinstance(error, (StepFailed, ArithmeticError)):
                return self.refuse(f"the step from t = {current_time!r} s of {step_size!r} s failed and was "
                                   f"discarded, the state is as before the step (retry with a shorter step or "
                                   f"another input, or roll back): {str(error)[:600]}", Fmi2Status.discard)
            return self.refuse(f"the step from t = {current_time!r} s failed ({type(error).__name__}: "
                               f"{str(error)[:400]}); the state is as before the step")
        self.clock.commit(float(current_time), float(step_size), end)
        return True

    def _roll_back(self, saved) -> None:
        """Restore `saved`; if even that fails, the instance can only be reset."""
        try:
            self.restore(saved)
        except Exception as error:         # noqa: BLE001
            self.failure = f"the state could not be restored ({type(error).__name__}: {error}); use fmi2Reset"
            self.report(self.failure)

    # state --------------------------------------------------------------------------------------------------
    def _state_tree(self):
        return dict(phase=self.phase, clock=self.clock.get_state(), failure=self.failure, model=self.snapshot())

    @guarded
    def _get_fmu_state(self):
        return SavedState(self._state_tree())

    @guarded
    def _set_fmu_state(self, state):
        if isinstance(state, RefusedState):
            return self.report(f"fmi2DeSerializeFMUstate refused the state: {state.reason}; nothing of it was used, "
                               f"the current state is kept")
        if not isinstance(state, SavedState):
            return self.report(f"fmi2SetFMUstate: a {type(state).__name__} is not a state of this FMU")
        tree = state.tree
        current = self._state_tree()
        try:
            if not isinstance(tree, dict) or tree.get("phase") not in PHASES:
                raise ValueError("the state has no valid phase")
            clock = Clock.from_state(tree["clock"])
            failure = tree["failure"]
            if failure is not None and not isinstance(failure, str):
                raise ValueError("the state's failure is not a text")
            self.restore(tree["model"])
        except Exception as error:         # noqa: BLE001 - a malformed state: keep the current one
            self._roll_back(current["model"])
            return self.report(f"fmi2SetFMUstate: the state cannot be restored ({type(error).__name__}: "
                               f"{str(error)[:300]}); the current state is kept")
        self.phase, self.clock, self.failure = tree["phase"], clock, failure

    # pythonfmu calls these two on the class, not on the instance
    @classmethod
    def _fmu_state_to_bytes(cls, state) -> bytes:
        """The serialized state (b"" for a refused one: the shim takes a size of 0 as the refusal)."""
        if not isinstance(state, SavedState):
            return b""
        if state.blob is None:
            state.blob = state_format.encode(cls.serializable(state.tree), cls.__name__, build_fingerprint())
        return state.blob

    @classmethod
    def _fmu_state_from_bytes(cls, blob: bytes):
        """The state in `blob`, or a RefusedState (fmu_src/c/fmi2_status_shim.c has already refused a blob whose
        envelope is not this FMU's: wrong magic, version, length, checksum or build). The content is checked in
        full (check_state_tree) before anything of it is used; no exception leaves (pythonfmu would answer
        fmi2Fatal and destroy the instance). pythonfmu calls this on the class, which has no logger: the reason
        goes to stderr here and to the instance's logger when the RefusedState reaches `_set_fmu_state`."""
        try:
            tree = state_format.decode(blob, cls.__name__, build_fingerprint())
            cls.check_state_tree(tree)
        except Exception as error:          # noqa: BLE001 - any fault of the bytes is a refusal
            reason = f"{str(error)[:600]}" if isinstance(error, ValueError) else \
                f"{type(error).__name__}: {str(error)[:600]}"
            print(f"[{cls.__name__}] fmi2DeSerializeFMUstate refused: {reason}", file=sys.stderr, flush=True)
            return RefusedState(reason)
        return SavedState(tree, bytes(blob))

    @classmethod
    def check_state_tree(cls, tree) -> None:
        """ValueError naming the first field of `tree` (a state read from bytes) that is not what this slave saves
        (fmu_src.state_schema): the phase, the clock against the model's time, the model (`model_schema`,
        `model_relations`)."""
        tree_schema = schema.Record({"phase": schema.Text(PHASES), "clock": CLOCK_SCHEMA,
                                     "failure": schema.Nullable(schema.Text(length=5000)), "model": cls.model_schema()})
        schema.check(tree_schema, cls.model_relations(), tree)
        model_time = cls.model_time(tree["model"])
        if (model_time is not None) != (tree["phase"] in (INITIALIZED, TERMINATED)):
            raise ValueError(f"the state is inconsistent: phase {tree['phase']!r} "
                             f"{'with' if model_time is not None else 'without'} a built model")
        check_clock(tree["clock"], model_time)

    @classmethod
    def serializable(cls, tree):
        """The snapshot tree in the form that is serialized (a slave may make it smaller)."""
        return tree

    # variable access: pythonfmu raises on unknown references or wrong types, which would be fmi2Fatal -----------
    def _refused_access(self, function: str, references, kind: type, setting: bool) -> str | None:
        """Why `function` may not access `references` now (then nothing is read or written), or None."""
        allowed = (INSTANTIATED, INITIALIZATION_MODE, INITIALIZED) if setting else \
            (INITIALIZATION_MODE, INITIALIZED, TERMINATED)
        refusal = self.wrong_state(function, allowed)
        if refusal is not None:
            return refusal
        for reference in references:
            variable = self.vars.get(reference)
            if variable is None:
                return f"{function}: value reference {reference} does not exist; nothing was done"
            if not isinstance(variable, kind):
                actual = next((name for cls, name in TYPE_NAMES.items() if isinstance(variable, cls)), "?")
                return (f"{function}: '{variable.name}' (value reference {reference}) is a {actual}, not a "
                        f"{TYPE_NAMES[kind]}; nothing was done")
            if not setting:
                continue
            if variable.causality not in (Fmi2Causality.parameter, Fmi2Causality.input):
                return f"{function}: '{variable.name}' is an {variable.causality.name}, it cannot be set; nothing " \
                       f"was set"
            if (self.phase == INITIALIZED and variable.causality == Fmi2Causality.parameter
                    and variable.variability != Fmi2Variability.tunable):
                return (f"{function}: parameter '{variable.name}' is fixed after initialization (variability "
                        f"{variable.variability.name}); nothing was set (use fmi2Reset to start over with other "
                        f"parameters)")
        return None

    def _get(self, getter, function, kind, references, default):
        """(values, True) or, refused with fmi2Error, ([default] * n, False)."""
        refusal = self._refused_access(function, references, kind, setting=False)
        if refusal is not None:
            self.report(refusal)
            return [default] * len(references), False
        try:
            return getter(references), True
        except Exception as error:          # noqa: BLE001
            self.report(f"{function}: {type(error).__name__}: {str(error)[:300]}")
            return [default] * len(references), False

    def get_real(self, vrs):
        """The values; a value that is not finite comes with fmi2Warning and the reason (never NaN with fmi2OK)."""
        values, done = self._get(super().get_real, "fmi2GetReal", Real, vrs, math.nan)
        undefined = [(self.vars[r].name, v) for r, v in zip(vrs, values) if not math.isfinite(v)] if done else []
        if undefined:
            self.report("; ".join(f"{name} = {value!r}: {self.undefined_reason(name)}" for name, value in undefined),
                        Fmi2Status.warning)
        return values

    def get_integer(self, vrs):
        return self._get(super().get_integer, "fmi2GetInteger", Integer, vrs, 0)[0]

    def get_boolean(self, vrs):
        return self._get(super().get_boolean, "fmi2GetBoolean", Boolean, vrs, False)[0]

    def get_string(self, vrs):
        return self._get(super().get_string, "fmi2GetString", String, vrs, "")[0]

    def _set(self, setter, function, kind, references, values):
        refusal = self._refused_access(function, references, kind, setting=True)
        if refusal is not None:
            return self.report(refusal)
        try:
            setter(references, values)
        except Exception as error:          # noqa: BLE001
            self.report(f"{function}: {type(error).__name__}: {str(error)[:300]}")

    def set_real(self, vrs, values):
        self._set(super().set_real, "fmi2SetReal", Real, vrs, values)

    def set_integer(self, vrs, values):
        self._set(super().set_integer, "fmi2SetInteger", Integer, vrs, values)

    def set_boolean(self, vrs, values):
        self._set(super().set_boolean, "fmi2SetBoolean", Boolean, vrs, values)

    def set_string(self, vrs, values):
        self._set(super().set_string, "fmi2SetString", String, vrs, values)

    # modelDescription ---------------------------------------------------------------------------------------
    def to_xml(self, model_options=dict()):
        """pythonfmu's modelDescription plus UnitDefinitions, output dependencies and InitialUnknowns."""
        phase, self.phase = self.phase, INITIALIZATION_MODE     # pythonfmu reads the start values through get_*
        try:
            root = super().to_xml(model_options)
        finally:
            self.phase = phase
        units = {v.unit for v in self.vars.values() if isinstance(v, RealVariable)}
        position = list(root).index(root.find("CoSimulation")) + 1
        root.insert(position, unit_definitions(units))
        structure = root.find("ModelStructure")
        outputs = structure.find("Outputs")
        if outputs is not None:
            for unknown in outputs:
                unknown.set("dependencies", "")       # outputs change only in do_step
            initial = SubElement(structure, "InitialUnknowns")
            for index, variable in enumerate(self.vars.values(), start=1):
                if variable.causality == Fmi2Causality.output:
                    SubElement(initial, "Unknown", index=str(index))
        return root

    # to implement -------------------------------------------------------------------------------------------
    def initialize(self):
        """Validate the parameters and build the model; raise ValueError with a clear message if invalid."""
        raise NotImplementedError

    def input_error(self) -> str | None:
        """Why the current input values cannot be used for a step (naming the input, its value and the allowed
        range), or None."""
        return None

    def advance(self, end_time: float, step_size: float) -> None:
        """One communication step of `step_size` to the model time `end_time` (from the start time); raise
        StepFailed if the model cannot complete it (the glue then restores the snapshot taken before)."""
        raise NotImplementedError

    def snapshot(self):
        """Everything the continuation depends on, as plain data (dicts with string keys, lists, numbers, strings,
        numpy arrays) that later steps do not change in place; cheap, it is taken before every step."""
        raise NotImplementedError

    def restore(self, state) -> None:
        """Continue from a `snapshot` (also one read back from bytes, where tuples are lists); the state must not
        be changed by it (it may be restored again)."""
        raise NotImplementedError

    def undefined_reason(self, name: str) -> str:
        """Why the Real variable `name` has no defined value now."""
        return "no defined value"

    def changed_parameters(self) -> dict:
        """The parameters whose values differ from their defaults (name -> value)."""
        return {}

    @classmethod
    def model_schema(cls) -> schema.Spec:
        """The schema of `snapshot`'s tree as read back from bytes (fmu_src.state_schema)."""
        raise NotImplementedError

    @classmethod
    def model_relations(cls) -> tuple:
        """Checks between the fields of a state tree (functions of the whole tree raising ValueError), run after
        the fields fit `model_schema`."""
        return ()

    @classmethod
    def model_time(cls, model) -> float | None:
        """The model time (from the start time) of a `snapshot` tree that fits `model_schema`; None if it holds
        no built model."""
        raise NotImplementedError


NAMED_PARAMETER = re.compile(r"parameter '(\w+)'")


def blame_changed(refusal: str, changed: dict) -> str:
    """A refusal at initialization that names a parameter the importer did not change (a relation: `rotor_radius`
    at its minimum refused through the `stroke` it leaves no room for), led by the parameters that were changed,
    with their values, so that the message names the parameter that was set (README contract row C2)."""
    named = NAMED_PARAMETER.search(refusal)
    if named is None or named.group(1) in changed or not changed:
        return refusal
    values = ", ".join(f"'{name}' = {schema.short_repr(value)}" for name, value in changed.items())
    return (f"parameter{'s' if len(changed) > 1 else ''} {values} {'are' if len(changed) > 1 else 'is'} refused: "
            f"with {'them' if len(changed) > 1 else 'it'}, {refusal}")


def build_fingerprint() -> str:
    """The bundled package's name, rotary_vane_<version>_<source hash> (fmu_src/build.py): a serialized state is
    read only by a build of the same sources."""
    return __name__.split(".")[0]


def drop_repeated_path_entries() -> None:
    """pythonfmu inserts the FMU's resources folder into sys.path at every fmi2Instantiate: keep each entry once,
    so that a host that instantiates and frees the FMU many times does not grow sys.path (and every import's
    search) without bound."""
    seen: set[str] = set()
    sys.path[:] = [entry for entry in sys.path if not (entry in seen or seen.add(entry))]
