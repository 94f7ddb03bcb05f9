"""Put the FMI shim (fmu_src/c/fmi2_status_shim.c) in front of pythonfmu's binary in a built FMU.

pythonfmu's library can return only fmi2OK, fmi2Discard (doStep) or fmi2Fatal (any Python exception, after which
the instance is gone), and it needs a Python in the host's process. The shim becomes
`binaries/<platform>/<model>.so`, loads pythonfmu's library renamed to `<model>_pythonfmu.so` beside it, and returns
for each call the worst status the Python slave logged during that call, so the slave can answer fmi2Warning or
fmi2Error as the standard prescribes (fmu_src/slave.py). In a host that is not a Python program it first loads a
libpython (fmu_src/c/host_python.c): by default the one of the interpreter that runs this build, recorded here.

It is compiled with the C compiler of the build machine (`$CC`, else `cc` or `gcc`) for linux64 only, once per FMU:
the state tag "<model>/<build fingerprint>", the modelDescription's GUID and the building interpreter (version,
`sys.executable`, shared libpython) are compiled in. The FMI headers come with fmpy. Without a compiler, or for
another platform's binary, the FMU keeps pythonfmu's binary and the build says so (`DEGRADED`).
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree

C_FOLDER = Path(__file__).resolve().parent / "c"
SOURCES = ("fmi2_status_shim.c", "host_python.c", "resource_uri.c", "state_envelope.c")
PLATFORM = "linux64"
MARKER = "resources/fmi2_status_shim.txt"         # present in an FMU whose binary is the shim
# the LogCategories pythonfmu declares and the shim gives every message (fmu_src/c/fmi2_status_shim.c, CATEGORY)
LOG_CATEGORIES = ("logAll", "logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal")
DEGRADED = ("it cannot answer fmi2Error or fmi2Warning: a bad parameter, a call in the wrong state, a write to an "
            "output or to a fixed parameter, an unknown value reference or state bytes of another build are "
            "answered with fmi2OK and an error message (a step then with fmi2Discard), there is no error state, "
            "and a string parameter that is not UTF-8 or a null pointer is fmi2Fatal; a host that is not a Python "
            "program must preload libpython (LD_PRELOAD) and set PYTHONHOME and PYTHONPATH")


def fmi_headers() -> Path:
    """The folder of fmi2Functions.h: fmpy ships the FMI 2.0 headers (found, not imported: the FMU bundles this
    module, and its requirements list what the bundle imports, fmu_src/requirements.py)."""
    fmpy = importlib.util.find_spec("fmpy")
    if fmpy is None or not fmpy.submodule_search_locations:
        raise FileNotFoundError("fmpy is not installed: it provides the FMI 2.0 headers the shim is compiled with")
    return Path(fmpy.submodule_search_locations[0]) / "c-code"


def shared_libpython() -> str:
    """The running interpreter's shared libpython (LIBDIR + INSTSONAME or LDLIBRARY), or "" for a static one."""
    if not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        return ""
    directory = sysconfig.get_config_var("LIBDIR") or ""
    for name in (sysconfig.get_config_var("INSTSONAME"), sysconfig.get_config_var("LDLIBRARY")):
        if name and ".so" in name and (Path(directory) / name).is_file():
            return str(Path(directory) / name)
    return ""


def building_interpreter() -> dict[str, str]:
    """The interpreter of this build, which the FMU uses in a host that is not a Python program."""
    return {"version": f"{sys.version_info.major}.{sys.version_info.minor}", "executable": sys.executable,
            "library": shared_libpython()}


def c_string(text: str) -> str:
    """`text` as a C string literal (UTF-8; every byte that is not a plain letter or digit as an octal escape)."""
    return '"' + "".join(chr(b) if chr(b).isalnum() and b < 128 else f"\\{b:03o}" for b in text.encode()) + '"'


def config_source(guid: str, interpreter: dict[str, str]) -> str:
    """The definitions of fmu_src/c/shim_config.h for one FMU."""
    values = {"SHIM_MODEL_GUID": guid, "SHIM_PYTHON_VERSION": interpreter["version"],
              "SHIM_PYTHON_EXECUTABLE": interpreter["executable"], "SHIM_PYTHON_LIBRARY": interpreter["library"]}
    return '#include "shim_config.h"\n' + "".join(f"const char {name}[] = {c_string(value)};\n"
                                                  for name, value in values.items())


def compile_shim(destination: Path, state_tag: str, guid: str, interpreter: dict[str, str]) -> str | None:
    """Compile the shim to `destination`; None on success, else why it could not be built."""
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        return "no C compiler ($CC, cc or gcc) on this machine"
    try:
        headers = fmi_headers()
    except FileNotFoundError as error:
        return str(error)
    if not all(c.isalnum() or c in "_/." for c in state_tag):
        return f"state tag {state_tag!r} has characters that cannot be passed to the compiler"
    config = destination.with_name("shim_config.c")
    config.write_text(config_source(guid, interpreter))
    command = [compiler, "-std=c99", "-O2", "-Wall", "-Wextra", "-fPIC", "-shared", "-pthread", f"-I{headers}",
               f"-I{C_FOLDER}", f'-DSTATE_TAG="{state_tag}"', "-o", str(destination),
               *[str(C_FOLDER / name) for name in SOURCES], str(config), "-ldl"]
    try:
        result = subprocess.run(command, capture_output=True, text=True)
    except OSError as error:
        return f"the C compiler {compiler!r} cannot be run: {error}"
    if result.returncode != 0:
        return f"{' '.join(command)} failed:\n{result.stderr}"
    return None


def model_description_facts(description: bytes) -> tuple[str, str | None]:
    """The GUID of a modelDescription.xml, and why the shim cannot serve it (None if it can): the shim gives every
    message one of LOG_CATEGORIES, which the modelDescription must declare."""
    root = ElementTree.fromstring(description)
    declared = {category.get("name") for category in root.iter("Category")}
    missing = [name for name in LOG_CATEGORIES if name not in declared]
    return root.get("guid") or "", (f"its modelDescription.xml does not declare the log categories {missing}"
                                    if missing else None)


def install(fmu: Path, model: str, state_tag: str) -> str | None:
    """Rewrite the FMU so that its linux64 binary is the shim; None on success, else why not (FMU unchanged).
    `state_tag` is fmu_src.state_format.tag_of(model, build fingerprint)."""
    inner_name = f"binaries/{PLATFORM}/{model}.so"
    with zipfile.ZipFile(fmu) as archive:
        if inner_name not in archive.namelist():
            return f"the FMU has no {inner_name}"
        entries = [(info, archive.read(info)) for info in archive.infolist()]
        guid, unfit = model_description_facts(archive.read("modelDescription.xml"))
    if unfit is not None:
        return unfit
    interpreter = building_interpreter()
    with tempfile.TemporaryDirectory(prefix="rvc_shim_") as temporary:
        shim = Path(temporary) / "shim.so"
        reason = compile_shim(shim, state_tag, guid, interpreter)
        if reason is not None:
            return reason
        rewritten = Path(temporary) / fmu.name
        with zipfile.ZipFile(rewritten, "w", zipfile.ZIP_DEFLATED) as archive:
            for info, data in entries:
                if info.filename == inner_name:
                    archive.writestr(f"binaries/{PLATFORM}/{model}_pythonfmu.so", data)
                    archive.writestr(info, shim.read_bytes())
                else:
                    archive.writestr(info, data)
            archive.writestr(MARKER, f"binaries/{PLATFORM}/{model}.so is the FMI shim of "
                                     f"rotary_vane.fmu_src.status_shim in front of {model}_pythonfmu.so.\n"
                                     f"In a host that is not a Python program it loads Python "
                                     f"{interpreter['version']}: $ROTARY_VANE_PYTHON if set, else "
                                     f"{interpreter['executable']} (libpython: {interpreter['library'] or 'none'}), "
                                     f"else python3 on PATH.\n")
        shutil.move(rewritten, fmu)
    return None
