"""Every piece of republished state the gateway decides on has an age: a queue state or a
controller status not refreshed for a few heartbeats is treated as missing, logged once, and
its stream subscribed to again until it is heard. The clock is the test's: ``Watchdog`` calls
``expire`` every heartbeat, as the adapter does."""

from __future__ import annotations

import itertools
import logging

import pytest

from motocell.services.gateway.core.cell_port import readiness
from motocell.services.gateway.core.cell_state import STATUS_STREAM, CellState, queue_stream
from motocell.services.gateway.core.freshness import STALE_HEARTBEATS
from motocell.shared.bus.liveness import HEARTBEAT_S
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.replies import motion_ctrl, traj_point
from tests.services.gateway.core.fake_cell import (
    FakeCell,
    exchange,
    gateway,
    queue,
    status,
    verdict_of,
)

INC_MOVE_ERROR = int(NotReadySubcode.INC_MOVE_ERROR)
EVERY = [STATUS_STREAM, queue_stream(0), queue_stream(1)]


class Watchdog:
    """The adapter's watchdog thread, on the test's clock."""

    def __init__(self, state: CellState) -> None:
        self.state = state
        self.now = 1000.0
        self.state.expire(self.now)

    def beat(self, seconds: float = HEARTBEAT_S) -> list[str]:
        self.now += seconds
        return self.state.expire(self.now)

    def beats(self, count: int) -> list[list[str]]:
        return [self.beat() for _ in range(count)]


def ready_cell() -> tuple[FakeCell, Watchdog]:
    cell = FakeCell(2).ready()
    return cell, Watchdog(cell.state)


def republish(state: CellState, *, queues: tuple[int, ...] = (0, 1)) -> None:
    """The controller and the executor republish what they last said."""
    state.on_status(status())
    for group in queues:
        state.on_queue(group, queue())


def test_the_age_limit_is_a_few_heartbeats() -> None:
    assert 3 <= STALE_HEARTBEATS <= 10


def test_state_republished_in_time_is_kept() -> None:
    cell, watchdog = ready_cell()
    for _ in range(20):
        assert watchdog.beats(STALE_HEARTBEATS - 1) == [[]] * (STALE_HEARTBEATS - 1)
        republish(cell.state)
    assert readiness(cell) == (True, 0)


def test_a_queue_state_not_refreshed_is_missing_and_the_cell_not_ready() -> None:
    cell, watchdog = ready_cell()
    stopped: list[str] = []
    for _ in range(STALE_HEARTBEATS - 1):
        assert watchdog.beat() == []
        republish(cell.state, queues=(0,))
    for _ in range(2):
        stopped += watchdog.beat()
        republish(cell.state, queues=(0,))

    assert stopped == [queue_stream(1)]
    assert cell.state.groups[1].queue is None
    assert cell.state.groups[0].queue is not None
    assert readiness(cell) == (False, INC_MOVE_ERROR)


def test_a_stale_controller_status_is_missing_and_ends_a_trajectory() -> None:
    cell, watchdog = ready_cell()
    count = cell.state.not_ready_count
    stopped: list[str] = []
    for _ in range(STALE_HEARTBEATS + 1):
        stopped += watchdog.beat()
        for group in range(2):
            cell.state.on_queue(group, queue())

    assert stopped == [STATUS_STREAM]
    assert cell.state.status is None
    assert cell.state.not_ready_count > count
    assert readiness(cell) == (False, INC_MOVE_ERROR)


def test_a_stopped_stream_is_logged_once_and_subscribed_again_until_heard(
    caplog: pytest.LogCaptureFixture,
) -> None:
    cell, watchdog = ready_cell()
    with caplog.at_level(logging.INFO, logger="gateway"):
        calls = watchdog.beats(4 * STALE_HEARTBEATS)
        after = []
        for _ in range(2 * STALE_HEARTBEATS):
            republish(cell.state)
            after += watchdog.beat()

    tries = [k for k, streams in enumerate(calls) if streams]
    assert [calls[k] for k in tries] == [EVERY] * len(tries)
    assert len(tries) >= 3
    assert all(b - a >= STALE_HEARTBEATS for a, b in itertools.pairwise(tries))
    assert after == []
    assert readiness(cell) == (True, 0)
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert [message.split()[0] for message in warned] == EVERY
    heard = [r.getMessage() for r in caplog.records if r.levelno == logging.INFO]
    assert heard == [f"{stream} heard again" for stream in EVERY]


def test_a_stream_never_heard_is_not_stale() -> None:
    """At start-up nothing has been heard yet: the publishers may not run yet."""
    watchdog = Watchdog(CellState(1))
    assert watchdog.beats(10 * STALE_HEARTBEATS) == [[]] * (10 * STALE_HEARTBEATS)


def test_a_stall_of_the_gateway_itself_does_not_age_the_cell() -> None:
    """What was published while the gateway was stalled is still queued behind it."""
    cell, watchdog = ready_cell()
    assert watchdog.beat(10.0) == []
    republish(cell.state)
    assert watchdog.beat() == []
    assert readiness(cell) == (True, 0)


def test_motion_is_not_ready_while_the_queue_states_are_stale() -> None:
    handler, cell = gateway()
    watchdog = Watchdog(cell.state)
    for _ in range(STALE_HEARTBEATS + 1):
        watchdog.beat()
        cell.state.on_status(status())

    ready = exchange(handler, motion_ctrl(Command.CHECK_MOTION_READY)).reply
    point = exchange(handler, traj_point(0, 0, 0.0, (0.0,) * 10, (0.0,) * 10)).reply

    assert cell.state.groups[0].queue is None
    assert verdict_of(ready) == (Result.FALSE, INC_MOVE_ERROR)
    assert verdict_of(point) == (Result.NOT_READY, INC_MOVE_ERROR)
    assert cell.sent == []
