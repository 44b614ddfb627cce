"""The documentation holds together: every relative link resolves, every figure is shown
in exactly one place, and the two front pages keep their sizes."""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

# [text](target) and ![alt](target); the target ends at the first space or ')'.
LINK = re.compile(r"(!?)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^```.*?^```", flags=re.MULTILINE | re.DOTALL)
CODE = re.compile(r"`[^`\n]*`")


def pages() -> list[Path]:
    """README.md and every Markdown page under docs/."""
    return [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]


def links(page: Path) -> list[tuple[bool, str]]:
    """(is an image, target) of every Markdown link of a page outside code."""
    text = CODE.sub("", FENCE.sub("", page.read_text(encoding="utf-8")))
    return [(bang == "!", target) for bang, target in LINK.findall(text)]


def local(target: str) -> bool:
    return not re.match(r"^[a-z][a-z0-9+.-]*:", target) and not target.startswith("#")


def resolve(page: Path, target: str) -> Path:
    return (page.parent / target.split("#", 1)[0]).resolve()


def test_links_are_found():
    page = DOCS / "x.md"
    text = "[a](b.md) `[c](d.md)` ![e](f.png) [g](https://h) [i](#j)"
    found = [(b == "!", t) for b, t in LINK.findall(CODE.sub("", text))]
    assert found == [(False, "b.md"), (True, "f.png"), (False, "https://h"), (False, "#j")]
    assert [t for _, t in found if local(t)] == ["b.md", "f.png"]
    assert resolve(page, "b.md#k") == (DOCS / "b.md").resolve()


def test_every_relative_link_resolves():
    broken = [
        f"{page.relative_to(ROOT)}: {target}"
        for page in pages()
        for _, target in links(page)
        if local(target) and not resolve(page, target).exists()
    ]
    assert broken == []


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to -."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """The anchors of a page's headings (outside code blocks)."""
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    return {slug(h) for h in re.findall(r"^#{1,6} (.+)$", text, flags=re.MULTILINE)}


def test_slug_is_githubs():
    assert slug("6. Motion predictors (sections 3–5 of the paper)") == (
        "6-motion-predictors-sections-35-of-the-paper"
    )
    assert slug("RVAR's origin") == "rvars-origin"


def test_every_anchor_resolves():
    broken = []
    for page in pages():
        for _, target in links(page):
            if not local(target) and not target.startswith("#"):
                continue
            path, _, anchor = target.partition("#")
            if not anchor:
                continue
            dest = resolve(page, path) if path else page
            if dest.suffix == ".md" and dest.exists() and anchor not in anchors(dest):
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert broken == []


def test_every_figure_is_shown_once():
    shown = Counter(
        resolve(page, target)
        for page in pages()
        for image, target in links(page)
        if image and local(target)
    )
    twice = sorted(str(p.relative_to(ROOT)) for p, n in shown.items() if n > 1)
    assert twice == []
    figures = {p.resolve() for ext in ("png", "jpg") for p in DOCS.rglob(f"*.{ext}")}
    unshown = sorted(str(p.relative_to(ROOT)) for p in figures - set(shown))
    assert unshown == []


def test_front_pages_keep_their_size():
    assert (ROOT / "README.md").stat().st_size <= 12 * 1024
    assert (DOCS / "design.md").stat().st_size <= 40 * 1024
