"""The study report: Markdown tables, each study's manifest, and report.md gathering every study's figures and tables.

Each study (examples/study_clearance.py, examples/study_lobes.py) writes its figures (PNG) and tables (Markdown
files holding one or more pipe tables) into `<out>/<study>/` and a `manifest.json` there that lists them in
reading order, each with a one-line explanation, plus the settings and wall time of the run. This script reads the
manifests found under `<out>/` and writes `<out>/report.md`: per study a heading, its settings, and every item
with its line of explanation (figures as image links relative to report.md, tables inlined). The studies call it
when they finish, so the report is always current; it can also be rebuilt alone:

    python examples/study_report.py                 # reads out/studies/*/manifest.json, writes out/studies/report.md
    python examples/study_report.py --out /tmp/st   # another studies folder
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

DEFAULT_OUT = Path("out/studies")
MANIFEST = "manifest.json"
REPORT = "report.md"
STUDY_ORDER = ("clearance", "lobes")          # report order; any other study folder follows alphabetically


# Markdown tables -------------------------------------------------------------------------------------------
def markdown_table(headers: list[str], rows: list[list[str]], title: str | None = None) -> str:
    """A GitHub pipe table of already formatted cells; the first column left-aligned, the others right-aligned.
    With `title`, a bold line above it. Cells must not contain '|'."""
    for row in rows:
        if len(row) != len(headers):
            raise ValueError(f"table row {row!r} has {len(row)} cells: allowed exactly {len(headers)} "
                             f"(one per header)")
    for cell in [*headers, *(cell for row in rows for cell in row)]:
        if "|" in cell:
            raise ValueError(f"table cell {cell!r} is invalid: allowed text without '|'")
    rule = [":---"] + ["---:"] * (len(headers) - 1)
    lines = [f"| {' | '.join(line)} |" for line in (headers, rule, *rows)]
    return (f"**{title}**\n\n" if title else "") + "\n".join(lines) + "\n"


# manifests -------------------------------------------------------------------------------------------------
def write_manifest(folder: Path, study: str, title: str, command: str, settings: str, items: list[dict],
                   timing: dict) -> Path:
    """Write `<folder>/manifest.json`: study name, title, the command that made it, a settings line, the timing
    figures {name: seconds} and the items [{"file": name in folder, "caption": one line}] in reading order."""
    for item in items:
        path = folder / item["file"]
        if not path.is_file():
            raise ValueError(f"manifest item 'file' = {item['file']!r} is invalid: allowed a file written to "
                             f"{folder}")
    manifest = dict(study=study, title=title, command=command, settings=settings, timing=timing, items=items)
    path = folder / MANIFEST
    path.write_text(json.dumps(manifest, indent=2) + "\n")
    return path


def read_manifests(root: Path) -> list[dict]:
    """The manifests of the study folders under `root`, in report order (STUDY_ORDER first)."""
    found = {path.parent.name: json.loads(path.read_text()) for path in sorted(root.glob(f"*/{MANIFEST}"))}
    order = [name for name in STUDY_ORDER if name in found] + sorted(set(found) - set(STUDY_ORDER))
    return [found[name] for name in order]


# report ----------------------------------------------------------------------------------------------------
def study_section(root: Path, manifest: dict) -> str:
    """One study's part of the report: heading, command, settings, timing, then each item with its caption."""
    folder = manifest["study"]
    timing = ", ".join(f"{name} {seconds:.1f} s" for name, seconds in manifest["timing"].items())
    parts = [f"## {manifest['title']}\n",
             f"Made by `{manifest['command']}`. {manifest['settings']} Wall time: {timing}.\n"]
    for number, item in enumerate(manifest["items"], start=1):
        path = root / folder / item["file"]
        parts.append(f"### {number}. {item['file']}\n\n{item['caption']}\n")
        if path.suffix == ".png":
            parts.append(f"![{item['file']}]({folder}/{item['file']})\n")
        elif path.suffix == ".md":
            parts.append(path.read_text())
        else:
            parts.append(f"Data: [{folder}/{item['file']}]({folder}/{item['file']})\n")
    return "\n".join(parts)


def write_report(root: Path) -> Path:
    """Gather every study's manifest under `root` into `root/report.md`."""
    manifests = read_manifests(root)
    if not manifests:
        raise ValueError(f"'--out' = {str(root)!r} holds no study results ({MANIFEST} in a sub-folder): run "
                         f"python examples/study_clearance.py and/or python examples/study_lobes.py with this --out")
    done = ", ".join(m["study"] for m in manifests)
    missing = [name for name in STUDY_ORDER if name not in {m["study"] for m in manifests}]
    intro = ("# Design studies of the single-vane rotary compressor\n\n"
             "After K.-M. Huang's thesis (docs/model.md §10-§11): every figure and table below was written by the study "
             f"scripts in `examples/` from runs of the library (`mechanics.Simulation`). Studies included: {done}."
             + (f" Not run yet: {', '.join(missing)}." if missing else "")
             + " Powers are means over the last full revolution after the settling revolutions, from the work "
               "integrals (docs/model.md §6.4); contact modes are 6-bit masks, bit k-1 = region ck in contact (docs/model.md §4.6).\n")
    path = root / REPORT
    path.write_text("\n".join([intro, *(study_section(root, m) for m in manifests)]))
    return path


def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description="Gather the studies' figures and tables into one Markdown report.")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="studies folder holding <study>/manifest.json; report.md is written there")
    return parser.parse_args(argv)


def main(argv=None) -> int:
    args = parse_arguments(argv)
    try:
        path = write_report(args.out)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
