"""What a state tree read from bytes must be before any of it is used: a declarative schema (one table per slave:
field -> type, shape, range), checked in full by `check`.

A state blob comes from the importer (fmi2DeSerializeFMUstate). state_format checks its envelope and that it is
data only; this module checks its content: every field's type (a bool is not a number, a list is not a text),
every number's range and finiteness, every array's dtype and shape (sizes follow from the state's own parameters,
so a field cannot be made larger than the model it describes), and texts from their allowed set. A slave's table
may add relations between fields (the clock against the model time, the integrator's controls against the step
bounds) as functions checked after the fields. Anything else is refused with a ValueError that names the field,
its value and what is allowed; the slaves turn it into fmi2Error and keep their state.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..mechanics.parameters import short_repr


class Spec:
    """One node of a schema: `check(value, path, context)` raises ValueError naming `path` if `value` does not
    fit. `context` is the whole tree being checked (array shapes depend on its parameters)."""

    def check(self, value, path: str, context) -> None:
        raise NotImplementedError


def refuse(path: str, value, allowed: str):
    raise ValueError(f"state {f'field {path!r}' if path else 'tree'} = {short_repr(value)} is invalid: allowed "
                     f"{allowed}")


@dataclass(frozen=True)
class Real(Spec):
    """A float (JSON integers are accepted for floats), in [low, high]; not finite only if `finite` is False."""
    low: float = -math.inf
    high: float = math.inf
    finite: bool = True

    def check(self, value, path, context):
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if not number or (self.finite and not math.isfinite(value)) or \
                (math.isfinite(value) and not self.low <= value <= self.high):
            bounds = "" if (self.low, self.high) == (-math.inf, math.inf) else f" in [{self.low:g}, {self.high:g}]"
            refuse(path, value, f"a {'finite ' if self.finite else ''}number{bounds}")


@dataclass(frozen=True)
class Integer(Spec):
    low: int
    high: int

    def check(self, value, path, context):
        if not isinstance(value, int) or isinstance(value, bool) or not self.low <= value <= self.high:
            refuse(path, value, f"an integer in [{self.low}, {self.high}]")


@dataclass(frozen=True)
class Boolean(Spec):
    def check(self, value, path, context):
        if not isinstance(value, bool):
            refuse(path, value, "true or false")


@dataclass(frozen=True)
class Text(Spec):
    """A string from `choices` (any string if None), at most `length` characters."""
    choices: tuple[str, ...] | None = None
    length: int = 1000

    def check(self, value, path, context):
        if not isinstance(value, str) or len(value) > self.length or \
                (self.choices is not None and value not in self.choices):
            refuse(path, value, f"one of {', '.join(self.choices)}" if self.choices else
                   f"a text of at most {self.length} characters")


@dataclass(frozen=True)
class Nullable(Spec):
    """None or `spec`."""
    spec: Spec

    def check(self, value, path, context):
        if value is not None:
            self.spec.check(value, path, context)


@dataclass(frozen=True)
class AnyOf(Spec):
    """The first of `specs` that fits (the message is the last one's)."""
    specs: tuple[Spec, ...]

    def check(self, value, path, context):
        for spec in self.specs[:-1]:
            try:
                return spec.check(value, path, context)
            except ValueError:
                pass
        self.specs[-1].check(value, path, context)


@dataclass(frozen=True)
class Record(Spec):
    """A dict with exactly these fields."""
    fields: dict[str, Spec]

    def check(self, value, path, context):
        if not isinstance(value, dict) or set(value) != set(self.fields):
            keys = sorted(value)[:8] if isinstance(value, dict) else type(value).__name__
            refuse(path, keys, f"a record of exactly the fields {', '.join(self.fields)}")
        for name, spec in self.fields.items():
            spec.check(value[name], f"{path}.{name}" if path else name, context)


@dataclass(frozen=True)
class Mapping(Spec):
    """A dict whose keys are some of `keys` (so it is never larger), each value fitting `value`."""
    keys: tuple[str, ...]
    value: Spec

    def check(self, value, path, context):
        if not isinstance(value, dict) or not set(value) <= set(self.keys):
            extra = sorted(set(value) - set(self.keys))[:3] if isinstance(value, dict) else type(value).__name__
            refuse(path, extra if isinstance(value, dict) else value,
                   f"a record of at most the {len(self.keys)} fields {', '.join(self.keys[:5])}, ...")
        for name, item in value.items():
            self.value.check(item, f"{path}.{name}" if path else name, context)


@dataclass(frozen=True)
class Sequence(Spec):
    """A list of exactly `length` items fitting `item`."""
    item: Spec
    length: int

    def check(self, value, path, context):
        if not isinstance(value, list) or len(value) != self.length:
            refuse(path, value, f"a list of {self.length} items")
        for k, item in enumerate(value):
            self.item.check(item, f"{path}[{k}]", context)


@dataclass(frozen=True)
class Array(Spec):
    """A numpy array of `dtype` whose shape is `shape(context)` (a tuple; None in it: any length up to the
    bound given as (None, bound)); all elements within [low, high] and, if `finite`, finite."""
    dtype: str
    shape: Callable[[Any], tuple]
    low: float = -math.inf
    high: float = math.inf
    finite: bool = True

    def check(self, value, path, context):
        expected = self.shape(context)
        if not isinstance(value, np.ndarray) or value.dtype != np.dtype(self.dtype) or \
                value.ndim != len(expected) or not all(
                    (n == size) if not isinstance(size, tuple) else (0 <= n <= size[1])
                    for n, size in zip(value.shape, expected)):
            described = (f"an array of shape {value.shape} and dtype {value.dtype}" if isinstance(value, np.ndarray)
                         else type(value).__name__)
            refuse(path, described, f"an array of dtype {self.dtype} and shape "
                                    f"{tuple(s if not isinstance(s, tuple) else f'<= {s[1]}' for s in expected)}")
        if self.finite and value.size and value.dtype.kind == "f" and not np.isfinite(value).all():
            refuse(path, f"an array with {int((~np.isfinite(value)).sum())} values that are not finite",
                   "finite values")
        numbers = value[np.isfinite(value)] if value.dtype.kind == "f" else value
        if numbers.size and (numbers.min() < self.low or numbers.max() > self.high):
            refuse(path, f"an array with values in [{numbers.min():g}, {numbers.max():g}]",
                   f"values in [{self.low:g}, {self.high:g}]")


def check(spec: Spec, relations: tuple[Callable[[Any], None], ...], tree) -> None:
    """Raise ValueError naming the first field of `tree` that does not fit `spec`, then run the `relations`
    (functions of the tree that raise ValueError naming the fields that disagree)."""
    spec.check(tree, "", tree)
    for relation in relations:
        relation(tree)
