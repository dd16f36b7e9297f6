"""The rest of the cell as the gateway's decisions see it (docs/conventions.md, World as a
parameter): the state the adapter keeps current, and the few things the gateway asks of other
services. ``ZenohCell`` is the real one; the unit tests drive the handlers with a fake.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Protocol

from motocell.services.gateway.core.cell_state import CellState
from motocell.services.gateway.core.sources import Source
from motocell.shared.bus.schemas import CommandReply, CommandRequest, Point


class CellPort(Protocol):
    @property
    def state(self) -> CellState:
        """What the port last read of the cell; a decision reads it inside ``current``."""
        ...

    def current(self) -> AbstractContextManager[CellState]:
        """``state`` brought up to date with the latest samples and held still while the
        caller decides on it (a point, a command's check). Never held across a query or a
        wait: other readers (the watchdog, the other ports) wait for it meanwhile."""
        ...

    def controller_alive(self) -> bool: ...

    def send_point(self, group: int, point: Point) -> None:
        """Publish a point numbered by the group's ``GroupCredit.number``."""
        ...

    def controller(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 2.0
    ) -> CommandReply | None:
        """A controller command; returns once ``state`` has the status that follows it.
        None when the controller did not answer in time."""
        ...

    def executor(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 1.0
    ) -> CommandReply | None:
        """An executor command; None when the executor did not answer in time."""
        ...

    def wait_for(self, condition: Callable[[], bool], timeout: float) -> bool:
        """Block until ``condition()`` (evaluated on ``state``) holds, at most ``timeout`` s;
        whether it does."""
        ...


def readiness(cell: CellPort, source: Source) -> tuple[bool, int]:
    """Motion-ready for ``source`` and the NOT_READY subcode, as CHECK_MOTION_READY and every
    point see it (inside ``current``)."""
    return cell.state.readiness(cell.controller_alive(), source)
