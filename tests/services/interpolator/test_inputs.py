"""The interpolator's inputs on a scripted bus: what wakes a wait (a point, a queue state, the
deadline, a stop) and what each read gives (the newest queue state and status, the points in
order, doorbells and garbage skipped). The waker is real: its thread rings the fake doorbells."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest

from motocell.services.interpolator.inputs import PARK_AFTER_S, Inputs
from motocell.shared.bus import ignored
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Point, encode
from motocell.shared.service import StopFlag
from motocell.testing.statuses import ready_status
from tests.services.interpolator.core.test_feeder import point, state
from tests.services.interpolator.fake_bus import WAIT_S, FakeBus

KEYS = CellKeys("cell1")
GROUP = 1
POINT_KEY = KEYS.group_point(GROUP)
AXES = 6
QUEUE_KEY = KEYS.group_queue(GROUP)


def later() -> float:
    """A deadline that does not come within a test."""
    return time.monotonic() + 3600


class Running:
    def __init__(self) -> None:
        self.bus = FakeBus()
        self.stop = StopFlag()
        self.now = time.monotonic()
        self.inputs = Inputs(self.bus, KEYS, GROUP, AXES, self.stop, clock=lambda: self.now)
        self.inputs.start()

    def parked(self) -> bool:
        return len(self.bus.callbacks.get(POINT_KEY, [])) == 1

    def wait_in_thread(self) -> threading.Thread:
        waiting = threading.Thread(target=self.inputs.wait, args=(False, later()))
        waiting.start()
        return waiting


@pytest.fixture
def running() -> Iterator[Running]:
    r = Running()
    yield r
    r.stop.set()
    r.inputs.close()


def test_a_point_ends_the_wait_and_the_points_come_in_order(
    running: Running, caplog: pytest.LogCaptureFixture
) -> None:
    bus, inputs = running.bus, running.inputs
    bus.publish(POINT_KEY, encode(point(1, 0, 0.0)))
    bus.publish(POINT_KEY, b"")  # a doorbell rung before
    bus.publish(POINT_KEY, b"\xc1")  # not msgpack
    bus.publish(POINT_KEY, encode(point(2, 1, 0.1)))
    inputs.wait(for_ring=False, deadline=later())
    assert [p.point_id for p in inputs.points()] == [1, 2]
    assert list(inputs.points()) == []
    assert f"undecodable sample on {POINT_KEY} ignored" in caplog.text


def test_waiting_for_the_ring_ends_with_a_queue_state_and_the_newest_is_read(
    running: Running,
) -> None:
    bus, inputs = running.bus, running.inputs
    bus.publish(QUEUE_KEY, encode(state(received=1)))
    inputs.wait(for_ring=True, deadline=later())
    bus.publish(QUEUE_KEY, encode(state(received=2)))  # arrived while the pass ran
    newest = inputs.queue()
    assert newest is not None
    assert newest.received == 2
    assert inputs.queue() is None


def test_the_queue_state_that_ended_the_wait_is_read_when_nothing_newer_came(
    running: Running,
) -> None:
    bus, inputs = running.bus, running.inputs
    bus.publish(QUEUE_KEY, encode(state(received=1)))
    inputs.wait(for_ring=True, deadline=later())
    woken_by = inputs.queue()
    assert woken_by is not None
    assert woken_by.received == 1
    assert inputs.queue() is None


def test_a_waiting_point_is_not_read_as_a_queue_state(running: Running) -> None:
    bus, inputs = running.bus, running.inputs
    bus.publish(POINT_KEY, encode(point(1, 0, 0.0)))
    bus.publish(QUEUE_KEY, encode(state()))
    inputs.wait(for_ring=True, deadline=later())
    assert inputs.queue() == state()
    assert [p.point_id for p in inputs.points()] == [1]


@pytest.mark.parametrize(("for_ring", "key"), [(False, POINT_KEY), (True, QUEUE_KEY)])
def test_the_deadline_rings_the_channel_waited_on(
    running: Running, for_ring: bool, key: str
) -> None:
    bus, inputs = running.bus, running.inputs
    inputs.wait(for_ring=for_ring, deadline=time.monotonic())
    assert {k: bell.rung for k, bell in bus.doorbells.items()} == {
        POINT_KEY: int(key == POINT_KEY),
        QUEUE_KEY: int(key == QUEUE_KEY),
    }
    assert inputs.queue() is None
    assert list(inputs.points()) == []


def test_a_stop_ends_the_wait(running: Running) -> None:
    ended = threading.Event()

    def wait() -> None:
        running.inputs.wait(for_ring=False, deadline=later())
        ended.set()

    waiting = threading.Thread(target=wait)
    waiting.start()
    running.stop.set()
    assert ended.wait(WAIT_S)
    waiting.join()


def test_the_newest_status_is_read_once(running: Running) -> None:
    bus, inputs = running.bus, running.inputs
    assert inputs.status() is None
    bus.publish(KEYS.controller_status, encode(ready_status(seq=1, tools=[0, 4])))
    bus.publish(KEYS.controller_status, encode(ready_status(seq=2, tools=[0, 5])))
    status = inputs.status()
    assert status is not None
    assert status.tools == [0, 5]
    assert inputs.status() is None


def test_close_undeclares_every_channel_and_closes_the_doorbells() -> None:
    r = Running()
    r.stop.set()
    r.inputs.close()
    channels = [channel for declared in r.bus.channels.values() for channel in declared]
    assert sorted(channel.key for channel in channels) == sorted(
        [POINT_KEY, QUEUE_KEY, KEYS.controller_status]
    )
    assert all(channel.undeclared for channel in channels)
    assert all(bell.closed for bell in r.bus.doorbells.values())


@pytest.mark.parametrize(
    "misfit",
    [
        point(2, 1, float("nan")),
        point(2, 1, -1.0),
        point(2, 1, 0.1, [0.0] * 3, [0.0] * 3),
        point(2, 1, 0.1, [0.0] * 6, [0.0] * 5),
        point(2, 1, 0.1, [float("inf")] + [0.0] * 5),
        point(2, 1, 0.1, velocities=[float("nan")] * 6),
    ],
)
def test_a_point_no_gateway_sends_is_ignored_and_counted(running: Running, misfit: Point) -> None:
    bus, inputs = running.bus, running.inputs
    bus.publish(POINT_KEY, encode(misfit))
    bus.publish(POINT_KEY, encode(point(3, 1, 0.2)))
    inputs.wait(for_ring=False, deadline=later())
    assert [p.point_id for p in inputs.points()] == [3]
    assert ignored.IGNORED.total == 1


def test_after_a_second_without_points_the_wait_is_parked_until_the_next_point(
    running: Running,
) -> None:
    """Parked, the thread polls a pipe (the channel's recv would wake it 10 times a second);
    the point that ends it is read as any other, and the parking ends with it."""
    bus, inputs = running.bus, running.inputs
    waiting = running.wait_in_thread()  # within a second of the start: the channel's recv
    bus.publish(POINT_KEY, encode(point(1, 0, 0.0)))
    waiting.join(WAIT_S)
    assert not waiting.is_alive()
    assert not running.parked()
    assert [p.point_id for p in inputs.points()] == [1]
    running.now += PARK_AFTER_S
    waiting = running.wait_in_thread()
    deadline = time.monotonic() + WAIT_S
    while not running.parked():
        assert time.monotonic() < deadline, "the idle wait never parked"
        time.sleep(0.001)
    assert waiting.is_alive()
    bus.publish(POINT_KEY, encode(point(2, 1, 0.1)))
    waiting.join(WAIT_S)
    assert not waiting.is_alive()
    assert [p.point_id for p in inputs.points()] == [2]
    assert not running.parked()


def test_a_parked_wait_ends_at_its_deadline_and_at_the_stop(running: Running) -> None:
    running.now += PARK_AFTER_S
    running.inputs.wait(for_ring=False, deadline=time.monotonic())
    assert running.parked()
    assert list(running.inputs.points()) == []
    waiting = running.wait_in_thread()
    running.stop.set()
    waiting.join(WAIT_S)
    assert not waiting.is_alive()


def test_a_point_that_came_before_the_parking_ends_the_wait_at_once(running: Running) -> None:
    running.bus.publish(POINT_KEY, encode(point(3, 0, 0.0)))
    running.now += PARK_AFTER_S
    waiting = running.wait_in_thread()
    waiting.join(WAIT_S)
    assert not waiting.is_alive(), "the point already in the channel is read after parking"
    assert [p.point_id for p in running.inputs.points()] == [3]
