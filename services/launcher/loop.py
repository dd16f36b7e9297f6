"""The launcher's one loop, on its main thread: start every child, then sleep until one exits,
a restart is due, the stop, or the time the caller asked to look again; restart the children
``RestartPolicy`` says to. Written against ``Supervised`` and ``Stop``, so a unit test drives it
with children that are not processes."""

from __future__ import annotations

import logging
import math
import select
import time
from collections.abc import Callable, Sequence
from typing import Protocol

from motocell.services.launcher.core.restarts import RestartPolicy
from motocell.services.launcher.core.states import Restart
from motocell.shared.config import EXIT_CONFIG

log = logging.getLogger("motocell")


class Supervised(Protocol):
    """A child as the loop sees it (``processes.Child``)."""

    @property
    def name(self) -> str: ...

    @property
    def exited(self) -> int | None:
        """A descriptor that becomes readable when the child exits; None when there is none."""
        ...

    @property
    def returncode(self) -> int | None:
        """How it exited; None while it runs or before it started."""
        ...

    def start(self) -> None:
        """Start it (again)."""
        ...

    def alive(self) -> bool: ...

    def forget(self) -> None:
        """Close ``exited``: the child is gone (or about to be replaced)."""
        ...


class Stop(Protocol):
    def is_set(self) -> bool: ...

    def fileno(self) -> int:
        """Readable once set."""
        ...


def supervise(
    children: Sequence[Supervised],
    policy: RestartPolicy,
    stop: Stop,
    look: Callable[[], float | None],
    *,
    reap: Callable[[], None] | None = None,
    started: Callable[[], None] | None = None,
) -> int:
    """Start every child at once, then restart those that die, until ``stop`` (status 0) or
    until one cannot start as configured (EXIT_CONFIG: it has said why on stderr). ``reap``,
    after each wake-up's restarts: what else the caller tends (the launcher reaps the
    processes it adopted and no child knows). ``started``, once every child has had its
    first start (the launcher lets its warm parent go).

    Sleeps until a child exits, a restart is due, ``stop``, or the time ``look`` asked to run
    again: it runs once at the start and returns the next time.monotonic() it wants, or None
    when it has nothing more to watch. A cell that runs wakes its launcher for nothing."""
    if stop.is_set():  # stopped while the router started: nothing to start
        return 0
    try:
        for child in children:
            child.start()  # a start a stop interrupts raises (StoppedWaiting)
        if started is not None:
            started()
        next_look = look()
        while True:
            _sleep(children, stop, [next_look, policy.next_restart()])
            if stop.is_set():
                return 0
            now = time.monotonic()
            if next_look is not None and now >= next_look:
                next_look = look()
            if _tend(children, policy, now) is Restart.GIVE_UP:
                return EXIT_CONFIG
            if reap is not None:
                reap()
    finally:
        for child in children:
            child.forget()


def _sleep(children: Sequence[Supervised], stop: Stop, deadlines: list[float | None]) -> None:
    """Until a live child exits, ``stop``, or the earliest of ``deadlines``."""
    poller = select.poll()
    poller.register(stop.fileno(), select.POLLIN)
    for child in children:
        if child.exited is not None:
            poller.register(child.exited, select.POLLIN)
    due = [deadline for deadline in deadlines if deadline is not None]
    wait = None if not due else max(0.0, min(due) - time.monotonic())
    poller.poll(None if wait is None else math.ceil(wait * 1000))


def _tend(children: Sequence[Supervised], policy: RestartPolicy, now: float) -> Restart | None:
    """Note the children found dead and restart those whose time has come; GIVE_UP when one
    cannot start as configured."""
    for child in children:
        if child.alive():
            continue
        child.forget()  # its exit is known: the exit descriptor would stay readable
        action = policy.dead(child.name, now, child.returncode)
        if action is Restart.GIVE_UP:
            log.error("%s cannot start as configured; stopping the cell", child.name)
            return action
        if action is Restart.NOTICED:
            log.error(
                "%s exited (code %s); restarting in %.0f s; the cell is NOT_READY until it is back",
                child.name,
                child.returncode,
                policy.delay_s,
            )
        elif action is Restart.NOW:
            child.start()
    return None
