"""The small slaves' shared part (DriveMotor, RefrigerationLoop): parameters declared in a table (name -> unit,
default, range or choices, description), checked by name, and a saved state holding `parameters`, `built` and
`time` beside the slave's own fields."""
from __future__ import annotations

import math

from pythonfmu.enums import Fmi2Causality, Fmi2Variability

from ..mechanics.parameters import short_repr

from .slave import GuardedSlave
from .variables import RealVariable, declared_parameter, output


def number(unit, default, minimum, maximum, description, *, integer=False):
    """A numeric parameter with its unit and closed range [minimum, maximum] (FMI min/max are inclusive)."""
    return dict(unit=unit, default=default, min=minimum, max=maximum, integer=integer, description=description)


def check_parameter(name, value, meta):
    """Raise ValueError naming the parameter, its value and the allowed values or range."""
    if "choices" in meta:
        if value not in meta["choices"]:
            raise ValueError(f"parameter '{name}' = {short_repr(value)} is invalid: allowed one of "
                             f"{', '.join(meta['choices'])}")
        return
    unit = "" if meta["unit"] == "1" else f" {meta['unit']}"
    allowed = f"{'an integer' if meta['integer'] else 'a finite value'} in [{meta['min']:g}, {meta['max']:g}]{unit}"
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or (meta["integer"] and value != int(value)) or value > meta["max"] \
            or value < meta["min"]:
        raise ValueError(f"parameter '{name}' = {short_repr(value)}{unit} is out of range: allowed {allowed}")


class DeclaredSlave(GuardedSlave):
    """A slave whose parameters are the table `declared_parameters` and whose saved state fits `state_schema`; subclasses
    set both and may extend `check_parameters` with relations between parameters."""

    declared_parameters: dict = {}
    state_schema = None

    def register_declared_variables(self, inputs, outputs) -> None:
        """Register the continuous inputs `inputs` (name, unit, start, description; each set to its start), the
        declared parameters (each set to its default) and the outputs `outputs` (name -> (unit, description),
        read through `_output(name)`)."""
        for name, unit, start, text in inputs:
            setattr(self, name, start)
            self.register_variable(RealVariable(name, unit, causality=Fmi2Causality.input,
                                                variability=Fmi2Variability.continuous, description=text))
        for name, meta in self.declared_parameters.items():
            setattr(self, name, meta["default"])
            self.register_variable(declared_parameter(name, meta))
        for name, (unit, text) in outputs.items():
            self.register_variable(output(name, unit, text,
                                          getter=lambda name=name, owner=self.owner: owner._output(name)))

    @classmethod
    def check_parameters(cls, values: dict) -> None:
        """Each parameter in its range; ValueError naming the parameter otherwise."""
        for name, meta in cls.declared_parameters.items():
            check_parameter(name, values[name], meta)

    @classmethod
    def check_built(cls, tree) -> None:
        """A saved model that is built has valid parameters; one that is not has not run."""
        model = tree["model"]
        if not model["built"]:
            if model["time"] != 0.0:
                raise ValueError(f"the state is inconsistent: no model is built, yet its time is {model['time']!r} s")
            return
        cls.check_parameters(model["parameters"])

    def restore_settings(self, state, input_names) -> None:
        """Set the parameters and the inputs `input_names` of a saved state (`restore`), its parameters checked
        first if it holds a built model."""
        parameters = state["parameters"]
        if set(parameters) != set(self.declared_parameters):
            raise ValueError(f"the state is not one of {type(self).__name__}")
        if state["built"]:
            self.check_parameters(parameters)
        for name, value in parameters.items():
            setattr(self, name, value)
        for name in input_names:
            setattr(self, name, float(state["inputs"][name]))

    def parameter_values(self) -> dict:
        return {name: getattr(self, name) for name in self.declared_parameters}

    def changed_parameters(self):
        return {name: getattr(self, name) for name, meta in self.declared_parameters.items()
                if getattr(self, name) != meta["default"]}

    @classmethod
    def model_schema(cls):
        return cls.state_schema

    @classmethod
    def model_relations(cls):
        return (cls.check_built,)

    @classmethod
    def model_time(cls, model):
        return model["time"] if model["built"] else None
