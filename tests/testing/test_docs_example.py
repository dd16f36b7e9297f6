"""docs/testing-with-motocell.md shows the user's test file that tests/testing/
test_installed_plugin.py runs against an installed motocell: the example is that file, so what
the page shows is what ran."""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PAGE = REPO / "docs" / "testing-with-motocell.md"
USER_FILE = Path(__file__).parent / "user" / "client.py"


def python_block_after(heading: str, text: str) -> str:
    section = text.split(f"\n{heading}\n", 1)[1]
    return section.split("```python\n", 1)[1].split("```", 1)[0]


def test_the_pages_client_example_is_the_file_the_tests_run() -> None:
    example = python_block_after("## A Python Simple Message client", PAGE.read_text())
    _docstring, _, code = USER_FILE.read_text().partition('"""\n\n')
    assert example == code
