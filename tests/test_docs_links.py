"""Every relative link in the repository's documents leads somewhere: the file exists and, for
a link to a heading (``page.md#heading``), the page has that heading. Links to the web are not
followed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCUMENTS = sorted(
    [
        ROOT / "README.md",
        ROOT / "ARCHITECTURE.md",
        ROOT / "CHANGELOG.md",
        *(ROOT / "docs").rglob("*.md"),
    ]
)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^\s*(```|~~~)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")


def links_in(text: str) -> list[tuple[int, str]]:
    """(line number, target) of every inline link outside fenced and inline code; a link's text
    may run over lines."""
    lines = text.splitlines()
    fenced = False
    for index, line in enumerate(lines):
        if FENCE.match(line):
            fenced = not fenced
            lines[index] = ""
        elif fenced:
            lines[index] = ""
        else:
            # Inline code keeps its length, so nothing in it is read as a link.
            lines[index] = re.sub(r"`[^`]*`", lambda m: " " * len(m[0]), line)
    prose = "\n".join(lines)
    return [(prose.count("\n", 0, m.start(1)) + 1, m[1]) for m in LINK.finditer(prose)]


def slug(heading: str) -> str:
    """The anchor GitHub gives a heading: lower case, inline markup and punctuation dropped,
    spaces as hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).lower()
    text = re.sub(r"[^\w\- ]", "", text.replace("`", ""))
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """Every heading anchor of ``page``, with GitHub's -1, -2 suffixes for repeated ones."""
    seen: dict[str, int] = {}
    result: set[str] = set()
    fenced = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        m = None if fenced else HEADING.match(line)
        if m:
            base = slug(m[1])
            count = seen.get(base, 0)
            seen[base] = count + 1
            result.add(base if count == 0 else f"{base}-{count}")
    return result


def problems(document: Path, root: Path = ROOT) -> list[str]:
    """What is wrong with each relative link of ``document`` (empty when all lead somewhere);
    a link may not leave ``root``."""
    found: list[str] = []
    for number, target in links_in(document.read_text(encoding="utf-8")):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        path_part, _, anchor = target.partition("#")
        where = f"{document.relative_to(root)}:{number}: {target}"
        path = (document.parent / path_part).resolve() if path_part else document
        if not path.exists():
            found.append(f"{where}: no such file")
        elif root not in path.parents and path != root:
            found.append(f"{where}: outside the repository")
        elif anchor and path.suffix == ".md" and anchor not in anchors(path):
            found.append(f"{where}: no heading with that anchor")
    return found


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(document: Path) -> None:
    assert not problems(document), "\n".join(problems(document))


def test_the_checker_finds_a_broken_link(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    (tmp_path / "there.md").write_text("# A heading, with `code`\n")
    page.write_text(
        "[ok](there.md) [ok](there.md#a-heading-with-code) [web](https://example.org)\n"
        "`[not a link](nowhere.md)`\n```\n[in code](nowhere.md)\n```\n"
        "[missing](nowhere.md) [bad anchor](there.md#nothing) [over\ntwo lines](there.md)\n"
    )
    assert [line for line, _ in links_in(page.read_text())] == [1, 1, 1, 6, 6, 7]
    assert anchors(tmp_path / "there.md") == {"a-heading-with-code"}
    assert problems(page, tmp_path) == [
        "page.md:6: nowhere.md: no such file",
        "page.md:6: there.md#nothing: no heading with that anchor",
    ]
