"""The cell file a test asks for: a sample or the default cell with top-level fields set by
keyword, checked before anything starts and written as TOML the launcher reads back."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from motocell.shared.config import ConfigError, load_cell
from motocell.testing.cell_file import value, write_cell_file


def test_the_default_cell_gets_the_name_and_settings(tmp_path: Path) -> None:
    path = write_cell_file(tmp_path / "cell.toml", None, "test-1-1", {"pending_points": 4})
    cell = load_cell(path)
    assert (cell.name, cell.pending_points, len(cell.groups)) == ("test-1-1", 4, 1)


def test_a_sample_keeps_its_fields_under_the_settings(tmp_path: Path) -> None:
    path = write_cell_file(tmp_path / "cell.toml", "four-group", "t", {"byte_order": "big"})
    cell, sample = load_cell(path), load_cell("four-group")
    assert (cell.name, cell.byte_order) == ("t", "big")
    assert cell.groups == sample.groups
    assert cell.controller == sample.controller


def test_a_misspelt_setting_is_refused_by_name_before_a_file_is_written(tmp_path: Path) -> None:
    path = tmp_path / "cell.toml"
    with pytest.raises(ConfigError, match=r"pending_point.*did you mean `pending_points`"):
        write_cell_file(path, None, "t", {"pending_point": 4})
    assert not path.exists()


def test_a_bad_name_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="must be letters, digits"):
        write_cell_file(tmp_path / "cell.toml", None, "a cell", {})


@pytest.mark.parametrize(
    "item",
    [
        'a "quoted"\\ line\nand\ttab\x7f\x01 é',
        1e-05,
        -0.0,
        True,
        12,
        [1.5, [2, 3], []],
        {"xyz": [0.0, 1.0], "odd key": {"kind": "ideal"}},
    ],
)
def test_values_read_back_as_written(item: object) -> None:
    assert tomllib.loads(f"v = {value(item)}")["v"] == item


def test_a_value_toml_cannot_hold_is_refused() -> None:
    with pytest.raises(ConfigError, match="not a value a cell file holds"):
        value(None)
