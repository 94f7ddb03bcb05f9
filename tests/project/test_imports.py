"""Every import of the project's own code resolves, read from the source alone, to a file of the repository.

Nothing is installed or imported here: the test parses each file with `ast`, the way an editor or a structure
viewer reads the source. Inside the library (`kernels/`, `thermo/`, `mechanics/`, `fmu_src/`) imports between the
folders are relative (`from ..kernels.kernel import kernel` in `mechanics/` is the file `kernels/kernel.py`); scripts,
tests and benchmarks import the installed name `rotary_vane.<folder>`, whose folders pyproject.toml's package-dir maps
one to one. The layers point one way: kernels <- thermo <- mechanics <- fmu_src <- examples.
"""
from __future__ import annotations

import ast
import functools
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LIBRARY = ("kernels", "thermo", "mechanics", "fmu_src")
LAYER = {"kernels": 0, "thermo": 1, "mechanics": 2, "fmu_src": 3, "examples": 4}
SOURCES = sorted(path for folder in (*LIBRARY, "examples", "benchmarks", "tests", "docs")
                 for path in (ROOT / folder).rglob("*.py"))


@functools.cache
def package_dir() -> dict[str, Path]:
    """pyproject.toml's mapping of import packages to folders."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return {name: ROOT / folder for name, folder in config["tool"]["setuptools"]["package-dir"].items()}


def module_file(folder: Path, parts: list[str]) -> Path | None:
    """The file of module `parts` under `folder` (a module file or a package's __init__.py), or None."""
    base = folder.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


@functools.cache
def top_level_names(path: Path) -> set[str]:
    """Names a module binds at its top level (definitions, assignments, imports, star-less)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((alias.asname or alias.name).split(".")[0] for alias in node.names)
        elif isinstance(node, (ast.Name,)) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
    return names


def resolve(source: Path, node: ast.ImportFrom, mapping: dict[str, Path]) -> tuple[Path | None, str]:
    """(file the import names, how it was named) for a project import; (None, text) if it does not resolve."""
    if node.level:
        folder = source.parent
        for _ in range(node.level - 1):
            folder = folder.parent
        parts = node.module.split(".") if node.module else []
        return module_file(folder, parts), "." * node.level + (node.module or "")
    parts = node.module.split(".")
    for length in range(len(parts), 0, -1):
        package = ".".join(parts[:length])
        if package in mapping:
            return module_file(mapping[package], parts[length:]), node.module
    return None, node.module


def project_imports(source: Path):
    """The `from X import ...` statements of `source` that name the project's own code."""
    for node in ast.walk(ast.parse(source.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").split(".")[0] == "rotary_vane"):
            yield node
        if isinstance(node, ast.Import):
            for alias in node.names:
                assert alias.name.split(".")[0] != "rotary_vane" or source.relative_to(ROOT).parts[0] not in LIBRARY, (
                    f"{source.relative_to(ROOT)}:{node.lineno}: `import {alias.name}` inside the library; "
                    f"use a relative `from` import")


@pytest.mark.parametrize("source", SOURCES, ids=lambda path: str(path.relative_to(ROOT)))
def test_every_project_import_resolves_to_a_file(source):
    mapping = package_dir()
    folder = source.relative_to(ROOT).parts[0]
    for node in project_imports(source):
        target, named = resolve(source, node, mapping)
        where = f"{source.relative_to(ROOT)}:{node.lineno}"
        assert target is not None, f"{where}: `from {named} import ...` names no file of the repository"
        assert ROOT in target.parents, f"{where}: `from {named}` leaves the repository"
        if folder in LIBRARY:
            assert node.level, f"{where}: `from {named}` inside the library: imports between its folders are relative"
        target_folder = target.relative_to(ROOT).parts[0]
        if folder in LAYER and target_folder in LAYER:
            assert LAYER[target_folder] <= LAYER[folder], (
                f"{where}: {folder}/ imports {target_folder}/, against the layering kernels <- thermo <- mechanics "
                f"<- fmu_src <- examples")
        defined = top_level_names(target)
        for alias in node.names:
            if alias.name == "*":
                continue
            submodule = module_file(target.parent, [alias.name]) if target.name == "__init__.py" else None
            assert alias.name in defined or submodule is not None, (
                f"{where}: `from {named} import {alias.name}`: {target.relative_to(ROOT)} defines no such name")


def test_the_resolver_finds_a_broken_import(tmp_path):
    """The check can fail: a relative import of a module that does not exist resolves to nothing."""
    dynamics = ROOT / "mechanics" / "loop" / "dynamics.py"
    node = ast.parse("from ...thermo.no_such_module import x").body[0]
    assert resolve(dynamics, node, package_dir())[0] is None
    node = ast.parse("from ...kernels.kernel import kernel").body[0]
    assert resolve(dynamics, node, package_dir())[0] == ROOT / "kernels" / "kernel.py"
