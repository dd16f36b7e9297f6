"""Fixtures the end-to-end modules share.

``cell`` is one running cell per module: the default cell, or the file of ``tests/e2e/cells``
(cells only tests need) or ``shared/cells`` (the samples) that the module names with
``pytest.mark.parametrize("cell", ["fs100.toml"], indirect=True)`` in its ``pytestmark``. The
other fixtures are clients of that cell, opened for one test and closed after.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.catalog import Role
from motocell.testing.client import MotionClient, StateListener
from motocell.testing.running_cell import RunningCell, TickLog, running_cell
from tests.leftovers import why_no_namespaces

TEST_CELLS = Path(__file__).parent / "cells"
START_DEADLINE_S = 60.0
"""For a module's cell to be whole: eleven processes start in about a second here, many times
that on a loaded machine; a bound for a hang, not a speed (start-up is benchmark figure 9),
within pytest-timeout's 120 s for the module's first test. A start that fails because a port
was taken meanwhile is tried again on new ports (``running_cell``), one that fails otherwise
once more."""


@pytest.fixture(scope="session")
def repo() -> Path:
    """The source tree: ``deploy/`` (cell files, Dockerfile) and ``compose.yaml``."""
    return Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def network_namespaces() -> None:
    """Skips a test on a machine where it cannot make network namespaces (not root, no ip)."""
    reason = why_no_namespaces()
    if reason:
        pytest.skip(reason)


@pytest.fixture(scope="module")
def cell(request: pytest.FixtureRequest, repo: Path) -> Iterator[RunningCell]:
    name: str | None = getattr(request, "param", None)
    if name is None:
        path = None
    elif (TEST_CELLS / name).exists():
        path = TEST_CELLS / name
    else:
        path = repo / "shared" / "cells" / name
    with running_cell(path, timeout=START_DEADLINE_S, attempts=2) as running:
        yield running


@pytest.fixture(scope="module")
def bus(cell: RunningCell) -> Iterator[zenoh.Session]:
    """A Zenoh client of the module's cell with the operator identity: it sees everything and
    may inject faults, as `motocell fault` does; nothing else."""
    session = cell.session(Role.OPERATOR)
    yield session
    session.close()


@pytest.fixture
def motion(cell: RunningCell) -> Iterator[MotionClient]:
    with cell.motion() as client:
        yield client


@pytest.fixture
def state(cell: RunningCell) -> Iterator[StateListener]:
    """A state port client that has seen at least one whole state cycle."""
    with cell.state() as listener:
        listener.wait_for(lambda f: f.status is not None, 10.0)
        yield listener


@pytest.fixture
def ticks(cell: RunningCell, bus: zenoh.Session) -> Iterator[TickLog]:
    log = TickLog(bus, cell.keys)
    yield log
    log.subscriber.undeclare()


@pytest.fixture(scope="session")
def motocell() -> Callable[..., subprocess.CompletedProcess[str]]:
    """Runs ``motocell <args>`` to the end, as an operator at a terminal would."""

    def run(*args: str, timeout: float = 30.0) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "motocell.tools.cli", *args]
        return subprocess.run(command, capture_output=True, text=True, timeout=timeout, check=False)

    return run
