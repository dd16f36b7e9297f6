"""``Inputs`` on a scripted bus: what it subscribes to, how it reads points, batches, statuses
and STOP_MOTION (garbage included), when a resting clock is woken and when not, and the one
question it asks at start."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator

import pytest

from motocell.services.executor.controller_token import CHANNEL_DEPTH as TOKEN_DEPTH
from motocell.services.executor.inputs import CHANNEL_DEPTH, Inputs
from motocell.shared.bus import ignored
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.liveness import QUERY_TIMEOUT_S
from motocell.shared.bus.schemas import CommandReply, IncrementBatch, Point, encode
from motocell.shared.protocol.constants import Result
from motocell.shared.service import StopFlag
from tests.services.executor.core.test_executor import batch, status, unit
from tests.services.executor.fake_bus import WAIT_S, FakeBus

KEYS = CellKeys("cell1")
GROUPS = 2
GARBAGE = b"\xc1\xff not msgpack"


class Harness:
    def __init__(self) -> None:
        self.bus = FakeBus()
        self.stop = StopFlag()
        self.inputs = Inputs(self.bus, KEYS, GROUPS, self.stop)
        self.inputs.start()
        [self.doorbell] = self.bus.doorbells
        self.points = self.bus.channel_of(KEYS.group_point_all)
        self._resting: threading.Thread | None = None

    def close(self) -> None:
        self.stop.set()
        self.inputs.close()

    def point(self, group: int, point_id: int = 1) -> None:
        point = Point(point_id, 1, 0.1, [], [], epoch=7)
        self.bus.publish(KEYS.group_point(group), encode(point))

    def status(self, ready: bool) -> None:
        self.bus.publish(KEYS.controller_status, encode(status(ready)))

    def rest(self, deadline_s: float | None = None) -> None:
        """``Inputs.rest`` on a thread of its own, as the clock's; returns once it is parked
        (with no deadline) or at once (with one, which may have passed by then)."""
        deadline = time.monotonic() + 60 if deadline_s is None else deadline_s
        self._resting = threading.Thread(target=self.inputs.rest, args=(deadline,))
        self._resting.start()
        if deadline_s is None:
            self.wait_parked()

    def parked(self) -> bool:
        return self.bus.subscribed(KEYS.group_point_all) == 1

    def wait_parked(self) -> None:
        deadline = time.monotonic() + WAIT_S
        while not self.parked():
            assert time.monotonic() < deadline, "the resting clock never parked"
            time.sleep(0.001)

    def woken(self) -> bool:
        """Whether the rest ended (waiting up to ``WAIT_S`` for it)."""
        assert self._resting is not None
        self._resting.join(WAIT_S)
        return not self._resting.is_alive()

    def still_resting(self) -> bool:
        assert self._resting is not None
        return self._resting.is_alive() and self.parked()


@pytest.fixture
def harness() -> Iterator[Harness]:
    harness = Harness()
    yield harness
    harness.close()


def test_what_it_reads_and_how(harness: Harness) -> None:
    bus = harness.bus
    assert [(channel.key, channel.depth) for channel in bus.channels] == [
        (KEYS.group_point_all, CHANNEL_DEPTH),
        *((KEYS.group_increments(group), CHANNEL_DEPTH) for group in range(GROUPS)),
    ]
    assert list(bus.callbacks) == [KEYS.controller_status]
    assert list(bus.queryables) == [KEYS.executor_cmd("stop")]
    assert [(c.key, c.depth) for c in bus.token_channels] == [
        (KEYS.alive("controller", "0"), TOKEN_DEPTH)
    ]
    assert harness.doorbell.key == KEYS.group_point(0), "rings the channel rest blocks on"


def test_points_come_with_their_group_in_order(harness: Harness) -> None:
    harness.point(1, point_id=5)
    harness.point(0, point_id=6)
    assert [(group, point.point_id) for group, point in harness.inputs.points()] == [
        (1, 5),
        (0, 6),
    ]
    assert list(harness.inputs.points()) == []


def test_a_point_that_does_not_decode_is_left_out_and_logged(
    harness: Harness, caplog: pytest.LogCaptureFixture
) -> None:
    harness.bus.publish(KEYS.group_point(1), GARBAGE)
    harness.point(0)
    with caplog.at_level(logging.WARNING):
        assert [group for group, _ in harness.inputs.points()] == [0]
    assert f"undecodable sample on {KEYS.group_point(1)} ignored" in caplog.text


@pytest.mark.parametrize("group", ["*", "2", "-1", "01", "1 ", "\u0661", "99999999999999999999"])
def test_a_point_for_no_group_of_the_cell_is_left_out_counted_and_logged_once(
    harness: Harness, group: str, caplog: pytest.LogCaptureFixture
) -> None:
    key = f"{KEYS.prefix}/group/{group}/point"
    for _ in range(100):
        harness.bus.publish(key, encode(Point(1, 1, 0.1, [], [], epoch=7)))
    harness.point(0)
    with caplog.at_level(logging.WARNING):
        assert [group for group, _ in harness.inputs.points()] == [0]
    assert [record.getMessage() for record in caplog.records] == [
        f"point for no group of this cell on {key} ignored"
    ]
    assert ignored.IGNORED.total == 100


def test_a_doorbell_is_no_point(harness: Harness) -> None:
    harness.doorbell.ring()
    assert list(harness.inputs.points()) == []


def test_batches_are_read_per_group_and_garbage_is_none(harness: Harness) -> None:
    sent = batch(7, 0, [unit(1)] * 2)
    harness.bus.publish(KEYS.group_increments(1), encode(sent))
    harness.bus.publish(KEYS.group_increments(1), GARBAGE)
    assert list(harness.inputs.batches(0)) == []
    got: list[IncrementBatch | None] = list(harness.inputs.batches(1))
    assert got == [sent, None]


def test_statuses_come_in_order_with_when_they_arrived(harness: Harness) -> None:
    before = time.monotonic_ns()
    harness.status(True)
    harness.status(False)
    statuses = list(harness.inputs.statuses())
    assert [sent.motion_ready for _, sent in statuses] == [True, False]
    arrived = [at for at, _ in statuses]
    assert before <= arrived[0] <= arrived[1] <= time.monotonic_ns()
    assert list(harness.inputs.statuses()) == []


def test_a_status_that_does_not_decode_is_ignored(
    harness: Harness, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING):
        harness.bus.publish(KEYS.controller_status, GARBAGE)
    assert list(harness.inputs.statuses()) == []
    assert f"undecodable sample on {KEYS.controller_status} ignored" in caplog.text


def test_stop_motion_queries_are_kept_in_order(harness: Harness) -> None:
    first = harness.bus.ask(KEYS.executor_cmd("stop"))
    second = harness.bus.ask(KEYS.executor_cmd("stop"))
    assert list(harness.inputs.stop_queries()) == [first, second]
    assert list(harness.inputs.stop_queries()) == []
    assert first.replies == [], "answered by the outputs, once the rings are cleared"


# -- rest -------------------------------------------------------------------------------------


def test_a_point_ends_a_rest_and_is_the_first_read(harness: Harness) -> None:
    harness.rest()
    harness.point(1, point_id=3)
    assert harness.woken()
    harness.point(0, point_id=4)
    assert [(group, point.point_id) for group, point in harness.inputs.points()] == [
        (1, 3),
        (0, 4),
    ]


def test_a_status_that_changes_readiness_ends_a_rest(harness: Harness) -> None:
    harness.inputs.executor_ready = True
    harness.rest()
    harness.status(True)
    assert harness.doorbell.rung == 0, "what the executor knows already wakes nobody"
    assert harness.still_resting()
    harness.status(False)
    assert harness.woken()
    assert [sent.motion_ready for _, sent in harness.inputs.statuses()] == [True, False]


def test_stop_motion_ends_a_rest(harness: Harness) -> None:
    harness.rest()
    query = harness.bus.ask(KEYS.executor_cmd("stop"))
    assert harness.woken()
    assert list(harness.inputs.stop_queries()) == [query]


def test_a_rest_waits_parked_and_the_clock_running_again_unparks(harness: Harness) -> None:
    """A rest polls a pipe, never the channel's recv (whose 100 ms slices would wake it), and
    the callback that tells the pipe stays declared across rests, until the clock runs."""
    harness.rest()
    assert harness.points.waiting == 0
    harness.point(0)
    assert harness.woken()
    assert harness.parked()
    harness.rest(time.monotonic())
    assert harness.woken()
    assert harness.parked()
    harness.inputs.awake()
    assert not harness.parked()
    harness.point(1)  # while the clock runs: no callback for points
    assert [group for group, _ in harness.inputs.points()] == [0, 1]


def test_a_point_before_the_parking_ends_the_rest_at_once(harness: Harness) -> None:
    harness.point(1, point_id=5)
    harness.rest(time.monotonic() + 60)
    assert harness.woken(), "the point already in the channel is read after parking"
    assert [point.point_id for _, point in harness.inputs.points()] == [5]


def test_a_rest_ends_at_its_deadline(harness: Harness) -> None:
    harness.rest(time.monotonic())
    assert harness.woken()
    assert harness.doorbell.rung == 1


def test_a_rest_ends_at_the_stop(harness: Harness) -> None:
    harness.rest()
    harness.stop.set()
    assert harness.woken()


def test_what_came_before_the_rest_ends_it_at_once(harness: Harness) -> None:
    harness.status(True)
    harness.inputs.rest(time.monotonic() + 60)
    assert harness.doorbell.rung == 0
    list(harness.inputs.statuses())
    harness.bus.ask(KEYS.executor_cmd("stop"))
    harness.inputs.rest(time.monotonic() + 60)
    assert harness.doorbell.rung == 0


def test_nothing_rings_the_doorbell_while_the_clock_runs(harness: Harness) -> None:
    harness.status(True)
    harness.bus.ask(KEYS.executor_cmd("stop"))
    assert harness.doorbell.rung == 0


# -- at start -----------------------------------------------------------------------------


def test_the_remembered_positions_are_the_broadcasters_answer(harness: Harness) -> None:
    key = KEYS.broadcaster_cmd("positions")
    remembered = CommandReply(Result.SUCCESS, pulses=[[1] * 8, [2] * 8])
    harness.bus.call_replies[key] = remembered
    assert harness.inputs.remembered_positions() == remembered
    assert harness.bus.calls == [(key, QUERY_TIMEOUT_S)]


def test_no_remembered_positions_when_nobody_answers(harness: Harness) -> None:
    assert harness.inputs.remembered_positions() is None
