"""The pytest plugin pip installs with motocell: registered through the ``pytest11`` entry
point, loaded in this very run, and light to load (every pytest run wherever motocell is
installed loads it, the project's own included)."""

from __future__ import annotations

import sys
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from tests.tools.test_cli import loaded_after

PLUGIN = "motocell.testing.plugin"
CELL_MACHINERY = {
    "zenoh",
    "numpy",
    "msgspec",
    "motocell.testing.under_test",
    "motocell.testing.running_cell",
    "motocell.shared.faults",
}
"""What the plugin loads only when a fixture first asks for a cell."""


def test_the_entry_point_names_the_plugin_and_pytest_loaded_it(
    request: pytest.FixtureRequest,
) -> None:
    (entry,) = [entry for entry in entry_points(group="pytest11") if entry.value == PLUGIN]
    assert request.config.pluginmanager.get_plugin(entry.name) is sys.modules[PLUGIN]


@pytest.mark.cell
def test_loading_the_plugin_loads_none_of_what_runs_a_cell(tmp_path: Path) -> None:
    assert loaded_after(f"import pytest, {PLUGIN}", CELL_MACHINERY, tmp_path) == []


@pytest.mark.cell
def test_the_first_name_asked_of_motocell_testing_loads_the_harness(tmp_path: Path) -> None:
    code = "from motocell.testing import cell"
    assert loaded_after(code, CELL_MACHINERY, tmp_path) == sorted(CELL_MACHINERY)
