"""``StateFeed`` over a scripted channel: the newest sample of those waiting, garbage and
doorbells skipped, and a wake-up at the deadline it is given."""

from __future__ import annotations

import time

from motocell.services.ros2.bus import CHANNEL_SIZE, StateFeed
from motocell.shared.bus.adapters import Channel, Latest
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import encode
from motocell.shared.service import StopFlag
from tests.services.broadcaster.fake_bus import FakeLatest
from tests.services.fakes import FakeChannel
from tests.services.ros2.scripted import MS, face_cell, sample

KEYS = CellKeys("face")
CELL = face_cell()


class OneChannelBus:
    def __init__(self) -> None:
        self.opened: FakeChannel | None = None
        self.latests: list[FakeLatest] = []

    def channel(self, key: str, size: int) -> Channel:
        self.opened = FakeChannel(key, size)
        return self.opened

    def latest(self, key: str) -> Latest:
        self.latests.append(FakeLatest(key))
        return self.latests[-1]

    def ask(self, key: str, payload: bytes, timeout: float) -> bytes | None:
        raise AssertionError("the state feed asks nothing")


def feed() -> tuple[StateFeed, FakeChannel, StopFlag]:
    bus, stop = OneChannelBus(), StopFlag()
    state_feed = StateFeed(bus, KEYS, stop)
    assert bus.opened is not None and (bus.opened.key, bus.opened.size) == (
        KEYS.state,
        CHANNEL_SIZE,
    )
    state_feed.start()
    return state_feed, bus.opened, stop


def test_the_newest_sample_waiting_is_taken_garbage_and_doorbells_skipped() -> None:
    state_feed, channel, stop = feed()
    try:
        channel.put(encode(sample(CELL, 4 * MS)))
        channel.put(encode(sample(CELL, 8 * MS)))
        channel.put(b"\xc1 not a state")
        channel.put(b"")
        state = state_feed.next(None, samples_expected=True)
        assert state is not None and state.tick_ns == 8 * MS
    finally:
        stop.set()
        state_feed.close()


def test_a_deadline_wakes_the_feed_without_a_sample() -> None:
    state_feed, channel, stop = feed()
    try:
        assert state_feed.next(time.monotonic_ns() + 20 * MS, samples_expected=True) is None
        assert channel.rung == 1
    finally:
        stop.set()
        state_feed.close()
    assert channel.closed


def test_while_the_cell_rests_the_feed_sleeps_to_its_deadline_without_a_doorbell() -> None:
    state_feed, channel, stop = feed()
    try:
        channel.put(encode(sample(CELL, 4 * MS)))
        state = state_feed.next(time.monotonic_ns() + 20 * MS, samples_expected=False)
        assert state is not None and state.tick_ns == 4 * MS
        assert channel.rung == 0
    finally:
        stop.set()
        state_feed.close()
