"""The launcher's loop with scripted children, no processes: each child's exit descriptor is a
pipe the test makes readable when it "dies". The loop starts every child, sleeps until an exit,
restarts by the policy, gives up on EXIT_CONFIG, calls ``look`` only while it asks to be,
``reap`` after each wake-up and ``started`` once after the first starts, and leaves no
descriptor open, a start a stop interrupts too."""

from __future__ import annotations

import os
from collections.abc import Callable

import pytest

from motocell.services.launcher.core.restarts import RestartPolicy
from motocell.services.launcher.loop import supervise
from motocell.shared.bus.session import StoppedWaiting
from motocell.shared.config import EXIT_CONFIG
from motocell.shared.service import StopFlag


class ScriptedChild:
    """A ``Supervised`` child: alive from ``start`` until ``die``."""

    def __init__(
        self, name: str, on_start: Callable[[ScriptedChild], None] = lambda child: None
    ) -> None:
        self.name = name
        self.on_start = on_start
        self.starts = 0
        self.exited: int | None = None
        self.returncode: int | None = None
        self._running = False
        self._died: int | None = None
        self.opened: list[int] = []
        self.closed: list[int] = []

    def start(self) -> None:
        self.forget()
        self.exited, self._died = os.pipe()
        self.opened.append(self.exited)
        self._running, self.returncode = True, None
        self.starts += 1
        self.on_start(self)

    def die(self, returncode: int) -> None:
        """Exit now: the exit descriptor becomes readable, as a pidfd does."""
        assert self._died is not None
        self._running, self.returncode = False, returncode
        os.write(self._died, b"\0")

    def alive(self) -> bool:
        return self._running

    def forget(self) -> None:
        if self.exited is not None:
            assert self._died is not None
            os.close(self.exited)
            os.close(self._died)
            self.closed.append(self.exited)
            self.exited = self._died = None


def test_nothing_is_started_once_a_stop_was_asked() -> None:
    children = [ScriptedChild("controller/0")]
    stop = StopFlag()
    stop.set()
    assert supervise(children, RestartPolicy(), stop, lambda: None) == 0
    assert children[0].starts == 0


def test_every_child_is_started_and_a_stop_ends_the_loop() -> None:
    children = [ScriptedChild("controller/0"), ScriptedChild("gateway/0")]
    stop = StopFlag()
    assert supervise(children, RestartPolicy(), stop, stop.set) == 0
    assert [child.starts for child in children] == [1, 1]
    assert all(child.exited is None for child in children)


def test_a_child_that_dies_wakes_the_loop_and_is_started_again() -> None:
    stop = StopFlag()

    def started(child: ScriptedChild) -> None:
        if child.starts == 1:
            child.die(3)  # at once: only its exit can wake the loop, which waits for nothing else
        else:
            stop.set()

    children = [ScriptedChild("controller/0"), ScriptedChild("gateway/0", started)]
    assert supervise(children, RestartPolicy(delay_s=0.0), stop, lambda: None) == 0
    assert [child.starts for child in children] == [1, 2]
    gateway = children[1]
    assert gateway.closed == gateway.opened, "every exit descriptor closed"


def test_a_child_that_cannot_start_as_configured_stops_the_loop_without_a_restart() -> None:
    children = [
        ScriptedChild("controller/0"),
        ScriptedChild("gateway/0", lambda child: child.die(EXIT_CONFIG)),
    ]
    status = supervise(children, RestartPolicy(delay_s=0.0), StopFlag(), lambda: None)
    assert status == EXIT_CONFIG
    assert [child.starts for child in children] == [1, 1]
    assert all(child.exited is None for child in children)


def test_look_is_not_called_again_once_it_asks_for_nothing() -> None:
    stop = StopFlag()
    looks: list[int] = []

    def started(child: ScriptedChild) -> None:
        if child.starts < 3:
            child.die(1)
        else:
            stop.set()

    children = [ScriptedChild("gateway/0", started)]

    def look() -> float | None:
        looks.append(children[0].starts)
        return None

    assert supervise(children, RestartPolicy(delay_s=0.0), stop, look) == 0
    assert children[0].starts == 3
    assert looks == [1]


def test_look_runs_again_each_time_it_is_due() -> None:
    stop = StopFlag()
    looks: list[int] = []
    children = [ScriptedChild("gateway/0")]

    def look() -> float | None:
        looks.append(len(looks))
        if len(looks) == 3:
            stop.set()
            return None
        return 0.0  # long past: due at once

    assert supervise(children, RestartPolicy(), stop, look) == 0
    assert looks == [0, 1, 2]
    assert children[0].starts == 1


def test_reap_runs_after_each_wake_ups_restarts() -> None:
    stop = StopFlag()
    reaped_at: list[int] = []
    children = [
        ScriptedChild("gateway/0", lambda child: child.die(1) if child.starts < 3 else None)
    ]

    def reap() -> None:
        reaped_at.append(children[0].starts)
        if children[0].starts == 3:
            stop.set()

    assert supervise(children, RestartPolicy(delay_s=0.0), stop, lambda: None, reap=reap) == 0
    # Each death: a wake-up that notices it, one that restarts it; reap sees the restart.
    assert reaped_at == [1, 2, 2, 3]


def test_started_is_told_once_after_every_first_start_and_before_any_restart() -> None:
    stop = StopFlag()
    children = [
        ScriptedChild("gateway/0", lambda child: child.die(1) if child.starts < 2 else None),
        ScriptedChild("controller/0"),
    ]
    told: list[list[int]] = []

    def reap() -> None:
        if children[0].starts == 2:
            stop.set()

    def started() -> None:
        told.append([child.starts for child in children])

    policy = RestartPolicy(delay_s=0.0)
    assert supervise(children, policy, stop, lambda: None, reap=reap, started=started) == 0
    assert told == [[1, 1]]  # once, before the gateway's restart
    assert children[0].starts == 2


def test_a_start_a_stop_interrupts_leaves_no_descriptor_open() -> None:
    def interrupted(child: ScriptedChild) -> None:
        raise StoppedWaiting

    children = [ScriptedChild("controller/0"), ScriptedChild("gateway/0", interrupted)]
    with pytest.raises(StoppedWaiting):
        supervise(children, RestartPolicy(), StopFlag(), lambda: None)
    assert all(child.closed == child.opened for child in children)
