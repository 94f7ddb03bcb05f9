"""Where numba keeps this project's compiled kernels: one folder per version of the sources, found by content.

Numba's own cache locators key the cache folder by the source file's directory and check only each function's
own file. Two failures follow for this project: a kernel compiled against an older version of a module it calls
(an index layout, a contact law) is reused after that module changed; and code unpacked into a new temporary
folder on every run, as fmpy does with an FMU, never finds its cache and compiles again (about 10 s).

`install(package_dir)` registers a locator for the functions defined under `package_dir` whose cache folder is
`<cache root>/<hash of all the project's sources>/<package>/`: any change of any source file gives a new folder,
and identical sources find the same folder wherever they are unpacked. The cache root is the environment
variable ROTARY_VANE_CACHE_DIR, else `$XDG_CACHE_HOME/rotary-vane-compressor/numba` (default `~/.cache/...`).
This module lives in the lowest layer because every package of the project uses it.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

from numba.core import caching

CACHE_ENVIRONMENT_VARIABLE = "ROTARY_VANE_CACHE_DIR"
PROJECT_PACKAGES = ("thermo", "mechanics", "fmu_src")


def source_hash(project_dir: Path) -> str:
    """SHA-256 over the relative paths and contents of every .py file of the project's packages."""
    digest = hashlib.sha256()
    for package in PROJECT_PACKAGES:
        for path in sorted((project_dir / package).rglob("*.py")):
            digest.update(str(path.relative_to(project_dir)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def cache_root() -> Path:
    """The folder that holds one sub-folder per source version."""
    if os.environ.get(CACHE_ENVIRONMENT_VARIABLE):
        return Path(os.environ[CACHE_ENVIRONMENT_VARIABLE])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "rotary-vane-compressor" / "numba"


class ProjectSourceLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """Numba cache locator for the functions of the registered package folders (see the module docstring)."""

    package_caches: dict[str, str] = {}         # package folder -> cache folder

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        package_dir = self._package_of(py_file)
        relative = os.path.relpath(os.path.dirname(os.path.abspath(py_file)), package_dir)
        self._cache_path = os.path.normpath(os.path.join(self.package_caches[package_dir], relative))

    @classmethod
    def _package_of(cls, py_file):
        path = os.path.abspath(py_file)
        for package_dir in cls.package_caches:
            if path.startswith(package_dir + os.sep):
                return package_dir
        return None

    def get_cache_path(self):
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file):
        if cls._package_of(py_file) is None:
            return None
        return super().from_function(py_func, py_file)


def install(package_dir: str | Path) -> None:
    """Cache the kernels defined under `package_dir` by source content (idempotent)."""
    package_dir = Path(package_dir).resolve()
    cache = cache_root() / source_hash(package_dir.parent)[:20] / package_dir.name
    ProjectSourceLocator.package_caches[str(package_dir)] = str(cache)
    locators = caching.CacheImpl._locator_classes
    if ProjectSourceLocator not in locators:
        locators.insert(0, ProjectSourceLocator)
