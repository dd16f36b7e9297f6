"""What a test asks of a running cell, from the samples its bus carries: the newest state, the
ticks of the last motion (from the first moving tick after a rest), a rest after the call."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import pytest
import zenoh

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import (
    GroupState,
    GroupTick,
    RobotStatusFields,
    State,
    Tick,
    encode,
)
from motocell.testing.observer import CellObserver

KEYS = CellKeys("c")


@dataclass
class Payload:
    data: bytes

    def to_bytes(self) -> bytes:
        return self.data


@dataclass
class Sample:
    payload: Payload


class Bus:
    """The subscribers a session would hold, and a way to deliver samples to them."""

    def __init__(self) -> None:
        self.callbacks: dict[str, Callable[[Any], None]] = {}

    def declare_subscriber(self, key: str, callback: Callable[[Any], None]) -> None:
        self.callbacks[key] = callback

    def put(self, key: str, item: State | Tick) -> None:
        self.callbacks[key](Sample(Payload(encode(item))))


@pytest.fixture
def bus() -> Bus:
    return Bus()


@pytest.fixture
def observer(bus: Bus) -> CellObserver:
    return CellObserver(cast(zenoh.Session, bus), KEYS)


def tick(number: int, increment: int = 0, resting: bool = False) -> Tick:
    group = GroupTick([number] * 6, [number] * 6, [increment] * 6, 0, [0.0] * 6)
    return Tick(number, number, 0, 0, True, [group], resting)


def test_the_newest_state_is_the_one_given(bus: Bus, observer: CellObserver) -> None:
    status = RobotStatusFields(1, 0, 0, 0, 0, 1, 1)
    for seq in (1, 2):
        positions = [0.1 * seq] * 6
        bus.put(KEYS.state, State(seq, seq, 0, [GroupState(0, positions, [0.0] * 6, [])], status))
    assert observer.state(0.0).seq == 2


def test_no_state_yet_times_out(observer: CellObserver) -> None:
    with pytest.raises(TimeoutError, match="a state snapshot"):
        observer.state(0.0)


def test_the_last_motion_starts_at_the_first_moving_tick_after_a_rest(
    bus: Bus, observer: CellObserver
) -> None:
    assert observer.last_motion() == []
    for item in (tick(1, 5), tick(2, 5), tick(3), tick(4, resting=True), tick(5, 7)):
        bus.put(KEYS.executor_tick, item)
    bus.put(KEYS.executor_tick, tick(6))
    bus.put(KEYS.executor_tick, tick(7, 7))
    assert [t.tick for t in observer.last_motion()] == [5, 7]


def test_a_rest_counts_only_when_a_resting_tick_arrives_after_the_call(
    bus: Bus, observer: CellObserver
) -> None:
    bus.put(KEYS.executor_tick, tick(1, resting=True))
    with pytest.raises(TimeoutError, match="clock to rest"):
        observer.wait_at_rest(0.0)
    later = threading.Timer(0.05, bus.put, (KEYS.executor_tick, tick(1, resting=True)))
    later.start()
    try:
        observer.wait_at_rest(30.0)
    finally:
        later.join()
