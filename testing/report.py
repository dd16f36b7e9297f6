"""What a failed test's report says about a cell it used: a section named after the cell with
its state and the end of its log, and, for a cell kept running (``--motocell-keep-failed``),
how to look at it and when it stops.

Light on purpose (the standard library only): the pytest plugin, loaded in every run, builds
the section from any ``Reported`` cell without loading what runs one.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Sequence

KEPT_UNTIL = (
    "until this pytest process ends: at a terminal, pytest asks for Enter after its summary "
    "first; elsewhere (CI, an xdist worker) it stops then. --pdb stops at the failure, with "
    "the cell running"
)


class Reported(abc.ABC):
    """A cell a failed test's report can describe."""

    @property
    @abc.abstractmethod
    def name(self) -> str: ...

    @abc.abstractmethod
    def described(self) -> list[str]:
        """Its state and the end of its log; or, if it is gone, one line that says so."""

    @abc.abstractmethod
    def how_to_look(self) -> list[str]:
        """The commands that show it while it runs."""


class Starts(abc.ABC):
    """What starts cells for a test (``motocell_cells``): the report describes each."""

    @property
    @abc.abstractmethod
    def started(self) -> Sequence[Reported]: ...


def reported_in(value: object) -> list[Reported]:
    """The cells a fixture's value is or started."""
    if isinstance(value, Reported):
        return [value]
    if isinstance(value, Starts):
        return list(value.started)
    return []


def section(cell: Reported, kept: bool) -> tuple[str, str]:
    """The report section on ``cell``: its title and text."""
    lines = _read(cell.described)
    if kept:
        lines += ["", f"kept running (--motocell-keep-failed) {KEPT_UNTIL}:"]
        lines += _read(cell.how_to_look)
    return f"motocell cell {cell.name}", "\n".join(lines)


def _read(reader: Callable[[], list[str]]) -> list[str]:
    """What ``reader`` says, or one line on why it could not: a report must show the test's
    own failure, never replace it with the reader's (a cell that stopped answering)."""
    try:
        return reader()
    except Exception as exc:
        return [f"the cell could not be read: {type(exc).__name__}: {exc}"]
