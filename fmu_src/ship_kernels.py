"""Compile the kernels an FMU run needs for the FMU to ship (kernels.compile_cache, "Shipped kernels").

fmu_src.build runs `python -m <bundle>.fmu_src.ship_kernels` from the bundled package, twice, in separate processes
with a temporary ROTARY_VANE_CACHE_DIR, none of the builder's NUMBA_* settings and numba's portable CPU
(NUMBA_CPU_NAME = compile_cache.portable_cpu, NUMBA_CPU_FEATURES=""). Each run drives the compressor slave through
its FMI callbacks for every pressure model with every integrator (initialization, steps past the first revolution,
every output), or with `--model RefrigerationLoop` the loop slave (initialization, steps with a running compressor's
exchange, every output, a state restored), which asks numba for every kernel and signature an FMU run calls from
Python:

* the first run compiles them into the cache folder;
* the second, `--into FOLDER`, must load all of them from there (it fails naming any kernel it had to compile),
  then copies the files of the kernels it loaded into FOLDER, laid out as the cache folder, and writes the stamp.
  Only the kernels called from Python are shipped: a loaded kernel contains the code of the kernels it calls.
  It also copies the fluid data its runs built from CoolProp (the default fluid's property and nozzle tables and
  operating point, thermo.disk_cache) into `shipped_data/` beside FOLDER, which a first run reads instead of
  building them.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

from numba.core import event, registry
from numba.core.dispatcher import Dispatcher
from pythonfmu.enums import Fmi2Status
from pythonfmu.variables import Integer, Real

from ..mechanics.parameters import INTEGRATORS, PRESSURE_MODELS
from ..kernels import compile_cache
from ..thermo import disk_cache

from .compressor import CompressorSlave
from .refrigeration_loop import LoopSlave
from .slave import INITIALIZED

PROJECT_DIR = Path(__file__).resolve().parent.parent
STEP_SIZE = 1e-3                   # s
STEPS = 50                         # past the first completed revolution at 1500 rpm (40 ms)


def run_fmu(pressure_model: str, integrator: str) -> None:
    """One FMU run through the slave's FMI callbacks; raises RuntimeError with the slave's messages if refused."""
    slave = CompressorSlave(instance_name="ship_kernels")
    for name, value in {**CompressorSlave.example_start_values, "pressure_model": pressure_model,
                        "integrator": integrator}.items():
        setattr(slave, name, value)
    slave.setup_experiment(0.0)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    stepped = slave.phase == INITIALIZED and all(slave.do_step(k * STEP_SIZE, STEP_SIZE) for k in range(STEPS // 2))
    if pressure_model == "real_gas":            # a moved boundary (its figures' references: mechanics.gas.boundary)
        slave.discharge_pressure *= 1.01
    stepped = stepped and all(slave.do_step(k * STEP_SIZE, STEP_SIZE) for k in range(STEPS // 2, STEPS))
    slave.get_real([reference for reference, variable in slave.vars.items() if isinstance(variable, Real)])
    slave.get_integer([reference for reference, variable in slave.vars.items() if isinstance(variable, Integer)])
    refusals = [entry.msg for entry in slave.log_queue if entry.status not in (Fmi2Status.ok, Fmi2Status.warning)]
    if not stepped or refusals:
        raise RuntimeError(f"the FMU run with pressure_model={pressure_model!r}, integrator={integrator!r} did not "
                           f"complete: {refusals}")


def run_loop() -> None:
    """One run of the refrigeration loop slave through its FMI callbacks (module docstring); RuntimeError with its
    messages if refused."""
    slave = LoopSlave(instance_name="ship_kernels")
    slave.setup_experiment(0.0)
    slave.enter_initialization_mode()
    slave.exit_initialization_mode()
    stepped = slave.phase == INITIALIZED
    for k in range(STEPS):
        slave.drawn_mass += 1e-5
        slave.drawn_enthalpy += 1e-5 * slave.model.outputs["suction_enthalpy"]
        slave.delivered_mass += 1e-5
        slave.delivered_enthalpy += 1e-5 * 440e3
        stepped = stepped and slave.do_step(k * STEP_SIZE, STEP_SIZE)
    slave._set_fmu_state(slave._fmu_state_from_bytes(slave._fmu_state_to_bytes(slave._get_fmu_state())))
    slave.get_real([reference for reference, variable in slave.vars.items() if isinstance(variable, Real)])
    refusals = [entry.msg for entry in slave.log_queue if entry.status not in (Fmi2Status.ok, Fmi2Status.warning)]
    if not stepped or refusals:
        raise RuntimeError(f"the refrigeration loop run did not complete: {refusals}")


def bundle_kernels() -> list[Dispatcher]:
    """Every kernel of the bundled packages (those of this module's top-level package)."""
    prefix = __package__.split(".")[0] + "."          # run with -m, __name__ is "__main__"
    kernels = {id(value): value for name, module in list(sys.modules.items()) if name.startswith(prefix)
               for value in vars(module).values()
               if isinstance(value, Dispatcher) and isinstance(value._cache, compile_cache.KernelCache)}
    return list(kernels.values())


def ship(into: Path) -> None:
    """Copy the files of the kernels loaded from the cache into `into` and write the stamp (see the module
    docstring)."""
    digest = compile_cache.source_hash(PROJECT_DIR)
    folder = compile_cache.cache_folder(PROJECT_DIR, __package__.split(".")[0], digest)
    loaded = [kernel for kernel in bundle_kernels() if kernel.stats.cache_hits]
    if not loaded:
        raise RuntimeError(f"no kernel of {__package__.split('.')[0]} was loaded from the cache {folder}")
    into.mkdir(parents=True)
    for kernel in loaded:
        for path in kernel._cache.files():
            target = into / path.relative_to(folder)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
    stamp = compile_cache.environment_stamp(PROJECT_DIR, digest)
    cpu, requires = compile_cache.portable_cpu(stamp["platform"])
    stamp.update(cpu=cpu, cpu_features="", cpu_requires=list(requires))
    (into / compile_cache.STAMP_FILE).write_text(json.dumps(stamp, indent=1) + "\n", encoding="utf-8")
    data = into.parent / disk_cache.SHIPPED_DATA.name
    data.mkdir()
    for path in disk_cache.property_cache_dir().iterdir():
        if path.is_file():
            shutil.copyfile(path, data / path.name)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--into", type=Path, help="second run: ship the kernels loaded from the cache into this "
                                                  "new folder")
    parser.add_argument("--model", choices=("RotaryVaneCompressor", "RefrigerationLoop"),
                        default="RotaryVaneCompressor", help="the FMU whose runs ask for the kernels")
    args = parser.parse_args(argv)
    if args.into is not None and args.into.exists():
        parser.error(f"--into {args.into}: already exists")
    triple = compile_cache.environment_stamp(PROJECT_DIR)["platform"]
    target = (triple, compile_cache.portable_cpu(triple)[0], "")
    compiles_for = registry.cpu_target.target_context.codegen().magic_tuple()
    if compiles_for != target:
        parser.error(f"numba compiles for {compiles_for}, not for {target}: run with NUMBA_CPU_NAME={target[1]} "
                     f"NUMBA_CPU_FEATURES=''")
    with event.install_recorder("numba:compile") as recorder:
        if args.model == "RefrigerationLoop":
            run_loop()
        else:
            for pressure_model in PRESSURE_MODELS:
                for integrator in INTEGRATORS:
                    run_fmu(pressure_model, integrator)
    if args.into is not None:
        compiled = sorted({e.data["dispatcher"].py_func.__qualname__ for _, e in recorder.buffer if e.is_start})
        if compiled:
            print(f"the second run compiled {', '.join(compiled)}: not in the cache the first run filled (a "
                  f"kernel numba cannot cache, or runs that ask for other kernels each time)", file=sys.stderr)
            return 1
        ship(args.into)
    return 0


if __name__ == "__main__":
    sys.exit(main())
