"""The compiled kernels RotaryVaneCompressor.fmu ships (issue 9 item 5; kernels/compile_cache.py "Shipped kernels",
fmu_src/ship_kernels.py).

Two host processes (tests/fmu_helpers.py) run the FMU with every pressure model and integrator, each instance from
a new unpack folder, with fresh cache folders (ROTARY_VANE_CACHE_DIR, XDG_CACHE_HOME, NUMBA_CACHE_DIR), counting
numba's compilations (its "numba:compile" events): the FMU as built (the shipped kernels) and the same FMU with
the numba version in its stamp changed (the fallback: compiled here, as without shipped kernels). What is checked:
the shipped path compiles nothing and writes no kernel into any cache folder; the fallback compiles, logs why with
fmi2OK and the versions, and caches its kernels; both give bit-identical outputs at every step. The stamp's
checks (unreadable or incomplete stamp, another environment, sources or CPU) are tested on stamps written here.
"""
from __future__ import annotations

import importlib.util
import json
import sys
import zipfile
from pathlib import Path
from string import Template

import numba
import pytest

import fmu_helpers as H
from rotary_vane.kernels import compile_cache

STAMP_MEMBER = "/compiled_kernels/stamp.json"
RUNS = """
from numba.core import event
import fmu_helpers as H
rows, messages = {}, []
with event.install_recorder("numba:compile") as recorder:
    for pressure_model in ("polytropic", "ideal_gas_table", "real_gas"):
        for integrator in ("dopri5", "abm4"):
            host = H.Host($fmu)                     # unpacked into a new temporary folder
            status = host.initialize(**{**H.OPERATING_POINT, "pressure_model": pressure_model, "integrator": integrator})
            assert status == H.OK, host.messages()
            rows[f"{pressure_model} {integrator}"] = host.run(0.0, 1e-3, 45)      # past the first revolution
            messages.append(host.messages())
            host.close()
compiled = sorted({e.data["dispatcher"].py_func.__qualname__ for _, e in recorder.buffer if e.is_start})
H.emit({"rows": rows, "messages": messages, "compiled": compiled})
"""


def stamp_of(fmu: Path) -> dict:
    with zipfile.ZipFile(fmu) as archive:
        return json.loads(archive.read(next(n for n in archive.namelist() if n.endswith(STAMP_MEMBER))))


def run_fresh(fmu: Path, folder: Path) -> dict:
    """RUNS in a host whose cache folders are new and empty; the result and the files the caches hold after it."""
    caches = {name: folder / name for name in ("rotary_vane_cache", "xdg_cache", "numba_cache_dir")}
    env = H.host_environment(**{H.CACHE_ENVIRONMENT_VARIABLE: str(caches["rotary_vane_cache"])},
                             XDG_CACHE_HOME=str(caches["xdg_cache"]), NUMBA_CACHE_DIR=str(caches["numba_cache_dir"]))
    result = H.run_host(Template(RUNS).substitute(fmu=repr(str(fmu))), env=env).check().result
    result["cached"] = {name: sorted(H.cache_listing(path)) if path.exists() else [] for name, path in caches.items()}
    return result


@pytest.fixture(scope="module")
def shipped(fmu, tmp_path_factory) -> dict:
    return run_fresh(fmu, tmp_path_factory.mktemp("shipped"))


@pytest.fixture(scope="module")
def fallback(fmu, tmp_path_factory) -> dict:
    """The FMU with another numba version in its stamp, run with empty caches."""
    folder = tmp_path_factory.mktemp("fallback")
    tampered = folder / fmu.name
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(tampered, "w", zipfile.ZIP_DEFLATED) as target:
        for member in source.infolist():
            data = source.read(member)
            if member.filename.endswith(STAMP_MEMBER):
                data = json.dumps({**json.loads(data), "numba": "0.0.0"}).encode()
            target.writestr(member, data)
    return run_fresh(tampered, folder)


def test_an_fmu_on_a_machine_with_an_empty_cache_runs_the_kernels_it_ships(shipped):
    assert shipped["compiled"] == [], f"numba compiled {shipped['compiled']}"
    assert shipped["messages"] == [[]] * 6, shipped["messages"]
    # nothing is written: neither kernels nor the default fluid's tables and operating point, which it ships too
    assert shipped["cached"]["rotary_vane_cache"] == [], shipped["cached"]["rotary_vane_cache"]
    assert shipped["cached"]["xdg_cache"] == shipped["cached"]["numba_cache_dir"] == []


def test_the_fmu_ships_the_default_fluid_data_and_a_changed_key_builds_its_own(fmu, tmp_path):
    """The shipped fluid-wide property and nozzle tables of R134a, their range file and the default operating
    point are named by their keys (thermo.disk_cache): a run at another suction temperature, inside the fluid's
    range, reads the shipped tables and builds and caches only its own operating point."""
    with zipfile.ZipFile(fmu) as archive:
        shipped = sorted(n.rsplit("/", 1)[1] for n in archive.namelist() if "/shipped_data/" in n)
    assert len(shipped) == 4 and any("operating-point" in n for n in shipped) and \
        any(n.startswith("nozzle-R134a") for n in shipped) and any(n.endswith(".range.json") for n in shipped), shipped
    env = H.host_environment(**{H.CACHE_ENVIRONMENT_VARIABLE: str(tmp_path / "cache")})
    H.run_host(f"""
import fmu_helpers as H
host = H.Host({str(fmu)!r})
assert host.initialize(suction_temperature=288.15) == H.OK, host.messages()
host.run(0.0, 1e-3, 5)
H.emit({{}})
""", env=env).check()
    built = sorted(path.name for path in (tmp_path / "cache" / "properties").iterdir())
    assert len(built) == 1 and "operating-point" in built[0] and not set(built) & set(shipped), (built, shipped)


def test_the_fmu_ships_the_bytecode_of_every_module_checked_by_the_hash_of_its_source(fmu):
    """Each Python module in the FMU's resources has its bytecode beside it, in the form this Python's import
    system uses whatever the unpacked files' modification times (PEP 552: this Python's magic number, flags 0b11 =
    hash-based and checked, the hash of the source shipped with it), so a first run does not compile the bundle."""
    with zipfile.ZipFile(fmu) as archive:
        names = set(archive.namelist())
        sources = [name for name in names if name.startswith("resources/") and name.endswith(".py")]
        assert len(sources) > 50, sources
        for name in sources:
            folder, module = name.rsplit("/", 1)
            cached = f"{folder}/__pycache__/{module[:-3]}.{sys.implementation.cache_tag}.pyc"
            assert cached in names, name
            header = archive.read(cached)[:16]
            assert header[:4] == importlib.util.MAGIC_NUMBER, name
            assert int.from_bytes(header[4:8], "little") == 0b11, name
            assert header[8:16] == importlib.util.source_hash(archive.read(name)), name


@pytest.mark.slow
def test_kernels_stamped_for_another_numba_are_not_used_and_the_fmu_says_why(fallback):
    assert "run" in fallback["compiled"], fallback["compiled"]
    for messages in fallback["messages"]:              # one fmi2OK message per instance, at initialization
        assert len(messages) == 1, messages
        status, _, text = messages[0]
        assert status == H.OK
        assert (f"the kernels compiled into this FMU are not used: they were compiled for another environment "
                f"(numba 0.0.0 there, {numba.__version__} here)") in text, text
    assert any(name.endswith(".nbi") for name in fallback["cached"]["rotary_vane_cache"])


@pytest.mark.slow
def test_shipped_and_locally_compiled_kernels_give_bit_identical_results(shipped, fallback):
    assert list(shipped["rows"]) == list(fallback["rows"]) and len(shipped["rows"]) == 6
    for run, rows in shipped["rows"].items():       # floats round-trip exactly through the JSON text
        assert json.dumps(rows) == json.dumps(fallback["rows"][run]), run


def test_the_stamp_names_this_environment_and_a_build_without_kernels_ships_none(fmu, tmp_path):
    stamp = stamp_of(fmu)
    with zipfile.ZipFile(fmu) as archive:
        bundle = next(n for n in archive.namelist() if n.endswith(STAMP_MEMBER)).split("/")[1]
        shipped = [n.split("/compiled_kernels/")[1] for n in archive.namelist() if "/compiled_kernels/" in n]
        archive.extractall(tmp_path / "unpacked", [n for n in archive.namelist()
                                                  if n.startswith(f"resources/{bundle}/") and n.endswith(".py")])
    sources = compile_cache.source_hash(tmp_path / "unpacked" / "resources" / bundle)
    assert {name: stamp[name] for name in ("numba", "llvmlite", "python", "platform", "sources")} == \
        compile_cache.environment_stamp(tmp_path, sources)
    cpu, requires = compile_cache.portable_cpu(stamp["platform"])
    assert (stamp["cpu"], stamp["cpu_features"], stamp["cpu_requires"]) == (cpu, "", list(requires))
    for kernel in ("mechanics/loop/integrators.run-", "mechanics/loop/integrators.evaluate_state-"):   # loop entries
        assert [n for n in shipped if n.startswith(kernel) and n.endswith(".nbi")], shipped
    without = H.build_fmu(tmp_path / "without", options=["--no-kernels"])
    with zipfile.ZipFile(without) as archive:
        assert not any("/compiled_kernels/" in name for name in archive.namelist())
        assert "first run on a machine compiles the numerical kernels" in archive.read(
            "documentation/index.html").decode()


# the stamp's checks, on stamps written here -------------------------------------------------------------------
DIGEST = "ab" * 32


def write_stamp(project: Path, **changes) -> None:
    cpu, requires = compile_cache.portable_cpu(compile_cache.environment_stamp(project, DIGEST)["platform"])
    stamp = {**compile_cache.environment_stamp(project, DIGEST), "cpu": cpu, "cpu_features": "",
             "cpu_requires": list(requires), **changes}
    folder = project / compile_cache.SHIPPED_FOLDER
    folder.mkdir(exist_ok=True)
    (folder / compile_cache.STAMP_FILE).write_text(json.dumps({k: v for k, v in stamp.items() if v is not None}))


def test_a_stamp_of_this_environment_is_used_under_its_cpu(tmp_path):
    write_stamp(tmp_path)
    stamp = json.loads((tmp_path / compile_cache.SHIPPED_FOLDER / compile_cache.STAMP_FILE).read_text())
    assert compile_cache.shipped_kernels(tmp_path, DIGEST) == ((stamp["platform"], stamp["cpu"], ""), None)


def test_sources_without_shipped_kernels_have_nothing_to_refuse(tmp_path):
    assert compile_cache.shipped_kernels(tmp_path, DIGEST) == (None, None)


@pytest.mark.parametrize("changes, reason", [
    (dict(sources="cd" * 32), "compiled for another environment (sources cdcdcdcdcdcd there, abababababab here)"),
    (dict(python="cpython-30"), "python cpython-30 there, "),
    (dict(platform="riscv64-unknown-linux-gnu", llvmlite="0.1"), "llvmlite 0.1 there, "),
    (dict(cpu="future-cpu", cpu_requires=["sse4.2", "no-such-feature"]),
     "compiled for the CPU future-cpu, whose no-such-feature this CPU lacks"),
    (dict(cpu_requires=None), "stamp.json is unusable (ValueError: allowed a JSON object of numba, "),
    (dict(cpu_requires="sse4.2"), "stamp.json is unusable (ValueError: allowed text values and a list of CPU"),
])
def test_a_stamp_that_does_not_fit_is_refused_with_the_reason(tmp_path, changes, reason):
    write_stamp(tmp_path, **changes)
    target, refusal = compile_cache.shipped_kernels(tmp_path, DIGEST)
    assert target is None and reason in refusal, refusal


def test_a_cpu_whose_features_llvm_cannot_tell_uses_only_generic_kernels(tmp_path, monkeypatch):
    def unknown():
        raise RuntimeError("no feature map")
    monkeypatch.setattr(compile_cache.llvm, "get_host_cpu_features", unknown)
    write_stamp(tmp_path, cpu_requires=["sse4.2"])
    assert compile_cache.shipped_kernels(tmp_path, DIGEST)[1] == (
        "they need the CPU features sse4.2, and this CPU's are unknown (no feature map)")
    write_stamp(tmp_path, cpu="generic", cpu_requires=[])
    assert compile_cache.shipped_kernels(tmp_path, DIGEST)[0][1:] == ("generic", "")


def test_an_unreadable_stamp_is_refused_with_the_reason(tmp_path):
    (tmp_path / compile_cache.SHIPPED_FOLDER).mkdir()
    assert "stamp.json is unusable (FileNotFoundError" in compile_cache.shipped_kernels(tmp_path, DIGEST)[1]
    (tmp_path / compile_cache.SHIPPED_FOLDER / compile_cache.STAMP_FILE).write_text("{not json")
    assert "stamp.json is unusable (JSONDecodeError" in compile_cache.shipped_kernels(tmp_path, DIGEST)[1]


# the bundle's folder as hosts spell it, and two FMUs of this project in one process ----------------------------
RESOURCE_FORMS = """
import os, pathlib, sys
from ctypes import byref
from numba.core import event
import fmu_helpers as H
from fmpy import calloc, free, read_model_description
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                       fmi2CallbackLoggerTYPE, fmi2CoSimulation)
from fmpy.logging import addLoggerProxy
messages = []
logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, text: messages.append([status, text.decode()]))
callbacks = fmi2CallbackFunctions()
callbacks.logger = logger
callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
addLoggerProxy(byref(callbacks))
folder = $folder
description = read_model_description(folder)
fmu = FMU2Slave(guid=description.guid, unzipDirectory=folder, modelIdentifier=H.MODEL, instanceName="compressor")
fmu.callbacks = callbacks
with event.install_recorder("numba:compile") as recorder:
    fmu.component = fmu.fmi2Instantiate(b"compressor", fmi2CoSimulation, description.guid.encode(), $uri.encode(),
                                        byref(callbacks), 0, 1)
    assert fmu.component, messages
    fmu.setupExperiment(startTime=0.0)
    for name, value in H.OPERATING_POINT.items():
        variable = next(v for v in description.modelVariables if v.name == name)
        if variable.type == "Real":
            fmu.setReal([variable.valueReference], [value])
        else:
            fmu.setString([variable.valueReference], [value])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    for k in range(45):
        fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
compiled = sorted({e.data["dispatcher"].py_func.__qualname__ for _, e in recorder.buffer if e.is_start})
bundle = next(name for name in sys.modules if name.startswith("rotary_vane_") and "." not in name)
H.emit({"compiled": compiled, "messages": messages, "bundle_file": sys.modules[bundle].__file__})
fmu.terminate()
fmu.freeInstance()
"""


def fresh_caches(folder: Path) -> tuple[dict, dict]:
    caches = {name: folder / name for name in ("rotary_vane_cache", "xdg_cache", "numba_cache_dir")}
    env = H.host_environment(**{H.CACHE_ENVIRONMENT_VARIABLE: str(caches["rotary_vane_cache"])},
                             XDG_CACHE_HOME=str(caches["xdg_cache"]), NUMBA_CACHE_DIR=str(caches["numba_cache_dir"]))
    return caches, env


def files_in(*folders: Path) -> set[str]:
    """Every file under `folders` but Python's own bytecode (*.pyc; numba's cache files are *.nbi and *.nbc)."""
    return {str(path) for folder in folders if folder.exists() for path in folder.rglob("*")
            if path.is_file() and path.suffix != ".pyc"}


@pytest.mark.parametrize("form", ["file:////abs (Ecos)", "a symbolic link to the folder"])
def test_the_shipped_kernels_are_found_whatever_path_the_host_gives(fmu, tmp_path, form):
    """kernels/compile_cache.py compares the bundle's folder with realpath: a resource location of the form
    `file:////tmp/...` (the path `//tmp/...`) or a folder reached through a symbolic link loads the shipped kernels:
    nothing is compiled, nothing written into any cache or the unpack folder, no miss is logged."""
    unpacked = tmp_path / "unpacked"
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(unpacked)
    if form.startswith("file"):          # as Ecos's FMI loader hands it over: "file:///" + an absolute path
        folder, uri = str(unpacked), f"file:///{unpacked}/resources"
    else:
        (tmp_path / "link").symlink_to(unpacked, target_is_directory=True)
        folder, uri = str(tmp_path / "link"), (tmp_path / "link" / "resources").as_uri()
    caches, env = fresh_caches(tmp_path)
    unpacked_files = files_in(unpacked)
    out = H.run_host(Template(RESOURCE_FORMS).substitute(folder=repr(folder), uri=repr(uri)), env=env).check().result
    assert out["compiled"] == [], out
    assert out["messages"] == [], out["messages"]
    assert files_in(unpacked, *caches.values()) == unpacked_files, "files were written"


TWO_FMUS = """
import shutil, sys
import fmu_helpers as H
def start(model, host):
    values = H.OPERATING_POINT if model == H.MODEL else {"load_torque": 2.5}
    assert host.initialize(**values) == H.OK, host.messages()
    host.run(0.0, 1e-3, 5)

first = H.Host($first, unzipdir=$first_folder)
start($first_model, first)
shutil.rmtree($first_folder)                       # as fmpy's simulate_fmu does after its run
second = H.Host($second, unzipdir=$second_folder)
start($second_model, second)
hosts = {$first_model: first, $second_model: second}
for host in hosts.values():
    host.run(5e-3, 1e-3, 5)
bundles = {name: module.__file__ for name, module in sys.modules.items()
           if name.startswith("rotary_vane_") and getattr(module, "__file__", None)}
H.emit({"bundles": bundles, "messages": {model: host.messages() for model, host in hosts.items()}})
for host in hosts.values():
    host.close()
"""


def bundle_of(module: str) -> str:
    """The private package a module of an FMU belongs to (its entry module: <package>_entry)."""
    return module.split(".")[0].removesuffix("_entry")


@pytest.mark.parametrize("order", [("DriveMotor", H.MODEL), (H.MODEL, "DriveMotor")])
def test_two_fmus_of_this_project_in_one_process_each_import_their_own_bundle(built_fmus, tmp_path, order):
    """The motor and the compressor in one host process, the first one instantiated and run, its folder deleted
    (as fmpy's simulate_fmu does after its run), then the second one instantiated; both run on. Each FMU's modules
    come from its own folder (its own private package name, fmu_src/build.py), and nothing is written anywhere
    (the deleted folder stays deleted: numba does not re-create it to cache kernels there)."""
    folders = {model: tmp_path / model for model in order}
    for model, folder in folders.items():
        with zipfile.ZipFile(built_fmus / f"{model}.fmu") as archive:
            archive.extractall(folder)
    caches, env = fresh_caches(tmp_path)
    first, second = order
    kept = files_in(folders[second])            # the first folder is deleted
    out = H.run_host(Template(TWO_FMUS).substitute(
        first=repr(str(built_fmus / f"{first}.fmu")), first_folder=repr(str(folders[first])),
        second=repr(str(built_fmus / f"{second}.fmu")), second_folder=repr(str(folders[second])),
        first_model=repr(first), second_model=repr(second)), env=env).check().result
    assert out["messages"] == {first: [], second: []}, out["messages"]
    for model, folder in folders.items():
        own = {name: path for name, path in out["bundles"].items() if bundle_of(name).endswith(f"_{model}")}
        assert own and all(path.startswith(str(folder) + "/") for path in own.values()), (model, own)
    assert all(bundle_of(name).endswith(order) for name in out["bundles"]), sorted(out["bundles"])
    assert not folders[first].exists(), "the deleted folder of the first FMU was re-created"
    assert files_in(*folders.values(), *caches.values()) == kept, "files were written"
