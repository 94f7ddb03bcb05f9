"""The disk cache of data derived from CoolProp: property tables (thermo.property_table) and operating points
(thermo.operating_point), docs/model.md §7.1, §7.3.

Rules shared by both: a file is named by its content's key (`cache_path`: a hash of the text that lists everything
the content depends on), written atomically (`atomic_write`), and a file that cannot be read or carries another key
is rebuilt with a warning, never trusted; an unwritable folder costs speed, not the run (`load_or_build`). Nothing
is unpickled.

An FMU ships the files of its default operating point (fmu_src.ship_kernels) in `shipped_data/` next to the
bundled packages: a file the cache folder lacks is read from there, read-only, when one of the same name (the same
key) is shipped, so a machine that never ran the FMU does not build the default fluid's tables from CoolProp.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
import warnings
from pathlib import Path

from ..kernels.compile_cache import CACHE_ENVIRONMENT_VARIABLE

SHIPPED_DATA = Path(__file__).resolve().parent.parent / "shipped_data"      # in an FMU: beside the packages


def property_cache_dir() -> Path:
    """$ROTARY_VANE_CACHE_DIR/properties if set, else $XDG_CACHE_HOME (default ~/.cache)/rotary-vane-compressor/
    properties."""
    if os.environ.get(CACHE_ENVIRONMENT_VARIABLE):
        return Path(os.environ[CACHE_ENVIRONMENT_VARIABLE]) / "properties"
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "rotary-vane-compressor" / "properties"


NAME_LENGTH = 64           # characters of the name kept in a file name (the hash tells files apart)


def cache_path(name: str, key: str, suffix: str, cache_dir=None) -> Path:
    """<cache dir>/<name>-<first 24 hex digits of sha256(key)><suffix>; the cache dir is `cache_dir`, else
    `property_cache_dir()`; characters other than ASCII letters, digits, '-' and '_' in `name` become '_' and only
    its first NAME_LENGTH characters are used (a file name has a length limit, the key holds the whole name)."""
    folder = property_cache_dir() if cache_dir is None else Path(cache_dir)
    safe_name = "".join(c if (c.isascii() and c.isalnum()) or c in "-_" else "_" for c in name[:NAME_LENGTH])
    return folder / f"{safe_name}-{hashlib.sha256(key.encode()).hexdigest()[:24]}{suffix}"


def atomic_write(path: Path, write) -> None:
    """`write(stream)` into a temporary file in the same folder, renamed over `path` (concurrent writers each
    rename a complete file; readers never see a partial one)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=path.stem + ".", suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as stream:
            write(stream)
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise


def load_or_build(path: Path, load, build, write, what: str):
    """`load(path)` if the file exists and loads; else `value = build()`, saved by `atomic_write(path,
    lambda stream: write(stream, value))`, and returned. A file `load` refuses (any exception) is rebuilt with a
    RuntimeWarning; a folder that cannot be written warns and the value is used uncached."""
    shipped = SHIPPED_DATA / path.name
    for candidate in (path, shipped) if path != shipped else (path,):
        if candidate.is_file():
            try:
                return load(candidate)
            except Exception as error:          # any damage: the cache is disposable, rebuild it
                warnings.warn(f"{what} cache {candidate} is unreadable ({type(error).__name__}: {error}); "
                              f"rebuilding it", RuntimeWarning, stacklevel=3)
    value = build()
    try:
        atomic_write(path, lambda stream: write(stream, value))
    except OSError as error:                    # e.g. a read-only home: run without the cache
        warnings.warn(f"cannot write the {what} cache {path} ({error}); continuing without it", RuntimeWarning,
                      stacklevel=3)
    return value
