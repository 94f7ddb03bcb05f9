"""The one way the library refuses a bad argument: a ValueError naming the variable, its value and what is allowed
(every check of thermo and mechanics words its refusal through `fail`)."""
from __future__ import annotations

import math


def fail(name, value, allowed):
    """Raise ValueError "name=value is out of range; allowed: allowed"."""
    raise ValueError(f"{name}={value!r} is out of range; allowed: {allowed}")


def checked_number(name, value, allowed, condition):
    """float(value) if it is a finite real number with condition(number) true, else `fail` with `allowed`."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        fail(name, value, allowed)
    if not (math.isfinite(number) and condition(number)):
        fail(name, value, allowed)
    return number
