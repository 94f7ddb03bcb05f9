"""How the project compiles its numerical kernels and where they are cached: the `@kernel` decorator and its helpers
(kernels.kernel) and the numba cache by source content with the kernels an FMU ships (kernels.compile_cache),
docs/model.md §8.2. The lowest layer: thermo/ and mechanics/ both compile their kernels with it."""
from pathlib import Path

from .compile_cache import install as _install_compile_cache

_install_compile_cache(Path(__file__).parent, __name__)       # before any kernel is defined (kernels.kernel.copy_values)
