"""Shared FMI glue for the project's slaves (the Reference-FMUs way: one model a file, shared glue here).

pythonfmu 0.7.0 turns any Python exception into fmi2Fatal and offers no fmi2Error from Python: `do_step`
returning False is fmi2Discard, everything else is fmi2OK. So the slaves never let an exception escape: a bad
parameter is reported at initialization (an error-status log message, also on stderr) and every later step is
refused with fmi2Discard and the same message; a bad input or step size discards that step only. The glue also
completes the modelDescription (units, InitialUnknowns, output dependencies) and saves the whole model state for
fmi2GetFMUstate / fmi2SerializeFMUstate.
"""
from __future__ import annotations

import copy
import functools
import pickle
import sys
from xml.etree.ElementTree import SubElement

from pythonfmu import Fmi2Slave as PythonFmuSlave
from pythonfmu.enums import Fmi2Causality, Fmi2Status

from .exit_guard import release_at_exit
from .variables import RealVariable, unit_definitions

AUTHOR = "Rotary vane compressor simulator team"
LICENSE = "MIT"
VERSION = "0.1.0"


def guarded(method):
    """Run an FMI callback so that no exception reaches pythonfmu: report it and refuse (return False)."""
    @functools.wraps(method)
    def call(self, *args):
        try:
            return method(self, *args)
        except Exception as error:          # noqa: BLE001 - the host must never see a Python exception
            self.report(f"{method.__name__}: {type(error).__name__}: {error}")
            return False
    return call


class GuardedSlave(PythonFmuSlave):
    """Base of the project's slaves; subclasses implement `initialize`, `advance` and `snapshot`/`restore`."""

    author = AUTHOR
    license = LICENSE
    version = VERSION

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.start_time = 0.0
        self.initialized = False
        self.failure: str | None = None      # set when the instance cannot go on (bad parameters, failed run)
        release_at_exit(self.resources, self.modelName)

    # reporting --------------------------------------------------------------------------------------------
    def report(self, message: str, status: Fmi2Status = Fmi2Status.error) -> None:
        """Log to the importer (with % escaped: the message is a printf format there) and to stderr."""
        self.log(message.replace("%", "%%"), status)
        print(f"[{type(self).__name__} {self.instance_name}] {status.name}: {message}", file=sys.stderr,
              flush=True)

    def refuse(self, message: str) -> bool:
        """Report an error for this step and discard it."""
        self.report(message)
        return False

    # FMI callbacks ----------------------------------------------------------------------------------------
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.start_time = float(start_time)

    @guarded
    def exit_initialization_mode(self):
        if self.initialized:
            self.report("exitInitializationMode called again: ignored (use fmi2Reset to start over)")
            return
        self.initialized = True
        try:
            self.initialize()
        except ValueError as error:
            self.failure = f"initialization refused: {error}"
            self.report(self.failure)

    @guarded
    def do_step(self, current_time, step_size):
        if not self.initialized:
            return self.refuse("doStep called before exitInitializationMode")
        if self.failure is not None:
            return self.refuse(f"step refused: {self.failure}")
        if not (step_size > 0.0) or step_size == float("inf"):
            return self.refuse(f"communication step size = {step_size!r} s is invalid: allowed a finite value > 0")
        return self.advance(float(current_time) - self.start_time, float(step_size))

    # state --------------------------------------------------------------------------------------------------
    @guarded
    def _get_fmu_state(self):
        return dict(copy.deepcopy(self.snapshot()), initialized=self.initialized)

    @guarded
    def _set_fmu_state(self, state):
        if not isinstance(state, dict) or "initialized" not in state:
            self.report(f"setFMUstate: {type(state).__name__} is not a state of this FMU")
            return
        state = copy.deepcopy(state)
        self.initialized = state.pop("initialized")
        self.restore(state)

    @staticmethod
    def _fmu_state_to_bytes(state) -> bytes:
        return pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)

    @staticmethod
    def _fmu_state_from_bytes(state: bytes):
        try:
            return pickle.loads(state)
        except Exception as error:          # noqa: BLE001 - garbage bytes must not become fmi2Fatal
            print(f"deSerializeFMUstate: not a state of this FMU ({type(error).__name__}: {error})",
                  file=sys.stderr, flush=True)
            return None

    # variable access: pythonfmu raises on unknown references or wrong types, which would be fmi2Fatal -----------
    def _checked_access(self, method, references, *values, default=None):
        try:
            return method(references, *values)
        except Exception as error:          # noqa: BLE001
            self.report(f"{method.__name__}{tuple(references)}: {type(error).__name__}: {error}")
            return None if default is None else [default] * len(references)

    def get_real(self, vrs):
        return self._checked_access(super().get_real, vrs, default=float("nan"))

    def get_integer(self, vrs):
        return self._checked_access(super().get_integer, vrs, default=0)

    def get_boolean(self, vrs):
        return self._checked_access(super().get_boolean, vrs, default=False)

    def get_string(self, vrs):
        return self._checked_access(super().get_string, vrs, default="")

    def set_real(self, vrs, values):
        self._checked_access(super().set_real, vrs, values)

    def set_integer(self, vrs, values):
        self._checked_access(super().set_integer, vrs, values)

    def set_boolean(self, vrs, values):
        self._checked_access(super().set_boolean, vrs, values)

    def set_string(self, vrs, values):
        self._checked_access(super().set_string, vrs, values)

    # modelDescription ---------------------------------------------------------------------------------------
    def to_xml(self, model_options=dict()):
        """pythonfmu's modelDescription plus UnitDefinitions, output dependencies and InitialUnknowns."""
        root = super().to_xml(model_options)
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

    def advance(self, time: float, step_size: float) -> bool:
        """One communication step from model time `time`; return False (after reporting) to discard it."""
        raise NotImplementedError

    def snapshot(self):
        """Everything the continuation depends on (deep-copied by the glue)."""
        raise NotImplementedError

    def restore(self, state) -> None:
        raise NotImplementedError
