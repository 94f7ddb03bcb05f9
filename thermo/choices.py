"""The one mechanism that turns a choice (a string parameter such as a leakage law or the integrator) into the
integer code the compiled kernels branch on, and back.

A `Choices` is the tuple of the allowed names; a name's code is its position. Where the kernels compare against
named codes, the module that declares the choices derives them with `codes` (so a name and its code cannot drift
apart), e.g. ``HARMONIC, CYCLOIDAL = DISPLACEMENT_LAWS.codes("harmonic", "cycloidal")``.
"""
from __future__ import annotations


class Choices(tuple):
    """The allowed names of one kind of choice, in code order (a tuple: `in`, iteration, `", ".join` work)."""

    def __new__(cls, *names: str):
        if not names or len(set(names)) != len(names) or not all(isinstance(n, str) and n for n in names):
            raise ValueError(f"Choices{names!r}: allowed distinct non-empty names")
        return super().__new__(cls, names)

    def allowed(self) -> str:
        """'one of a, b, c' (the wording of the refusals and of the parameter table)."""
        return "one of " + ", ".join(self)

    def code(self, name, parameter: str) -> int:
        """The kernel code of `name`; ValueError naming `parameter`, the value and the allowed names otherwise."""
        if not isinstance(name, str) or name not in self:
            raise ValueError(f"parameter '{parameter}' = {name!r} is out of range: allowed {self.allowed()}")
        return self.index(name)

    def codes(self, *names: str) -> tuple[int, ...]:
        """The codes of several names (for the named constants the kernels compare against)."""
        return tuple(self.code(name, "choice") for name in names)

    def name(self, code) -> str:
        """The name of a kernel code (a float code of a constants record is accepted if it is integral)."""
        if isinstance(code, bool) or not float(code).is_integer() or not 0 <= int(code) < len(self):
            raise ValueError(f"code={code!r} is out of range; allowed: an integer in [0, {len(self) - 1}] "
                             f"({self.allowed()})")
        return self[int(code)]
