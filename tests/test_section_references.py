"""Every section reference in the code says whose section it is.

The paper and docs/design.md both number their sections, and the numbers 1–7 mean
different things in each, so a section sign in the sources, tests, benchmarks,
examples, tools and Makefile is always preceded by ``paper `` or ``design ``
("paper §5", "design §14.3"). A list that continues one owner's sections may leave the
owner out after the first ("design §2, §3", "design §4 and §15"); a list of two owners
names both ("paper §4–5, design §7"). Other works' sections are written out as
"section 4.3". This test reads every such file with a regular expression and names
each bare reference.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SIGN = "\N{SECTION SIGN}"  # spelt out, so that this file's own examples are not bare

_NUMBER = rf"{SIGN}\d+(?:\.\d+)*(?:[–-]\d+(?:\.\d+)*)?"
# A section sign is qualified when "paper " or "design " comes right before it, or
# before the list of that owner's sections it continues.
_QUALIFIED = re.compile(
    rf"\b(?:paper|design) (?:{_NUMBER}(?:,| and| or) )*$",
)


def bare_references(text: str) -> list[tuple[int, str]]:
    """(line number, line) of every section sign in `text` that names no owner."""
    found = []
    for number, line in enumerate(text.splitlines(), 1):
        for match in re.finditer(SIGN, line):
            if not _QUALIFIED.search(line[: match.start()]):
                found.append((number, line.strip()))
    return found


def _code_files() -> list[Path]:
    files = [ROOT / "Makefile"]
    for folder in ("src", "tests", "benchmarks", "examples", "tools"):
        files += sorted((ROOT / folder).rglob("*.py"))
    return [f for f in files if f.is_file()]


def _bare_in(path: Path) -> list[str]:
    rel = path.relative_to(ROOT).as_posix()
    return [f"{rel}:{n}: {line}" for n, line in bare_references(path.read_text())]


def test_every_section_reference_names_paper_or_design():
    bad = []
    for path in _code_files():
        bad += _bare_in(path)
    assert not bad, "section references without 'paper' or 'design':\n" + "\n".join(bad)


@pytest.mark.parametrize(
    "text",
    [
        f"The order follows {SIGN}2 and makes",
        f"(the paper's {SIGN}4)",
        f"(paper {SIGN}4; {SIGN}7)",  # a list continues after a comma, "and" or "or"
        f"design.md {SIGN}12",
        f"Lütkepohl 2006, {SIGN}4.3",
        f'"{SIGN}6, fig. 8"',
        f"papers {SIGN}2",
    ],
)
def test_a_bare_reference_is_found(text):
    assert len(bare_references(text)) == 1, text


@pytest.mark.parametrize(
    "text",
    [
        f"the SMD of paper {SIGN}4 (design {SIGN}5)",
        f"(design {SIGN}2, {SIGN}3)",
        f"(design {SIGN}4 and {SIGN}15)",
        f"(paper {SIGN}4–5, design {SIGN}7)",
        f'"paper {SIGN}4, fig. 2"',
        f"design {SIGN}14.3 step 5",
        f"measures of the paper {SIGN}3.3",
        "Lütkepohl 2006, section 4.3",
    ],
)
def test_a_qualified_reference_passes(text):
    assert bare_references(text) == []
