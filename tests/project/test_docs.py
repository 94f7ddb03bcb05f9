"""docs/model.md is the model's documentation inside the project: every `docs/model.md §x.y` citation in the tracked
files must lead to one of its numbered headings, nothing may point at a description outside the project, its
images must exist, and its generated tables (§9 parameters, §12 FMU variables) must match the code."""
from __future__ import annotations

import importlib.util
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "docs" / "model.md"
SECTION = r"§(\d+(?:\.\d+)?b?)"
# a citation: "docs/model.md §2.4", also lists and ranges "docs/model.md §2.4–§2.6, §7 / §8.1b"
CITATION = re.compile(r"docs/model\.md " + SECTION + r"((?:\s*(?:,|/|-|–|and)\s*" + SECTION + r")*)")
HEADING = re.compile(r"^#{2,4} (\d+(?:\.\d+)?b?) \S", re.M)
# the team's design notes outside the repository (spelled apart: this file must pass too)
OUTSIDE = ("../" + "shared", "shared/" + "SPEC", "SPEC" + ".md", "SPEC" + " §", "ARCHI" + "TECTURE", "PERFOR" + "MANCE.md",
           "FMI" + "_NOTES")


def tracked_text_files():
    names = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in names.decode().split("\0"):
        path = ROOT / name
        if not name or not path.is_file():
            continue
        try:
            yield name, path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue                                  # images and other binary files


def model_sections(text: str) -> set[str]:
    return set(HEADING.findall(text))


def citations(text: str) -> list[str]:
    found = []
    for match in CITATION.finditer(text):
        found.append(match.group(1))
        found.extend(re.findall(SECTION, match.group(2)))
    return found


def unresolved(files, sections) -> list[str]:
    return [f"{name}: docs/model.md §{section}" for name, text in files for section in citations(text)
            if section not in sections]


def test_every_citation_of_docs_model_leads_to_a_numbered_heading():
    files = list(tracked_text_files())
    sections = model_sections(MODEL.read_text(encoding="utf-8"))
    assert {"1", "2.6", "4.6", "5.2", "7.5", "8.1b", "11", "13", "15"} <= sections
    count = sum(len(citations(text)) for _, text in files)
    assert count > 300, f"only {count} citations found: the pattern no longer matches the code's form"
    assert unresolved(files, sections) == []


def test_the_citation_check_catches_a_broken_citation():
    sections = model_sections(MODEL.read_text(encoding="utf-8"))
    cite = "docs/model" + ".md"                        # spelled apart: this file's own text must pass the check
    broken = [("example.py", f"see {cite} §4.2, §4.9 and {cite} §7.2-§7.8")]
    assert unresolved(broken, sections) == [f"example.py: {cite} §4.9", f"example.py: {cite} §7.8"]


def test_nothing_in_the_project_points_at_a_description_outside_it():
    offending = [f"{name}: {marker}" for name, text in tracked_text_files() for marker in OUTSIDE
                 if marker in text]
    assert offending == []


def test_every_image_of_docs_model_exists():
    text = MODEL.read_text(encoding="utf-8")
    images = re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", text)
    assert images, "docs/model.md shows no figure"
    missing = [image for image in images if not (MODEL.parent / image).is_file()]
    assert missing == []


@pytest.fixture(scope="module")
def make_tables():
    spec = importlib.util.spec_from_file_location("make_tables", ROOT / "docs" / "make_tables.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generated_tables_match_the_code(make_tables):
    text = MODEL.read_text(encoding="utf-8")
    assert make_tables.rewrite(text, make_tables.generated_blocks()) == text, \
        "docs/model.md is out of date: run python docs/make_tables.py"
    readme = make_tables.README.read_text(encoding="utf-8")
    assert make_tables.rewrite(readme, make_tables.readme_blocks()) == readme, \
        "README.md is out of date: run python docs/make_tables.py"


def test_every_fmu_variable_is_described_in_section_12(make_tables):
    text = MODEL.read_text(encoding="utf-8")
    chapter = re.search(r"^## 12 .*?(?=^## 13 |\Z)", text, re.M | re.S).group(0)
    names = [v.name for variables in make_tables.fmu_variables().values() for v in variables]
    assert len(names) > 80
    assert [name for name in names if f"`{name}`" not in chapter] == []
