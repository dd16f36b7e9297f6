"""The kernel timer a waker sleeps on: a deadline fires once, at or after its instant; one
replaced before it is taken is never seen; None disarms; moving it wakes nobody."""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Iterator

import pytest

from motocell.shared.bus.channels import Waker
from motocell.shared.service import StopFlag
from motocell.shared.timerfd import DeadlineTimer

MS = 1_000_000
BOUND_MS = 5000
"""How long a test waits for what must come: a bound for a hang, not a speed."""


@pytest.fixture
def timer() -> Iterator[DeadlineTimer]:
    timer = DeadlineTimer()
    yield timer
    timer.close()


def readable(timer: DeadlineTimer, wait_ms: int) -> bool:
    poller = select.poll()
    poller.register(timer.fileno(), select.POLLIN)
    return bool(poller.poll(wait_ms))


def test_a_passed_deadline_fires_at_once_and_is_taken_once(timer: DeadlineTimer) -> None:
    timer.set(time.monotonic_ns() - MS)
    assert readable(timer, BOUND_MS)
    assert timer.take()
    assert not timer.take()
    assert not readable(timer, 0)


def test_an_instant_of_zero_fires_rather_than_disarming(timer: DeadlineTimer) -> None:
    timer.set(0)
    assert readable(timer, BOUND_MS)


def test_a_deadline_replaced_before_it_is_taken_is_not_seen(timer: DeadlineTimer) -> None:
    for replacement in (None, time.monotonic_ns() + 3600 * 1000 * MS):
        timer.set(time.monotonic_ns() - MS)
        assert readable(timer, BOUND_MS)
        timer.set(replacement)
        assert not timer.take()


def test_a_deadline_moved_later_fires_at_the_later_one(timer: DeadlineTimer) -> None:
    start = time.monotonic_ns()
    timer.set(start + 200 * MS)
    timer.set(start + 400 * MS)
    assert readable(timer, BOUND_MS)
    assert time.monotonic_ns() >= start + 400 * MS  # the kernel never fires early
    assert timer.take()


def test_the_waker_rings_at_its_deadline_and_once_more_at_stop() -> None:
    stop = StopFlag()
    rung: list[int] = []
    ring_seen = threading.Event()

    def ring() -> None:
        rung.append(time.monotonic_ns())
        ring_seen.set()

    waker = Waker(ring, stop, "test-waker")
    waker.start()
    try:
        start = time.monotonic_ns()
        # Far enough apart that a test preempted between the two calls still moves the
        # first before it passes.
        waker.wake_at((start + 200 * MS) / 1e9)
        waker.wake_at((start + 400 * MS) / 1e9)  # later: no ring at the first
        assert ring_seen.wait(BOUND_MS / 1000)
        assert len(rung) == 1 and rung[0] >= start + 400 * MS
    finally:
        stop.set()
        waker.close()
    assert len(rung) == 2
