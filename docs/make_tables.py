"""Regenerate the tables of docs/model.md and the README that come from the code: the default parameters (§9, from
`rotary_vane.mechanics.parameters.markdown_table`), the outputs (from the declarations of
`rotary_vane.mechanics.loop.outputs`) and the FMU variables (§12, from the variables the FMU slaves register). Each
table sits between `<!-- generated: NAME -->` and `<!-- end generated: NAME -->`; `tests/project/test_docs.py` checks that
the files hold what this script would write.

    python docs/make_tables.py
"""
from __future__ import annotations

import re
from pathlib import Path

MODEL = Path(__file__).resolve().parent / "model.md"
README = Path(__file__).resolve().parent.parent / "README.md"


def parameter_table() -> str:
    from rotary_vane.mechanics.parameters import markdown_table
    return markdown_table()


def fmu_variables() -> dict[str, list]:
    """{FMU model name: the ScalarVariables its slave registers, in declaration order}."""
    from rotary_vane.fmu_src.compressor import CompressorSlave
    from rotary_vane.fmu_src.motor import MotorSlave
    from rotary_vane.fmu_src.refrigeration_loop import LoopSlave
    return {name: list(cls(instance_name="docs", resources=None).vars.values())
            for name, cls in (("RotaryVaneCompressor", CompressorSlave), ("DriveMotor", MotorSlave),
                              ("RefrigerationLoop", LoopSlave))}


def _type_name(variable) -> str:
    return type(variable).__name__.replace("Variable", "")


def variable_table(variables) -> str:
    lines = ["| variable | causality | type | unit | description |", "|---|---|---|---|---|"]
    for v in variables:
        unit = getattr(v, "unit", None) or "-"
        description = (v.description or "").replace("|", "/")
        lines.append(f"| `{v.name}` | {v.causality.name} | {_type_name(v)} | {unit} | {description} |")
    return "\n".join(lines)


def output_table() -> str:
    from rotary_vane.mechanics.loop.outputs import markdown_table
    return markdown_table()


def generated_blocks() -> dict[str, str]:
    """The generated tables of docs/model.md."""
    blocks = {"parameters": parameter_table(), "outputs": output_table()}
    for model, variables in fmu_variables().items():
        blocks[f"variables {model}"] = variable_table(variables)
    return blocks


def readme_blocks() -> dict[str, str]:
    """The generated tables of the README."""
    return {"parameters": parameter_table(), "outputs": output_table()}


def block_pattern(name: str) -> re.Pattern:
    return re.compile(rf"(<!-- generated: {re.escape(name)} -->\n)(.*?)(<!-- end generated: {re.escape(name)} -->)", re.S)


def rewrite(text: str, blocks: dict[str, str]) -> str:
    for name, table in blocks.items():
        pattern = block_pattern(name)
        if not pattern.search(text):
            raise SystemExit(f"docs/model.md has no block '<!-- generated: {name} -->'")
        text = pattern.sub(lambda match: match.group(1) + table + "\n" + match.group(3), text)
    return text


def main() -> None:
    for path, blocks in ((MODEL, generated_blocks()), (README, readme_blocks())):
        path.write_text(rewrite(path.read_text(encoding="utf-8"), blocks), encoding="utf-8")


if __name__ == "__main__":
    main()
