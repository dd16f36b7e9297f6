"""Fixtures the end-to-end modules share; each module defines its own ``cell``."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from shared.bus.session import open_session
from testkit.cell import RunningCell


@pytest.fixture(scope="module")
def bus(cell: RunningCell) -> Iterator[zenoh.Session]:
    """A Zenoh client of the module's cell: what any observer or operator tool would be."""
    session = open_session("client", [cell.zenoh_endpoint], wait=False)
    yield session
    session.close()
