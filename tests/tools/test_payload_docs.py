"""docs/payloads.md's payload tables are what the schemas say: regenerated and compared."""

from __future__ import annotations

from pathlib import Path

import msgspec

from motocell.shared.bus import schemas
from motocell.shared.bus.catalog import ROUTES
from motocell.tools import payload_docs

PAGE = Path(__file__).resolve().parents[2] / payload_docs.DEFAULT_PAGE


def test_the_document_shows_the_schemas_as_they_are() -> None:
    text = PAGE.read_text()
    start = text.index(payload_docs.BEGIN)
    end = text.index(payload_docs.END) + len(payload_docs.END)
    assert text[start:end] == payload_docs.generate(), (
        "docs/payloads.md's payload tables are stale: run `python -m motocell.tools.payload_docs`"
    )


def test_every_payload_of_the_catalogue_and_every_field_is_shown() -> None:
    generated = payload_docs.generate()
    carried = {route.payload for route in ROUTES} | {route.reply for route in ROUTES}
    for kind in payload_docs.payload_types():
        assert f"#### `{kind.__name__}`" in generated
        for index, field in enumerate(msgspec.structs.fields(kind)):
            assert f"| {index} | `{field.name}` |" in generated
    assert carried - {None} <= set(payload_docs.payload_types())
    assert schemas.Alarm in payload_docs.payload_types()


def test_rewriting_replaces_only_the_block(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(f"before\n{payload_docs.BEGIN}\nold\n{payload_docs.END}\nafter\n")
    assert payload_docs.main([str(page)]) == 0
    assert page.read_text() == f"before\n{payload_docs.generate()}\nafter\n"


def test_a_union_does_not_split_its_table_cell() -> None:
    """Every row of every table has the five cells of its header."""
    for line in payload_docs.generate().splitlines():
        if line.startswith("| "):
            assert len(line.replace("\\|", "").split("|")) == 7, line
