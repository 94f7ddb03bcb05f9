"""No function of the physics layers (`kernels/`, `thermo/`, `mechanics/`) is longer than 80 lines, its docstring
included: a reader follows one on one screen, and a longer one is a sign that two jobs share it (the time loop's
`advance` delegates the replay verdict, the time advance, the commit of a step, a rejection and a valley crossing to
their own kernels). Read from the source with `ast`; nothing is imported.
"""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LIMIT = 80


def function_lengths(source: str) -> list[tuple[int, str]]:
    """(lines from `def` to the last line of the body, name) of every function and method in `source`."""
    return [(node.end_lineno - node.lineno + 1, node.name) for node in ast.walk(ast.parse(source))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))]


def test_no_function_of_the_physics_layers_is_longer_than_80_lines():
    too_long = [f"{path.relative_to(ROOT)}: {name} has {length} lines"
                for folder in ("kernels", "thermo", "mechanics") for path in sorted((ROOT / folder).rglob("*.py"))
                for length, name in function_lengths(path.read_text()) if length > LIMIT]
    assert not too_long, "\n".join(too_long)


def test_the_measure_counts_a_function_from_def_to_its_last_line():
    body = "".join(f"    x{i} = {i}\n" for i in range(LIMIT))
    source = f"def long():\n    '''doc'''\n{body}\n\nclass A:\n    def short(self):\n        return 1\n"
    assert sorted(function_lengths(source)) == [(2, "short"), (LIMIT + 2, "long")]
