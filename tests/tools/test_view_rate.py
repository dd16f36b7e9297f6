"""The view's pacing (``tools.view_rate``) on instants given by hand, and its forwarder's thread
(``tools.view_forward``) on a clock the test moves: each key at most once a period, always
its newest sample, and one busy key never holding back another."""

from __future__ import annotations

import threading

import pytest

from motocell.shared.service import StopFlag
from motocell.testing.processes import wait_until
from motocell.tools.view_forward import PacedForwarder
from motocell.tools.view_rate import Pacing, Sample

PERIOD_NS = 1_000
DEADLINE_S = 10.0
"""For a thread that an idle machine wakes at once: a bound for a hang, not a speed."""


def sample(key: str, n: int) -> Sample:
    return Sample(n, key, str(n).encode())


def test_a_quiet_key_goes_out_at_once_and_then_once_a_period() -> None:
    pacing = Pacing(PERIOD_NS)
    assert pacing.offer(sample("a", 1))
    assert pacing.due(0) == [sample("a", 1)]
    assert pacing.next_due_ns() is None
    assert pacing.offer(sample("a", 2))
    assert not pacing.offer(sample("a", 3)), "a key already waiting wakes nobody"
    assert pacing.due(PERIOD_NS - 1) == []
    assert pacing.next_due_ns() == PERIOD_NS
    assert pacing.due(PERIOD_NS) == [sample("a", 3)], "the newest, the one before dropped"
    assert pacing.due(10 * PERIOD_NS) == []


def test_a_source_faster_than_the_rate_is_sent_at_the_rate() -> None:
    """Samples every tenth of a period for 100 periods: 100 sent, each the newest there was."""
    pacing = Pacing(PERIOD_NS)
    sent: list[Sample] = []
    for now in range(0, 100 * PERIOD_NS, PERIOD_NS // 10):
        pacing.offer(sample("tick", now))
        sent += pacing.due(now)
    assert len(sent) == 100
    assert [s.received_ns for s in sent] == list(range(0, 100 * PERIOD_NS, PERIOD_NS))


def test_a_source_slower_than_the_rate_loses_nothing() -> None:
    pacing = Pacing(PERIOD_NS)
    sent = []
    for now in range(0, 50 * PERIOD_NS, 3 * PERIOD_NS // 2):
        pacing.offer(sample("state", now))
        sent += pacing.due(now)
    assert len(sent) == len(range(0, 50 * PERIOD_NS, 3 * PERIOD_NS // 2))


def test_a_busy_key_does_not_hold_back_another() -> None:
    """However many ticks come, the status offered once goes out in the same turn."""
    pacing = Pacing(PERIOD_NS)
    pacing.offer(sample("tick", 0))
    pacing.due(0)
    for n in range(1, 1000):
        pacing.offer(sample("tick", n))
    pacing.offer(sample("status", 5))
    assert pacing.due(1) == [sample("status", 5)]
    assert pacing.due(PERIOD_NS) == [sample("tick", 999)]


def test_the_period_must_be_positive() -> None:
    with pytest.raises(ValueError, match="positive"):
        Pacing(0)


class Clock:
    """A monotonic clock the test moves."""

    def __init__(self) -> None:
        self.ns = 0

    def __call__(self) -> int:
        return self.ns


class Written:
    def __init__(self) -> None:
        self.samples: list[Sample] = []
        self._lock = threading.Lock()

    def __call__(self, received_ns: int, key: str, data: bytes) -> None:
        with self._lock:
            self.samples.append(Sample(received_ns, key, data))

    def keys(self) -> list[str]:
        with self._lock:
            return [s.key for s in self.samples]


def test_the_forwarder_sends_the_newest_of_each_key_when_its_period_has_passed() -> None:
    clock, written = Clock(), Written()
    forwarder = PacedForwarder(written, rate_hz=10.0, stop=StopFlag(), clock=clock)
    forwarder.start()
    try:
        forwarder.offer(sample("a", 1))
        wait_until(lambda: written.keys() == ["a"], DEADLINE_S, "the first sample")
        for n in (2, 3):
            forwarder.offer(sample("a", n))
        forwarder.offer(sample("b", 1))
        wait_until(lambda: written.keys() == ["a", "b"], DEADLINE_S, "the other key's")
        # A period at 10 Hz: the forwarder reads the clock again when its timed wait (0.1 s
        # of real time) ends.
        clock.ns = 100_000_000
        wait_until(lambda: len(written.keys()) == 3, DEADLINE_S, "the newest of the first key")
    finally:
        forwarder.close()
    assert written.samples[2] == sample("a", 3)
    assert forwarder.error is None


def test_a_write_that_raises_stops_the_view_with_its_error() -> None:
    def broken(received_ns: int, key: str, data: bytes) -> None:
        raise RuntimeError("a bug")

    stop = StopFlag()
    forwarder = PacedForwarder(broken, rate_hz=10.0, stop=stop)
    forwarder.start()
    try:
        forwarder.offer(sample("a", 1))
        assert stop.wait(DEADLINE_S)
    finally:
        forwarder.close()
    assert str(forwarder.error) == "a bug"
