"""Work around pythonfmu 0.7.0's heap corruption at process exit.

The FMU binary keeps the embedded interpreter's state in a static `std::shared_ptr<PyState>`. At exit the C++
static destructors destroy that pointer, and afterwards the library's `__attribute__((destructor))` assigns
nullptr to the destroyed pointer (`finalizePythonInterpreter`): the control block is released twice and glibc
aborts ("corrupted double-linked list") or the host segfaults, depending on the memory layout.

The cure is to run the library's exported `finalizePythonInterpreter` once *before* those destructors. It is
registered with the C runtime's `__cxa_atexit` (as a process exit handler, not tied to the library) the first time
an instance is created: exit handlers run in reverse order of registration, so it runs before the library's static
destructors (registered when the library was loaded) and before the library destructors (run last). The pointer
is then null when they reach it, and both become no-ops. In a C host this also shuts the interpreter down
(pythonfmu's own thread does it); in a Python host the interpreter is already finalized and only the pointer is
released. The library cannot be unloaded before exit (it has STB_GNU_UNIQUE symbols), so the handler stays valid.
"""
from __future__ import annotations

import ctypes
import os
import sys
from pathlib import Path

_registered: set[Path] = set()


def binary_path(resources: str | os.PathLike, model_identifier: str) -> Path:
    """pythonfmu's shared library of the FMU next to its resources folder: binaries/linux64/<model>_pythonfmu.so
    behind the status shim (fmu_src/status_shim.py), else binaries/linux64/<model>.so."""
    binaries = Path(resources).resolve().parent / "binaries" / "linux64"
    behind_shim = binaries / f"{model_identifier}_pythonfmu.so"
    return behind_shim if behind_shim.is_file() else binaries / f"{model_identifier}.so"


def release_at_exit(resources: str | os.PathLike | None, model_identifier: str) -> None:
    """Register the FMU binary's `finalizePythonInterpreter` as a process exit handler, once per binary (no-op
    outside Linux, or when the binary does not exist, e.g. while pythonfmu builds the FMU)."""
    if resources is None or not sys.platform.startswith("linux"):
        return
    library = binary_path(resources, model_identifier)
    if library in _registered or not library.is_file():
        return
    try:
        finalize = ctypes.CDLL(str(library)).finalizePythonInterpreter
        register = ctypes.CDLL(None).__cxa_atexit
    except (OSError, AttributeError):       # not a pythonfmu 0.7 binary, or not glibc
        return
    register.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    register(ctypes.cast(finalize, ctypes.c_void_p), None, None)
    _registered.add(library)
