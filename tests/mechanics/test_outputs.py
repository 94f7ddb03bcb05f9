"""Every output is declared once (mechanics.loop.outputs): the kernel's column layout, the FMU variables, the
periodic-map channels and the documentation tables all follow from the declarations, and every declared figure is
something the per-revolution summary defines."""
import dataclasses

from rotary_vane.mechanics.loop import outputs
from rotary_vane.mechanics.loop.outputs import (FIGURES, STEP_OUTPUTS, Figure, Output, fmu_outputs, index_layout,
                                                markdown_table)
from rotary_vane.mechanics.performance import WindowSummary
from rotary_vane.mechanics.contact.regions import REGION_COUNT, REGION_LABELS, REGIONS


def test_adding_an_output_is_one_declaration():
    """A new step output and a new figure, declared once, appear in the column layout (after the existing columns),
    in the FMU outputs with their unit and description, and in the output table of the docs."""
    step = Output("vane_spin_energy", "J", "rotational kinetic energy of the vane", fmu="vane_spin_energy")
    figure = Figure("spin_power", "W", "mean spin power", fmu="spin_power")
    declared = (*STEP_OUTPUTS, step)
    layout = index_layout(declared)
    assert layout.vane_spin_energy == outputs.OUTPUT_SIZE
    assert layout._fields[:-1] == index_layout()._fields
    made = {o.name: o for o in fmu_outputs(declared, (*FIGURES, figure))}
    assert (made["vane_spin_energy"].unit, made["vane_spin_energy"].source) == ("J", "vane_spin_energy")
    assert made["spin_power"].per == outputs.REVOLUTION and made["spin_power"].source == "spin_power"
    text = markdown_table(declared, (*FIGURES, figure))
    assert "`vane_spin_energy`" in text and "`spin_power`" in text


def test_per_region_outputs_expand_to_one_column_per_region():
    normal = next(o for o in STEP_OUTPUTS if o.name == "normal_force")
    assert normal.columns() == tuple(f"normal_force_{k}" for k in range(1, REGION_COUNT + 1))
    assert outputs.OUTPUT_NAMES.index("normal_force_1") == outputs.O.normal_force
    forces = [o for o in fmu_outputs() if o.source.startswith("normal_force_")]
    assert [o.name for o in forces] == [f"contact_force_{k}" for k in range(1, REGION_COUNT + 1)]
    assert [label for label, *_ in REGIONS] == list(REGION_LABELS)


def test_columns_and_fmu_names_are_unique():
    assert len(set(outputs.OUTPUT_NAMES)) == len(outputs.OUTPUT_NAMES)
    names = [o.name for o in fmu_outputs()]
    assert len(set(names)) == len(names)


def test_every_declared_figure_is_a_summary_attribute():
    fields = {f.name for f in dataclasses.fields(WindowSummary)}
    properties = {name for name, value in vars(WindowSummary).items() if isinstance(value, property)}
    assert {f.name for f in FIGURES} <= fields | properties


ADD_A_REGION = r'''
import sys, types
path = sys.argv[1]
source = open(path).read().replace(
    "REGION_COUNT = len(REGIONS)",
    'REGIONS = REGIONS + (Region("c9", "test corner", ROTOR, 7, FLOOR_CORNER, 1.0),)\nREGION_COUNT = len(REGIONS)')
module = types.ModuleType("rotary_vane.mechanics.contact.regions")
module.__file__ = path
exec(compile(source, path, "exec"), module.__dict__)
sys.modules[module.__name__] = module
from rotary_vane.mechanics import performance
from rotary_vane.mechanics.contact import modes
from rotary_vane.mechanics.loop import layout, outputs, windows
assert "normal_force_9" in outputs.OUTPUT_NAMES and "penetration_rate_9" in outputs.OUTPUT_NAMES
made = {o.name: o for o in outputs.fmu_outputs()}
assert made["contact_force_9"].source == "normal_force_9" and "region c9" in made["contact_force_9"].description
assert "`normal_force_1..9`" in outputs.markdown_table() and "c9 (slot wear)" in outputs.markdown_table()
assert layout.MEMORY_SIZE == layout.MEM_MODE + 3 and layout.MEM_MODE == layout.MEM_ONSET_VELOCITY + 8
assert modes.MODE_COUNT == 512 and windows.MASKS == 512 and modes.mode_label(1 << 8) == "c9"
assert 8 in performance.SLOT_REGIONS
print("ok")
'''


def test_adding_a_region_is_one_declaration():
    """docs/model.md §14.1: a ninth region declared in the table (a copy of mechanics/contact/regions.py with one more
    entry, loaded in a fresh interpreter) appears in the output columns, the FMU outputs, the docs table, the
    memory layout, the mode masks and the rotor-force group, with no other edit."""
    import subprocess
    import sys
    from pathlib import Path

    import rotary_vane.mechanics.contact.regions as regions
    result = subprocess.run([sys.executable, "-c", ADD_A_REGION, str(Path(regions.__file__))], capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip().endswith("ok")
