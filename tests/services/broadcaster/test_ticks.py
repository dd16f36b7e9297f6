"""The tick source against a scripted bus: the executor's ticks come straight from the channel,
the newest only; without ticks, the reader wakes at the deadline it set (by the waker's
doorbell while ticks are expected, by its own sleep at rest), when rung and at stop."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest

from motocell.services.broadcaster.ticks import CHANNEL_SIZE, TickSource
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Tick, encode
from motocell.shared.service import StopFlag
from tests.services.broadcaster.fake_bus import FakeBus
from tests.services.broadcaster.scripted import tick
from tests.services.fakes import FakeChannel

KEYS = CellKeys("c1")
SOON_S = 0.05
WAIT_S = 5.0
"""Deadline for what another thread is expected to do soon (generous for a loaded host)."""


@pytest.fixture
def bus() -> FakeBus:
    return FakeBus()


@pytest.fixture
def stop() -> StopFlag:
    return StopFlag()


@pytest.fixture
def source(bus: FakeBus, stop: StopFlag) -> Iterator[TickSource]:
    ticks = TickSource(bus, KEYS, stop)
    ticks.start()
    yield ticks
    stop.set()
    ticks.close()


def channel(bus: FakeBus) -> FakeChannel:
    return bus.channels[KEYS.executor_tick]


def test_the_ticks_wait_in_a_ring_channel_of_their_own(bus: FakeBus, source: TickSource) -> None:
    assert list(bus.channels) == [KEYS.executor_tick]
    assert channel(bus).size == CHANNEL_SIZE


@pytest.mark.parametrize("ticks_expected", [True, False])
def test_a_deadline_wakes_the_reader_without_a_tick(
    source: TickSource, ticks_expected: bool
) -> None:
    assert source.next(time.monotonic() + SOON_S, ticks_expected) is None


def test_while_ticks_are_expected_the_deadline_rings_the_doorbell(
    bus: FakeBus, source: TickSource
) -> None:
    assert source.next(time.monotonic() + SOON_S, ticks_expected=True) is None
    assert channel(bus).rung == 1


@pytest.mark.parametrize("ticks_expected", [True, False])
def test_a_ring_wakes_the_reader(source: TickSource, ticks_expected: bool) -> None:
    source.ring()
    assert source.next(None, ticks_expected) is None


@pytest.mark.parametrize("ticks_expected", [True, False])
def test_the_newest_tick_is_taken_and_older_ones_and_doorbells_dropped(
    bus: FakeBus, source: TickSource, ticks_expected: bool
) -> None:
    for number in (100, 101):
        bus.publish(KEYS.executor_tick, encode(tick(number)))
    channel(bus).ring()
    bus.publish(KEYS.executor_tick, encode(tick(102)))
    channel(bus).ring()
    got = source.next(time.monotonic(), ticks_expected)
    assert got is not None and got.tick == 102
    assert channel(bus).try_recv() is None


def test_an_undecodable_tick_is_dropped(bus: FakeBus, source: TickSource) -> None:
    bus.publish(KEYS.executor_tick, b"\x93\x01")
    assert source.next(None, ticks_expected=True) is None
    bus.publish(KEYS.executor_tick, encode(tick(7)))
    got = source.next(None, ticks_expected=True)
    assert got is not None and got.tick == 7


@pytest.mark.parametrize("ticks_expected", [True, False])
def test_stop_wakes_the_reader(bus: FakeBus, ticks_expected: bool) -> None:
    stop = StopFlag()
    source = TickSource(bus, KEYS, stop)
    source.start()
    stop.set()
    assert source.next(None, ticks_expected) is None
    source.close()
    assert channel(bus).closed


def test_at_rest_a_tick_ends_the_sleep_at_once(bus: FakeBus, source: TickSource) -> None:
    """Parked on the tick key: the resent resting tick, or a motion's first, is taken when it
    comes, not at the next beat."""
    got: list[Tick | None] = []
    sleeping = threading.Thread(
        target=lambda: got.append(source.next(time.monotonic() + 60, ticks_expected=False))
    )
    sleeping.start()
    deadline = time.monotonic() + WAIT_S
    while not bus.callbacks.get(KEYS.executor_tick):
        assert time.monotonic() < deadline, "the resting reader never parked"
        time.sleep(0.001)
    bus.publish(KEYS.executor_tick, encode(tick(5)))
    sleeping.join(WAIT_S)
    assert not sleeping.is_alive()
    assert [t.tick for t in got if t is not None] == [5]
    assert source.next(time.monotonic(), ticks_expected=True) is None
    assert not bus.callbacks.get(KEYS.executor_tick), "unparked once ticks are expected"


def test_at_rest_a_tick_that_came_before_the_sleep_ends_it_at_once(
    bus: FakeBus, source: TickSource
) -> None:
    bus.publish(KEYS.executor_tick, encode(tick(6)))
    got: list[Tick | None] = []
    sleeping = threading.Thread(
        target=lambda: got.append(source.next(time.monotonic() + 60, ticks_expected=False))
    )
    sleeping.start()
    sleeping.join(WAIT_S)
    assert not sleeping.is_alive()
    assert [t.tick for t in got if t is not None] == [6]
