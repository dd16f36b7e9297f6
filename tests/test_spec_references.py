"""Every section reference in the repository's .py and .md files names a document summarised
in docs/spec and a section that summary has a heading for (convention: docs/spec/README.md).
The section sign is written as an escape here so this file does not scan itself."""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SPEC_DIR = ROOT / "docs" / "spec"
SIGN = "\N{SECTION SIGN}"
NUMBER = r"\d+(?:\.\d+)*"
REFERENCE = re.compile(
    rf"(?:(?P<name>[\w.-]+) )?{SIGN}(?P<first>{NUMBER})?(?:-(?P<last>{NUMBER}))?"
)
HEADING = re.compile(rf"^#+ {SIGN}(?P<number>{NUMBER})\b")
SCANNED_SUFFIXES = {".py", ".md"}
SKIPPED_DIRS = {"__pycache__", "node_modules", "build", "dist"}


def summarised_sections() -> dict[str, set[str]]:
    """Short name -> the section numbers its docs/spec summary has headings for."""
    sections: dict[str, set[str]] = {}
    for summary in SPEC_DIR.glob("*.md"):
        if summary.name == "README.md":
            continue
        lines = summary.read_text(encoding="utf-8").splitlines()
        sections[summary.stem] = {m["number"] for line in lines if (m := HEADING.match(line))}
    return sections


def covered(first: str, last: str | None) -> list[str]:
    """The sections a reference covers: both ends of a range, and every section between them
    when they share a parent (4.3-4.5 covers 4.4)."""
    if last is None:
        return [first]
    head, _, tail = first.rpartition(".")
    last_head, _, last_tail = last.rpartition(".")
    if head != last_head or int(last_tail) <= int(tail):
        return [first, last]
    prefix = f"{head}." if head else ""
    return [f"{prefix}{n}" for n in range(int(tail), int(last_tail) + 1)]


def problems_in(line: str, sections: dict[str, set[str]]) -> list[str]:
    """What is wrong with each section reference in ``line`` (empty when all are fine)."""
    problems: list[str] = []
    for m in REFERENCE.finditer(line):
        name, first, text = m["name"], m["first"], repr(m[0])
        if name is None:
            problems.append(f"{text}: no short name before the section sign")
        elif name not in sections:
            problems.append(f"{text}: {name!r} is not a short name of a docs/spec summary")
        elif first is None:
            problems.append(f"{text}: no section number")
        else:
            missing = [s for s in covered(first, m["last"]) if s not in sections[name]]
            problems.extend(f"{text}: docs/spec/{name}.md has no heading for {s}" for s in missing)
    return problems


def scanned_files() -> Iterator[Path]:
    """The repository's .py and .md files, without virtualenvs, VCS data and caches."""
    for directory, subdirectories, files in os.walk(ROOT):
        subdirectories[:] = [
            d
            for d in subdirectories
            if not d.startswith(".") and d not in SKIPPED_DIRS and not d.endswith(".egg-info")
        ]
        for name in files:
            if Path(name).suffix in SCANNED_SUFFIXES:
                yield Path(directory) / name


def repository_problems() -> list[str]:
    sections = summarised_sections()
    problems: list[str] = []
    for path in sorted(scanned_files()):
        is_summary = path.parent == SPEC_DIR
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            if is_summary and HEADING.match(line):
                continue  # a summary's section headings define sections, they cite none
            where = f"{path.relative_to(ROOT)}:{number}"
            problems.extend(f"{where}: {problem}" for problem in problems_in(line, sections))
    return problems


def test_every_section_reference_resolves_to_a_summary_heading() -> None:
    problems = repository_problems()
    assert not problems, "section references that do not resolve:\n" + "\n".join(problems)


SECTIONS = {"motoros1": {"2.4", "2.5", "2.6", "7.3"}, "incremental-motion": {"2.7.2"}}


@pytest.mark.parametrize(
    "line",
    [
        f"see motoros1 {SIGN}2.4 step 5",
        f"(motoros1 {SIGN}2.4-2.6)",
        f"incremental-motion {SIGN}2.7.2's cubic",
        f"[quirk, motoros1 {SIGN}2.5, motoros1 {SIGN}7.3]",
        "no reference here",
    ],
)
def test_a_well_formed_reference_passes(line: str) -> None:
    assert problems_in(line, SECTIONS) == []


@pytest.mark.parametrize(
    "line",
    [
        f"a bare {SIGN}2.4",
        f"spec {SIGN}2.7",
        f"motoros1-behaviour.md {SIGN}2.4",
        f"motoros1 {SIGN}2.4, {SIGN}2.5",
        f"motoros1 {SIGN}9.9",
        f"motoros1 {SIGN}2.4-2.7",
        f"motoros1 {SIGN}",
    ],
)
def test_a_malformed_or_unknown_reference_fails(line: str) -> None:
    assert problems_in(line, SECTIONS) != []
