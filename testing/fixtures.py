"""Cells as pytest fixtures: ``cell_fixture`` makes one of a configured cell at any scope (the
plugin's own fixtures are made by it), and ``Keeper`` is what ``--motocell-keep-failed`` does
with a failed test's cells: they outlive their fixture's scope until the pytest process ends.

Light to import, as the plugin is: nothing here loads what runs a cell before a fixture asks
for one.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import pytest

from motocell import testing
from motocell.testing.report import Reported, reported_in

if TYPE_CHECKING:
    from _pytest.fixtures import FixtureFunctionDefinition

    from motocell.testing import CellUnderTest

T = TypeVar("T")
Scope = Literal["function", "class", "module", "package", "session"]
KEEP_OPTION = "--motocell-keep-failed"


class Keeper:
    """The cells of failed tests, when ``keep`` (the option) is on: their fixtures hand their
    stops here instead of stopping them, and ``stop`` stops them all."""

    def __init__(self, keep: bool) -> None:
        self.keep = keep
        self._failed: set[Reported] = set()
        """The cells of failed tests (held, so that no later cell takes one's identity)."""
        self._kept = ExitStack()
        self.kept: list[str] = []
        """The names of the cells kept, in the order their fixtures ended."""

    def failed_with(self, cell: Reported) -> bool:
        """A test that used ``cell`` failed: whether the cell is kept."""
        if self.keep:
            self._failed.add(cell)
        return self.keep

    def hand_over(self, value: object, stop: ExitStack) -> None:
        """A fixture's scope ended: ``stop`` stops ``value``'s cells now, or, if a failed test
        used one of them, when ``stop()`` is called."""
        cells = reported_in(value)
        if any(cell in self._failed for cell in cells):
            self._kept.push(stop.pop_all())
            self.kept += [cell.name for cell in cells]

    def stop(self, ask: Callable[[str], object]) -> None:
        """Stop the kept cells, the last kept first, once ``ask`` returns: asked a person
        who had a look at them whether to (``ask_a_person``)."""
        with self._kept:
            if self.kept:
                ask(f"motocell: {', '.join(self.kept)} kept running; Enter stops them ")


KEEPER = pytest.StashKey[Keeper]()


def kept_if_failed(request: pytest.FixtureRequest, cells: AbstractContextManager[T]) -> Iterator[T]:
    """A fixture's body: what ``cells`` gives, stopped when the fixture's scope ends, or later,
    by the run's ``Keeper``, if a failed test used it."""
    with ExitStack() as stop:
        value = stop.enter_context(cells)
        yield value
        keeper = request.config.stash.get(KEEPER, None)
        if keeper is not None:  # None: a cell_fixture in a run without the plugin (-p no:motocell)
            keeper.hand_over(value, stop)


def cell_fixture(
    config: str | Path | None = None,
    *,
    scope: Scope = "function",
    name: str | None = None,
    **settings: Any,
) -> FixtureFunctionDefinition:
    """A pytest fixture of a started cell, as ``motocell.testing.cell(config, name=name,
    **settings)`` starts it, for each ``scope``: ``four_groups = cell_fixture("four-group",
    scope="module")`` in a conftest gives the fixture ``four_groups``, one cell for each test
    module that asks for it. A setting the cell cannot take fails the first test that asks."""

    if scope not in SHARED_BY:
        raise ValueError(f"cell_fixture: scope {scope!r} is not one of: {', '.join(SHARED_BY)}")

    def started_cell(request: pytest.FixtureRequest) -> Iterator[CellUnderTest]:
        yield from kept_if_failed(request, testing.cell(config, name=name, **settings))

    started_cell.__doc__ = described(config, scope, settings)
    return pytest.fixture(scope=scope)(started_cell)


SHARED_BY = {
    "function": "for each test alone",
    "class": "shared by the tests of each class",
    "module": "shared by the tests of each module",
    "package": "shared by the tests of each package",
    "session": "shared by every test of this process (one per xdist worker under pytest -n)",
}


def described(config: str | Path | None, scope: Scope, settings: dict[str, Any]) -> str:
    """What ``pytest --fixtures`` says of a ``cell_fixture``."""
    cell = "default cell (one 6-axis arm, YRC1000)" if config is None else f"cell {config}"
    changed = "".join(f", {field}={value!r}" for field, value in settings.items())
    return f"A started {cell}{changed}, {SHARED_BY[scope]}."


def ask_a_person(config: pytest.Config) -> Callable[[str], None]:
    """``input`` from pytest's own standard input, when a person can answer: at a terminal,
    and not in an xdist worker (whose input is its controller's); elsewhere nothing is asked."""
    capture = config.pluginmanager.getplugin("capturemanager")

    def ask(prompt: str) -> None:
        if capture is not None:
            # The run's output is all written by now: what is captured stays released.
            capture.suspend_global_capture(in_=True)
        if not hasattr(config, "workerinput") and sys.stdin.isatty():
            try:
                input(prompt)
            # Ctrl-C or Ctrl-D answers as Enter does: the cells stop, without a traceback.
            except (EOFError, KeyboardInterrupt):
                print()

    return ask
