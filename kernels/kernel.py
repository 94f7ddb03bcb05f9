"""How the project compiles the functions of its time loop (docs/model.md §8.2).

`@kernel` is numba's nopython mode with three settings every loop function shares:
- cached on disk (per source version, kernels.compile_cache), so a new process does not compile again, and read from
  the kernels an FMU ships compiled when they can be used (`KernelCache`);
- numpy's error model: a division by zero or the logarithm of a negative number gives inf or NaN, never a Python
  exception, so nothing can leave the compiled loop as an exception; the loop checks its state for finiteness and
  stops with a named status instead;
- no reference counting (numba's `_nrt=False`): the loop's functions pass arrays and records around on every
  right-hand side, and counting references to each array on each call costs about as much as the physics (measured:
  0.86 -> 0.41 us per right-hand side of the pressure-table model). A function that creates arrays or array views
  (slices) needs the counting: `@kernel(allocates=True)`.
"""
from __future__ import annotations

import numpy as np
from numba import config, njit
from numba.core.dispatcher import Dispatcher

from .compile_cache import KernelCache


def kernel(function=None, *, allocates: bool = False, inline: bool = False):
    """Compile `function` for the time loop (module docstring); `allocates=True` if it creates arrays or views;
    `inline=True` to compile it into each caller (numba's inline="always"), for a small function on the loop's path
    whose call would otherwise copy its arguments once more (the method dispatchers of mechanics.loop.integrators)."""
    options = dict(error_model="numpy")
    if not allocates:
        options["_nrt"] = False
    if inline:
        options["inline"] = "always"

    def compiled(function):
        dispatcher = njit(**options)(function)
        if isinstance(dispatcher, Dispatcher):        # under NUMBA_DISABLE_JIT=1 njit returns the Python function
            dispatcher._cache = KernelCache(dispatcher.py_func)   # what cache=True sets (Dispatcher.enable_caching)
        return dispatcher
    return compiled if function is None else compiled(function)


def kernel_record(array: np.ndarray) -> np.ndarray:
    """A one-row structured array of constants as the kernels read it (`m = array[0]; m.stroke`): numba reads the
    fields of the plain array by name; pure Python (NUMBA_DISABLE_JIT=1) only those of a record array."""
    return array.view(np.recarray) if config.DISABLE_JIT else array


@kernel
def copy_values(target, target_start, source, source_start, count):
    """target[target_start:target_start + count] = source[source_start:...], without creating views (a kernel
    without reference counting cannot slice)."""
    for i in range(count):
        target[target_start + i] = source[source_start + i]
