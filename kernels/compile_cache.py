"""Where numba keeps this project's compiled kernels: one folder per version of the sources, found by content, and
the kernels an FMU ships compiled.

Numba's own cache locators key the cache folder by the source file's directory and check only each function's
own file. Two failures follow for this project: a kernel compiled against an older version of a module it calls
(an index layout, a contact law) is reused after that module changed; and code unpacked into a new temporary
folder on every run, as fmpy does with an FMU, never finds its cache and compiles again (about 10 s).

`install(package_dir, module_name)` registers a locator for the functions defined under `package_dir` whose cache
folder is `<cache root>/<hash of all the project's sources>/<import root>/<package>/`: any change of any source file
gives a new folder, and identical sources find the same folder wherever they are unpacked. The import root is the
top-level package the sources are imported as (`rotary_vane` for the library, the FMU's private name for the copy
bundled in an FMU): a compiled kernel refers to the modules it calls by their import names, so a kernel compiled by
an FMU cannot be loaded by the library, nor the reverse, even when their sources are identical (loading one raised
ModuleNotFoundError for the FMU's private package in a library process sharing the cache). The cache root is the environment
variable ROTARY_VANE_CACHE_DIR, else `$XDG_CACHE_HOME/rotary-vane-compressor/numba` (default `~/.cache/...`).
This module lives in the lowest layer, kernels/, because every package of the project uses it.

Shipped kernels. An FMU built by fmu_src.build carries its kernels compiled (fmu_src/ship_kernels.py) in numba's own
cache format, in `compiled_kernels/` next to the bundled packages (laid out as a cache folder: `kernels/...`,
`thermo/...`, `mechanics/...`), with `stamp.json`: the numba, llvmlite and Python versions, the LLVM target triple and
the source hash they were compiled for, and the portable CPU they were compiled for (`portable_cpu`) with the CPU
features that code needs. numba keys a cache entry by the CPU it was compiled for, so this process's own key never
finds them: when the stamp matches this process and this CPU has those features, each kernel's `KernelCache` first
looks in the shipped folder under the shipped CPU's key, read-only, and otherwise loads from or compiles into the
user's cache folder as without shipped kernels. When anything differs nothing shipped is used and
`shipped_kernels_refusal()` says why (the compressor FMU logs it). numba's cache index and data files are pickles,
which numba unpickles: the shipped ones are trusted as the FMU's Python code is, which comes from the same archive and
runs in the host too.
"""
from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path
from typing import NamedTuple

import llvmlite
import numba
from llvmlite import binding as llvm
from numba.core import caching

CACHE_ENVIRONMENT_VARIABLE = "ROTARY_VANE_CACHE_DIR"
PROJECT_PACKAGES = ("kernels", "thermo", "mechanics", "fmu_src")
SHIPPED_FOLDER = "compiled_kernels"
STAMP_FILE = "stamp.json"
# The CPU the shipped kernels are compiled for (numba's NUMBA_CPU_NAME, with NUMBA_CPU_FEATURES="": the CPU model's
# own features), per architecture of the LLVM triple, and the CPU features (LLVM's names) that code may use. numba's
# "generic" x86-64 has no SSE4.1 and calls the C library for every floor and round: 5-9 % slower time loop than
# x86-64-v2 (every x86-64 CPU since 2009; same results to the bit), which is checked against this CPU before use.
PORTABLE_CPUS = {"x86_64": ("x86-64-v2", ("cx16", "sahf", "popcnt", "crc32", "sse3", "ssse3", "sse4.1", "sse4.2"))}
GENERIC_CPU = ("generic", ())
STAMP_FIELDS = ("numba", "llvmlite", "python", "platform", "sources", "cpu", "cpu_features", "cpu_requires")


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


def cache_folder(project_dir: Path, import_root: str, digest: str | None = None, root: Path | None = None) -> Path:
    """The cache folder of the sources in `project_dir`, imported as the top-level package `import_root`
    (`digest`: their source_hash, if known), under `root` (default: cache_root())."""
    return (root or cache_root()) / (digest or source_hash(project_dir))[:20] / import_root


def portable_cpu(triple: str) -> tuple[str, tuple[str, ...]]:
    """(numba CPU name, CPU features its code needs) of the shipped kernels for the LLVM target `triple`."""
    return PORTABLE_CPUS.get(triple.split("-")[0], GENERIC_CPU)


def environment_stamp(project_dir: Path, digest: str | None = None) -> dict[str, str]:
    """What compiled kernels depend on besides the CPU: numba, llvmlite, Python (its bytecode tag), the LLVM target
    triple and the sources of `project_dir` (`digest`: their source_hash, if known)."""
    return {"numba": numba.__version__, "llvmlite": llvmlite.__version__,
            "python": sys.implementation.cache_tag + sys.abiflags, "platform": llvm.get_process_triple(),
            "sources": digest or source_hash(project_dir)}


class ShippedKernels(NamedTuple):
    folder: str                      # compiled_kernels/<package> of one package
    target: tuple[str, str, str]     # numba's cache key of their code generator: (LLVM triple, CPU name, features)


def shipped_kernels(project_dir: Path, digest: str) -> tuple[tuple[str, str, str] | None, str | None]:
    """(cache key target, None) when the kernels shipped in `project_dir` can be used here, (None, why not) when
    not, (None, None) when none are shipped (`digest`: the source_hash of `project_dir`)."""
    folder = Path(project_dir) / SHIPPED_FOLDER
    if not folder.is_dir():
        return None, None
    try:
        stamp = json.loads((folder / STAMP_FILE).read_text(encoding="utf-8"))
        if not isinstance(stamp, dict) or sorted(stamp) != sorted(STAMP_FIELDS):
            raise ValueError(f"allowed a JSON object of {', '.join(STAMP_FIELDS)}")
        if not (all(isinstance(stamp[name], str) for name in STAMP_FIELDS[:-1])
                and isinstance(stamp["cpu_requires"], list)
                and all(isinstance(feature, str) for feature in stamp["cpu_requires"])):
            raise ValueError("allowed text values and a list of CPU feature names in cpu_requires")
    except (OSError, ValueError) as error:
        return None, f"{folder / STAMP_FILE} is unusable ({type(error).__name__}: {str(error)[:200]})"
    current = environment_stamp(project_dir, digest)
    differences = [f"{name} {_short(stamp[name])} there, {_short(value)} here"
                   for name, value in current.items() if stamp[name] != value]
    if differences:
        return None, f"they were compiled for another environment ({'; '.join(differences)})"
    required = stamp["cpu_requires"]
    try:
        host = llvm.get_host_cpu_features() if required else {}
    except RuntimeError as error:                # LLVM cannot tell on some platforms (numba then assumes none)
        return None, f"they need the CPU features {', '.join(required)}, and this CPU's are unknown ({error})"
    missing = [feature for feature in required if not host.get(feature, False)]
    if missing:
        return None, f"they were compiled for the CPU {stamp['cpu']}, whose {', '.join(missing)} this CPU lacks"
    return (stamp["platform"], stamp["cpu"], stamp["cpu_features"]), None


def _short(value: str) -> str:
    return value[:12] if len(value) == 64 else value          # a source hash: its first 12 digits


_refusal: str | None = None


def shipped_kernels_refusal() -> str | None:
    """Why the kernels shipped with these sources are not used; None if they are, or if none are shipped."""
    return _refusal


_misses: list[str] = []


def shipped_kernel_misses() -> list[str]:
    """The kernels looked up among usable shipped kernels and not found there (numba then loads them from, or
    compiles them into, the user's cache folder) since the last call: each miss is returned once."""
    misses = _misses[:]
    del _misses[:len(misses)]
    return misses


class ProjectSourceLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """Numba cache locator for the functions of the registered package folders (see the module docstring)."""

    package_caches: dict[str, str] = {}                 # package folder -> cache folder
    package_shipped: dict[str, ShippedKernels] = {}     # package folder -> its usable shipped kernels

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        package_dir = self._package_of(py_file)
        relative = os.path.relpath(os.path.dirname(os.path.realpath(py_file)), package_dir)
        self._cache_path = os.path.normpath(os.path.join(self.package_caches[package_dir], relative))
        shipped = self.package_shipped.get(package_dir)
        self.shipped = None if shipped is None else shipped._replace(
            folder=os.path.normpath(os.path.join(shipped.folder, relative)))

    @classmethod
    def _package_of(cls, py_file):
        """The registered package folder `py_file` lies in, or None; both are compared after os.path.realpath: a
        host may hand the FMU its folder as `//tmp/...` (Ecos: `file:///` + `/tmp/...`) or through a symbolic link,
        and a folder that matched only by spelling would send numba to compile into the unpack folder."""
        path = os.path.realpath(py_file)
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


class KernelCache(caching.FunctionCache):
    """numba's disk cache of one kernel (what `cache=True` gives), which first reads the shipped kernels, if any
    can be used, under the shipped CPU's key; it never writes there (module docstring)."""

    def __init__(self, py_func):
        super().__init__(py_func)
        locator = self._impl.locator
        shipped = locator.shipped if isinstance(locator, ProjectSourceLocator) else None
        self._shipped = None if shipped is None else (
            caching.IndexDataCacheFile(shipped.folder, self._impl.filename_base, locator.get_source_stamp()),
            shipped.target)

    def _load_overload(self, sig, target_context):
        if self._enabled and self._shipped is not None:
            index, target = self._shipped
            signature, _, code = self._index_key(sig, target_context.codegen())   # numba's (sig, target, code)
            data = index.load((signature, target, code))
            if data is not None:
                return self._impl.rebuild(target_context, data)
            _misses.append(f"the kernel {self._py_func.__qualname__}{signature} is not among the kernels shipped in "
                           f"{os.path.dirname(index._index_path)}")
        return super()._load_overload(sig, target_context)

    def files(self) -> list[Path]:
        """This kernel's files in the user's cache folder: its index and its data files."""
        base = self._impl.filename_base
        return sorted(path for path in Path(self.cache_path).iterdir()
                      if path.name == f"{base}.nbi" or (path.name.startswith(f"{base}.") and path.suffix == ".nbc"))


def install(package_dir: str | Path, module_name: str) -> None:
    """Cache the kernels defined under `package_dir` (the package imported as `module_name`) by source content and
    import root, reading the kernels shipped with them first if they can be used here (idempotent)."""
    global _refusal
    package_dir = Path(os.path.realpath(package_dir))
    digest = source_hash(package_dir.parent)
    ProjectSourceLocator.package_caches[str(package_dir)] = str(
        cache_folder(package_dir.parent, module_name.split(".")[0], digest) / package_dir.name)
    target, _refusal = shipped_kernels(package_dir.parent, digest)
    if target is not None:
        ProjectSourceLocator.package_shipped[str(package_dir)] = ShippedKernels(
            str(package_dir.parent / SHIPPED_FOLDER / package_dir.name), target)
    locators = caching.CacheImpl._locator_classes
    if ProjectSourceLocator not in locators:
        locators.insert(0, ProjectSourceLocator)
