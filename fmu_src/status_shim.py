"""Put the FMI status shim (fmu_src/c/fmi2_status_shim.c) in front of pythonfmu's binary in a built FMU.

pythonfmu's library can return only fmi2OK, fmi2Discard (doStep) or fmi2Fatal (any Python exception, after which
the instance is gone). The shim becomes `binaries/<platform>/<model>.so`, loads pythonfmu's library renamed to
`<model>_pythonfmu.so` beside it, and returns for each call the worst status the Python slave logged during that
call, so the slave can answer fmi2Warning or fmi2Error as the standard prescribes (fmu_src/slave.py).

It is compiled with the C compiler of the build machine (`$CC`, else `cc` or `gcc`) for linux64 only, once per FMU
(the state tag "<model>/<build fingerprint>" it checks is compiled in); the FMI headers come with fmpy. Without a
compiler, or for another platform's binary, the FMU keeps pythonfmu's binary and the build says so
(`DEGRADED`): the model then runs, but it cannot answer fmi2Error or fmi2Warning.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

SOURCE = Path(__file__).resolve().parent / "c" / "fmi2_status_shim.c"
PLATFORM = "linux64"
MARKER = "resources/fmi2_status_shim.txt"         # present in an FMU whose binary is the shim
DEGRADED = ("it cannot answer fmi2Error or fmi2Warning: a bad parameter, a call in the wrong state, a write to an "
            "output or to a fixed parameter, an unknown value reference or state bytes of another build are "
            "answered with fmi2OK and an error message (a step then with fmi2Discard), there is no error state, "
            "and a string parameter that is not UTF-8 or a null pointer is fmi2Fatal")


def fmi_headers() -> Path:
    """The folder of fmi2Functions.h: fmpy ships the FMI 2.0 headers (found, not imported: the FMU bundles this
    module, and its requirements list what the bundle imports, fmu_src/requirements.py)."""
    fmpy = importlib.util.find_spec("fmpy")
    if fmpy is None or not fmpy.submodule_search_locations:
        raise FileNotFoundError("fmpy is not installed: it provides the FMI 2.0 headers the shim is compiled with")
    return Path(fmpy.submodule_search_locations[0]) / "c-code"


def compile_shim(destination: Path, state_tag: str) -> str | None:
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
    command = [compiler, "-std=c99", "-O2", "-Wall", "-Wextra", "-fPIC", "-shared", f"-I{headers}",
               f'-DSTATE_TAG="{state_tag}"', "-o", str(destination), str(SOURCE), "-ldl"]
    try:
        result = subprocess.run(command, capture_output=True, text=True)
    except OSError as error:
        return f"the C compiler {compiler!r} cannot be run: {error}"
    if result.returncode != 0:
        return f"{' '.join(command)} failed:\n{result.stderr}"
    return None


def install(fmu: Path, model: str, state_tag: str) -> str | None:
    """Rewrite the FMU so that its linux64 binary is the shim; None on success, else why not (FMU unchanged).
    `state_tag` is fmu_src.state_format.tag_of(model, build fingerprint)."""
    inner_name = f"binaries/{PLATFORM}/{model}.so"
    with zipfile.ZipFile(fmu) as archive:
        if inner_name not in archive.namelist():
            return f"the FMU has no {inner_name}"
        entries = [(info, archive.read(info)) for info in archive.infolist()]
    with tempfile.TemporaryDirectory(prefix="rvc_shim_") as temporary:
        shim = Path(temporary) / "shim.so"
        reason = compile_shim(shim, state_tag)
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
            archive.writestr(MARKER, f"binaries/{PLATFORM}/{model}.so is the FMI status shim of "
                                     f"rotary_vane.fmu_src.status_shim in front of {model}_pythonfmu.so\n")
        shutil.move(rewritten, fmu)
    return None
