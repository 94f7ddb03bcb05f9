"""Work around pythonfmu 0.7.0's heap corruption at process exit in Python hosts.

The FMU binary keeps the embedded interpreter's state in a static `std::shared_ptr<PyState>`. At exit the
library's static destructors destroy that pointer, and then its `__attribute__((destructor))` assigns nullptr to
the destroyed pointer (`finalizePythonInterpreter`): the control block is released twice and glibc aborts
("corrupted double-linked list") or the host segfaults, depending on the memory layout.

The cure is to call the library's exported `finalizePythonInterpreter` once, from Python's `atexit`, which runs
before any C++ exit handler: the pointer is then null when the static destructors and the library destructor
reach it, and both become no-ops. This is done only when the host, not pythonfmu, initialised Python (the
interpreter's main thread is the process's main thread); when pythonfmu initialised it (a C host), Python's
atexit runs inside the library's own shutdown, where the call would interfere, so that case is left alone.
"""
from __future__ import annotations

import atexit
import ctypes
import os
import sys
import threading
from pathlib import Path

_libraries: set[Path] = set()


def binary_path(resources: str | os.PathLike, model_identifier: str) -> Path:
    """The FMU's shared library next to its resources folder (binaries/linux64/<model>.so)."""
    return Path(resources).resolve().parent / "binaries" / "linux64" / f"{model_identifier}.so"


def release_at_exit(resources: str | os.PathLike | None, model_identifier: str) -> None:
    """Register the FMU binary of this instance for the exit-time release (no-op outside a Python-initialised
    Linux process or when the binary does not exist, e.g. while pythonfmu builds the FMU)."""
    if resources is None or not sys.platform.startswith("linux"):
        return
    if threading.main_thread().native_id != os.getpid():
        return                               # pythonfmu initialised Python in its worker thread: a C host
    library = binary_path(resources, model_identifier)
    if not library.is_file():
        return
    if not _libraries:
        atexit.register(_release_all)
    _libraries.add(library)


def _release_all() -> None:
    for library in sorted(_libraries):
        try:
            ctypes.CDLL(str(library)).finalizePythonInterpreter()
        except (OSError, AttributeError):     # not loaded any more, or not a pythonfmu 0.7 binary
            pass
