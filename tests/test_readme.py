"""The README's Python examples run as written.

Each ```python block of README.md is executed in a fresh namespace, in a scratch folder
that sees the repository's ``examples/`` (the examples name their data by relative
paths, as a reader in a clone would run them).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def python_blocks(text: str) -> list[str]:
    """The bodies of the ```python fenced blocks of a Markdown text, in order, each
    preceded by blank lines so that its line numbers are the text's."""
    pattern = re.compile(r"^```python\n(.*?)^```", flags=re.MULTILINE | re.DOTALL)
    return ["\n" * text.count("\n", 0, m.start(1)) + m.group(1) for m in pattern.finditer(text)]


BLOCKS = python_blocks(README.read_text(encoding="utf-8"))


def test_readme_has_the_three_examples():
    assert len(BLOCKS) == 3
    assert "handvar.track(" in BLOCKS[0]
    assert "tracker.process(frame)" in BLOCKS[1]
    assert ".predict()" in BLOCKS[2]


def test_python_blocks_are_found():
    text = "a\n```python\nx = 1\n```\n```sh\nls\n```\n```python\ny = 2\n```\n"
    assert [b.strip() for b in python_blocks(text)] == ["x = 1", "y = 2"]
    block = python_blocks(text)[1]
    assert len(block) - len(block.lstrip("\n")) == 8  # y = 2 is line 9


@pytest.mark.parametrize("block", BLOCKS, ids=["track", "hand_tracker", "predictor"][: len(BLOCKS)])
def test_readme_example_runs(block, tmp_path, monkeypatch):
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    exec(compile(block, str(README), "exec"), {"__name__": "__readme__"})
