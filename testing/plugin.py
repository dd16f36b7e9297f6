"""The pytest plugin pip installs with motocell (the ``pytest11`` entry point): fixtures that
start cells (``motocell.testing``) and stop them, every process reaped, when their scope ends,
also on a failure or Ctrl-C (pytest tears fixtures down on KeyboardInterrupt). A run killed
outright (SIGKILL, SIGTERM) tears nothing down: its cells stop by themselves, each launcher
seeing its lifeline to this process end (``running_cell.start_cell``).

pytest loads it in every run wherever motocell is installed: ``motocell.testing`` loads the
harness (Zenoh, numpy) only when a fixture first asks for a cell.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import pytest

from motocell import testing

if TYPE_CHECKING:
    from motocell.testing import CellUnderTest, StartCell


@pytest.fixture
def motocell_cell() -> Iterator[CellUnderTest]:
    """A started default cell (one 6-axis arm, YRC1000) for this test alone."""
    with testing.cell() as started:
        yield started


@pytest.fixture(scope="session")
def motocell_session_cell() -> Iterator[CellUnderTest]:
    """A started default cell shared by every test of the run that asks for it: faster, but
    each test finds it as the one before left it."""
    with testing.cell() as started:
        yield started


@pytest.fixture
def motocell_cells() -> Iterator[StartCell]:
    """``motocell_cells(config="four-group", byte_order="big", **settings)`` starts a cell and
    returns it started; every cell started so stops when the test ends."""
    with testing.cells() as start:
        yield start
