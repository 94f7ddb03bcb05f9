"""The README's parameter table is generated from the declarations: it must not drift from them."""
from pathlib import Path

from rotary_vane.mechanics.parameters import markdown_table


def test_readme_parameter_table_matches_the_declarations():
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")
    assert markdown_table() in readme
