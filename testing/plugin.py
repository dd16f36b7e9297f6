"""The pytest plugin pip installs with motocell (the ``pytest11`` entry point): fixtures that
start cells (``motocell.testing``) and stop them, every process reaped, when their scope ends,
also on a failure or Ctrl-C (pytest tears fixtures down on KeyboardInterrupt). A run killed
outright (SIGKILL, SIGTERM) tears nothing down: its cells stop by themselves, each launcher
seeing its lifeline to this process end (``running_cell.start_cell``).

A failed test's report has a section on each cell it used (``testing.report``); with
``--motocell-keep-failed`` those cells run on until the pytest process ends
(``testing.fixtures.Keeper``): a cell's lifeline ties it to this process, so it can outlive
its fixture but not its run.

pytest loads it in every run wherever motocell is installed: ``motocell.testing`` loads the
harness (Zenoh, numpy) only when a fixture first asks for a cell.
"""

from __future__ import annotations

from collections.abc import Generator, Iterator
from typing import TYPE_CHECKING, Any

import pytest

from motocell import testing
from motocell.testing.fixtures import (
    KEEP_OPTION,
    KEEPER,
    Keeper,
    ask_a_person,
    cell_fixture,
    kept_if_failed,
)
from motocell.testing.report import Reported, reported_in, section

if TYPE_CHECKING:
    from motocell.testing import StartCell

motocell_cell = cell_fixture()
# Faster, but each test finds it as the one before left it (``reset()`` undoes some of that).
motocell_session_cell = cell_fixture(scope="session")


@pytest.fixture
def motocell_cells(request: pytest.FixtureRequest) -> Iterator[StartCell]:
    """``motocell_cells(config="four-group", byte_order="big", **settings)`` starts a cell and
    returns it started; every cell started so stops when the test ends."""
    yield from kept_if_failed(request, testing.cells())


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.getgroup("motocell").addoption(
        KEEP_OPTION,
        action="store_true",
        help="keep the cells of a failed test running until pytest ends (at a terminal, "
        "until Enter after the summary); its report says how to look at them",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.stash[KEEPER] = Keeper(config.getoption(KEEP_OPTION))


def pytest_unconfigure(config: pytest.Config) -> None:
    config.stash[KEEPER].stop(ask_a_person(config))


# The old-style wrapper: a user's pytest 7 (pluggy before 1.2) has no ``wrapper=True``, and
# pytest loads this plugin in every run wherever motocell is installed.
@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, Any, None]:
    """A failed test's (or its set-up's) report gets a section on each cell it used, which its
    fixtures still run; a cell its tear-down failed to stop was stopped already."""
    outcome = yield
    report: pytest.TestReport = outcome.get_result()
    if report.failed and report.when != "teardown":
        keeper = item.config.stash[KEEPER]
        for cell in cells_of(item):
            report.sections.append(section(cell, keeper.failed_with(cell)))


def cells_of(item: pytest.Item) -> list[Reported]:
    """The cells of the fixtures ``item`` asked for, directly or through others."""
    values = getattr(item, "funcargs", {}).values()
    cells = {id(cell): cell for value in values for cell in reported_in(value)}
    return list(cells.values())
