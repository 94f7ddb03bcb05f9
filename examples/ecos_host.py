"""Ecos (the C++ co-simulation engine of PyPI's `ecospy`) as a test host: where its pieces are in this virtual
environment and what each needs to start.

* `ecospy` loads `binaries/libecosc.so`, which needs `libtbb.so.12` and has no run path: the `tbb` package (a test
  extra) installs that library under the environment's `lib/`, and `load_ecospy` loads it first (global symbols),
  so that the import finds it. This is Ecos's own dependency, not the FMU's.
* The `ecos` command line and `proxyfmu` (Ecos's out-of-process FMU server, started for `proxyfmu://` models) come
  in the wheel without their execute bit: `make_executable` sets it (pip keeps the modes the wheel records).
* `command_environment` is the environment of an `ecos` command: the host's, plus the tbb folder on
  LD_LIBRARY_PATH (again for Ecos itself; `ecos` finds `proxyfmu` next to itself). Nothing in it is for the FMU:
  no LD_PRELOAD, PYTHONHOME or PYTHONPATH.

Only the standard library is imported at module level (host scripts import this file).
"""
from __future__ import annotations

import ctypes
import importlib.metadata
import importlib.util
import os
import stat
from pathlib import Path

EXECUTABLES = ("ecos", "proxyfmu")


def binaries() -> Path:
    """The folder of the wheel's `ecos`, `proxyfmu` and `libecosc.so` (found without importing ecospy)."""
    spec = importlib.util.find_spec("ecospy")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("ecospy is not installed: pip install -e \".[test]\" installs it")
    return Path(next(iter(spec.submodule_search_locations))) / "binaries"


def tbb_library() -> Path:
    """libtbb.so.12 of the `tbb` package."""
    files = importlib.metadata.files("tbb") or []
    for file in files:
        if file.name == "libtbb.so.12":
            return Path(file.locate()).resolve()
    raise RuntimeError("the tbb package has no libtbb.so.12: pip install -e \".[test]\" installs it")


def make_executable() -> None:
    """Give the wheel's `ecos` and `proxyfmu` their execute bit (idempotent)."""
    for name in EXECUTABLES:
        path = binaries() / name
        mode = path.stat().st_mode
        wanted = mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH
        if mode != wanted:
            path.chmod(wanted)


def load_ecospy():
    """Import ecospy after loading its libtbb.so.12; returns the module."""
    ctypes.CDLL(str(tbb_library()), mode=ctypes.RTLD_GLOBAL)
    import ecospy
    return ecospy


def command_environment(base: dict[str, str]) -> dict[str, str]:
    """`base` with what the `ecos` command needs itself: tbb's folder on LD_LIBRARY_PATH."""
    env = dict(base)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(filter(None, (str(tbb_library().parent), env.get("LD_LIBRARY_PATH"))))
    return env


def run(simulation, names: list[str], steps: int, parameter_set: str | None = None) -> list[list[float]]:
    """Initialize `simulation` (an ecospy.EcosSimulation; applying the parameter set named `parameter_set`), step
    it `steps` times, terminate and free it; the Real values of `names` ("instance::variable") after initialization
    and after each step."""
    if not simulation.init(parameter_set=parameter_set):
        from ecospy import EcosLib
        raise RuntimeError(f"Ecos could not initialize: {EcosLib.get_last_error()}")
    rows = [[simulation.get_real(name) for name in names]]
    for _ in range(steps):
        simulation.step(1)
        rows.append([simulation.get_real(name) for name in names])
    simulation.terminate()
    simulation.free()
    return rows
