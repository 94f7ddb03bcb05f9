"""The FMU's `resources/requirements.txt`: exactly the distributions that the bundled code imports.

The list is not written by hand: every `import X` / `from X import ...` in the bundled packages (module level or
inside a function, as the lazy CoolProp import is) is collected from their syntax trees, the standard library and
the project's own packages are dropped, each remaining top-level module is mapped to the distribution that provides
it (`importlib.metadata.packages_distributions`), and the version constraint is the one this project's own
metadata declares for that distribution. A host environment made from exactly this file runs the FMU.
"""
from __future__ import annotations

import ast
import importlib.metadata
import re
import sys
from pathlib import Path

DISTRIBUTION = "rotary-vane-compressor"
OWN_PACKAGES = ("rotary_vane",)               # and the private name each FMU bundles it under


def imported_modules(package_dirs: list[Path]) -> set[str]:
    """Top-level names of every module imported anywhere in the .py files under `package_dirs`
    (absolute imports only: relative ones stay inside the package)."""
    names = set()
    for package_dir in package_dirs:
        for path in sorted(package_dir.rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
                if isinstance(node, ast.Import):
                    names.update(alias.name.split(".")[0] for alias in node.names)
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names.add(node.module.split(".")[0])
    return names


def declared_constraints() -> dict[str, str]:
    """Distribution name (normalised) -> the requirement this project declares for it (no extras' entries)."""
    constraints = {}
    for requirement in importlib.metadata.requires(DISTRIBUTION) or []:
        if ";" in requirement:                      # an extra's or a platform's entry
            continue
        name = re.split(r"[\s\[<>=!~]", requirement, maxsplit=1)[0]
        constraints[normalised(name)] = requirement
    return constraints


def normalised(distribution: str) -> str:
    """PEP 503 name normalisation."""
    return re.sub(r"[-_.]+", "-", distribution).lower()


def bundled_requirements(package_dirs: list[Path]) -> list[str]:
    """requirements.txt lines for the code under `package_dirs`, sorted; a third-party import that no installed
    distribution provides, or that this project does not declare, is an error (the FMU would fail in a host)."""
    providers = importlib.metadata.packages_distributions()
    constraints = declared_constraints()
    own = {*OWN_PACKAGES, *(package_dir.name for package_dir in package_dirs)}
    third_party = sorted(imported_modules(package_dirs) - set(sys.stdlib_module_names) - own)
    lines = []
    for module in third_party:
        distributions = providers.get(module)
        if not distributions:
            raise RuntimeError(f"the bundled code imports {module!r}, which no installed distribution provides")
        declared = constraints.get(normalised(distributions[0]))
        if declared is None:
            raise RuntimeError(f"the bundled code imports {module!r} (distribution {distributions[0]!r}), which "
                               f"{DISTRIBUTION} does not declare as a dependency in pyproject.toml")
        lines.append(declared)
    return sorted(set(lines), key=str.lower)
