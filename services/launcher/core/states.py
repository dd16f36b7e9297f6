"""The launcher's state table: what to do about a child found dead, from where its restart
stands and how it exited. ``RestartPolicy`` consults ``RESTARTS``.

A child found dead is restarted a delay later, for as long as the launcher runs: meanwhile the
controller sees its liveliness token gone and the cell answers NOT_READY, and the delay keeps a
child that dies at once from spinning. A child that exits with EXIT_CONFIG cannot start as
configured, and restarting it would only repeat its one line: the cell stops instead.
"""

from __future__ import annotations

from enum import Enum


class ChildState(Enum):
    RUNNING = "no restart scheduled: running since its last start, as far as the launcher knew"
    RESTART_PENDING = "found dead before; its restart is not due yet"
    RESTART_DUE = "found dead before; its restart is due"


class Exit(Enum):
    FAILED = "exited with any status but EXIT_CONFIG, or was killed"
    CANNOT_START = "exited with EXIT_CONFIG: it cannot start as configured"


class Restart(Enum):
    GIVE_UP = "give up"
    """Stop the cell, with the child's status."""
    NOTICED = "noticed"
    """Just found dead: report it; its restart is scheduled a delay from now."""
    WAIT = "wait"
    NOW = "now"
    """Start it again; no restart is scheduled for it any more."""


RESTARTS: dict[tuple[ChildState, Exit], Restart] = {
    (ChildState.RUNNING, Exit.FAILED): Restart.NOTICED,
    (ChildState.RESTART_PENDING, Exit.FAILED): Restart.WAIT,
    (ChildState.RESTART_DUE, Exit.FAILED): Restart.NOW,
    (ChildState.RUNNING, Exit.CANNOT_START): Restart.GIVE_UP,
    (ChildState.RESTART_PENDING, Exit.CANNOT_START): Restart.GIVE_UP,
    (ChildState.RESTART_DUE, Exit.CANNOT_START): Restart.GIVE_UP,
}
