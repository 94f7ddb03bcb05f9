"""First-step latency of RotaryVaneCompressor.fmu in each host of README "Running the FMU in other hosts".

`python benchmarks/bench_hosts.py [--repeats 3] [--fmu-dir build/fmu]` (needs the test extra: libcosimpy, ecospy,
tbb). Each run is a fresh process, with the FMU's defaults (real gas) at 1500 rpm and 1 ms steps:
  - fmpy, libcosim, Ecos in-process, proxyfmu (through ecospy): instantiation + initialization + the first step,
    timed inside the host process;
  - the project's C host (tests/c_host/fmu_host.c, compiled here): from the host's start to the end of its first
    fmi2DoStep, as it prints it;
  - the `ecos` command line: the whole process for 10 steps (it cannot report a first step; with fewer than 10
    steps it divides by zero).
The C host and the `ecos` command line run from an environment with nothing set for the FMU (no LD_PRELOAD,
PYTHONHOME or PYTHONPATH): the FMU's binary loads its Python itself. Prints the median and the spread per host.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
import zipfile
from pathlib import Path

from report import heading, table

from rotary_vane.examples import ecos_host
from rotary_vane.examples.fmu_harness import ensure_fmus

PROJECT_DIR = Path(__file__).resolve().parent.parent
TESTS_DIR = PROJECT_DIR / "tests"
MODEL = "RotaryVaneCompressor"
REPORT = 'print("LATENCY", time.perf_counter() - start)\n'

FMPY = """
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave
fmu = {fmu!r}
description = read_model_description(fmu)
folder = extract(fmu)
start = time.perf_counter()
slave = FMU2Slave(guid=description.guid, unzipDirectory=folder, modelIdentifier={model!r}, instanceName="c")
slave.instantiate()
slave.setupExperiment(startTime=0.0)
slave.enterInitializationMode()
slave.exitInitializationMode()
slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
"""
LIBCOSIM = """
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimSlave import CosimLocalSlave
start = time.perf_counter()
execution = CosimExecution.from_step_size(step_size=int(1e6))
execution.add_local_slave(CosimLocalSlave(fmu_path={fmu!r}, instance_name="compressor"))
assert execution.simulate_until(int(1e6))
"""
ECOS = """
from rotary_vane.examples import ecos_host
ecospy = ecos_host.load_ecospy()
start = time.perf_counter()
structure = ecospy.EcosSimulationStructure()
structure.add_model("compressor", {location!r})
structure.add_parameter_set("start", {{"compressor::shaft_speed": 1500.0}})
simulation = ecospy.EcosSimulation(structure=structure, step_size=1e-3)
assert simulation.init(parameter_set="start")
simulation.step(1)
assert simulation.get_real("compressor::shaft_work") > 0.0
"""


def clean_environment() -> dict[str, str]:
    """PATH and HOME only (and the tbb folder for Ecos itself): nothing that points the FMU at a Python."""
    return {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/root")}


def python_host(body: str) -> float:
    """Seconds the host script reports (from its `start`, before instantiation, to the end of the first step)."""
    source = "import time\n" + textwrap.dedent(body) + REPORT
    with tempfile.TemporaryDirectory(prefix="rvc_python_host_") as scratch:   # where fmpy unpacks (40 MB a run)
        done = subprocess.run([sys.executable, "-c", source], capture_output=True, text=True, timeout=600,
                              env=dict(os.environ, TMPDIR=scratch))
    match = re.search(r"LATENCY (\S+)", done.stdout)
    if done.returncode != 0 or not match:
        raise RuntimeError(f"host failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return float(match.group(1))


def c_host(fmu: Path, work: Path) -> float:
    binary = work / "fmu_host"
    if not binary.exists():
        subprocess.run(["cc", "-O2", "-o", str(binary), str(TESTS_DIR / "c_host" / "fmu_host.c"), "-ldl"], check=True)
    folder = Path(tempfile.mkdtemp(dir=work))
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
        description = archive.read("modelDescription.xml").decode()
    guid = re.search(r'guid="([^"]+)"', description).group(1)
    references = {name: re.search(rf'name="{name}"\s+valueReference="(\d+)"', description).group(1)
                  for name in ("shaft_speed", "shaft_torque_mean", "input_power")}
    done = subprocess.run([str(binary), str(folder), MODEL, guid, references["shaft_speed"],
                           references["shaft_torque_mean"], references["input_power"], "1500", "1", "0.001",
                           "--quick-exit"], capture_output=True, text=True, env=clean_environment(), timeout=600)
    match = re.search(r"FIRST_STEP_SECONDS (\S+)", done.stdout)
    shutil.rmtree(folder)
    if not match:
        raise RuntimeError(f"C host failed ({done.returncode}):\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
    return float(match.group(1))


def ecos_command_line(fmu: Path, work: Path) -> float:
    ecos_host.make_executable()
    folder = Path(tempfile.mkdtemp(dir=work))
    shutil.copy(fmu, folder)
    env = ecos_host.command_environment({**clean_environment(), "TMPDIR": str(folder)})
    start = time.perf_counter()
    done = subprocess.run([str(ecos_host.binaries() / "ecos"), "simulate", "--path", str(folder / fmu.name),
                           "--stepSize", "0.001", "--stopTime", "0.01"], cwd=folder, env=env, capture_output=True,
                          text=True, timeout=600)
    elapsed = time.perf_counter() - start
    shutil.rmtree(folder)
    if done.returncode != 0:
        raise RuntimeError(f"ecos failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return elapsed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--fmu-dir", type=Path, default=PROJECT_DIR / "build" / "fmu")
    args = parser.parse_args(argv)
    fmu = ensure_fmus(args.fmu_dir) / f"{MODEL}.fmu"
    hosts = {
        "fmpy (FMU2Slave)": lambda work: python_host(FMPY.format(fmu=str(fmu), model=MODEL)),
        "libcosim (libcosimpy)": lambda work: python_host(LIBCOSIM.format(fmu=str(fmu))),
        "Ecos in-process (ecospy)": lambda work: python_host(ECOS.format(location=str(fmu))),
        "proxyfmu (through ecospy)": lambda work: python_host(
            ECOS.format(location="proxyfmu://localhost?file=" + str(fmu))),
        "C host, nothing set (from its start)": lambda work: c_host(fmu, work),
        "ecos command line, nothing set (whole run, 10 steps)": lambda work: ecos_command_line(fmu, work),
    }
    heading(f"First-step latency, median of {args.repeats} fresh processes [s]")
    rows = []
    with tempfile.TemporaryDirectory(prefix="rvc_bench_hosts_") as temporary:
        work = Path(temporary)
        for name, measure in hosts.items():
            times = [measure(work) for _ in range(args.repeats)]
            rows.append([name, f"{statistics.median(times):.2f}", f"{min(times):.2f}-{max(times):.2f}"])
            print(f"  {name}: {', '.join(f'{t:.2f}' for t in times)}", flush=True)
    print(table(["host", "median", "range"], rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
