"""The examples in docs/python.md's sections on signals and snapshots run as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[2] / "docs" / "python.md"


def _blocks(section: str) -> list[str]:
    text = DOC.read_text()
    start = text.index(f"## {section}\n")
    end = text.find("\n## ", start + 1)
    return re.findall(r"```python\n(.*?)```", text[start:end], re.S)


@pytest.mark.parametrize("section", ["Signals and junctions", "Signal control", "Snapshots"])
def test_the_section_examples_run(section: str) -> None:
    blocks = _blocks(section)
    assert blocks, section
    for code in blocks:
        exec(compile("import flockway\n" + code, f"{DOC.name}:{section}", "exec"), {})
