"""rotary-vane-compressor: one import package that owns the project's folders.

The repository keeps the design card's folders at its top (`kernels/`, `thermo/`, `mechanics/`, `fmu_src/`,
`examples/`); the installed distribution maps them to `rotary_vane.kernels`, `rotary_vane.thermo`,
`rotary_vane.mechanics`, ... (`[tool.setuptools.package-dir]` in pyproject.toml), so that nothing this project
installs can overwrite or be shadowed by another distribution's `thermo` or `mechanics` (PyPI has a widely used
`thermo`). Inside the library the folders import each other relatively (`from ..kernels.kernel import kernel`), so
every import names a file of the repository.

In a checkout that is not installed (the repository folder on sys.path), this package also looks for its
subpackages in the repository's top folder, so `import rotary_vane.mechanics` works there too.
"""
from pathlib import Path as _Path

_CHECKOUT = _Path(__file__).resolve().parent.parent
if (_CHECKOUT / "pyproject.toml").is_file() and (_CHECKOUT / "mechanics" / "__init__.py").is_file():
    __path__.append(str(_CHECKOUT))
