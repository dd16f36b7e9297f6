"""Every piece of republished state the gateway decides on has an age: a queue state or a
controller status not refreshed for STALE_HEARTBEATS of the heartbeat its newest sample
announced is treated as missing, logged once, and its stream subscribed to again until it is
heard. The clock is the test's: ``Watchdog`` checks when the state says a check is due, as the
adapter's thread does, and never in between."""

from __future__ import annotations

import logging

import pytest

from motocell.services.gateway.core.cell_port import readiness
from motocell.services.gateway.core.cell_state import STATUS_STREAM, CellState, queue_stream
from motocell.services.gateway.core.freshness import LATE_CHECK_S, stale_after_s
from motocell.services.gateway.core.sources import Source
from motocell.shared.bus.liveness import (
    AT_REST_HEARTBEAT_S,
    HEARTBEAT_S,
    STALE_HEARTBEATS,
    heartbeat_ms,
)
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.replies import motion_ctrl, traj_point
from tests.services.gateway.core.fake_cell import (
    NOW,
    FakeCell,
    exchange,
    gateway,
    queue,
    slot,
    status,
    verdict_of,
)

INC_MOVE_ERROR = int(NotReadySubcode.INC_MOVE_ERROR)
EVERY = [STATUS_STREAM, queue_stream(0), queue_stream(1)]
MOVING = heartbeat_ms(motion_possible=True)
AT_REST = heartbeat_ms(motion_possible=False)
SPAN = STALE_HEARTBEATS * HEARTBEAT_S
"""How long a stream that announced the short heartbeat may stay silent."""
REST_SPAN = STALE_HEARTBEATS * AT_REST_HEARTBEAT_S


class Watchdog:
    """The adapter's watchdog thread on the test's clock: it checks at the moments the state
    plans, or at once when the state says something may be due sooner."""

    def __init__(self, state: CellState) -> None:
        self.state = state
        self.now = NOW
        self.checks: list[float] = []
        self.stopped: list[str] = []
        """Every stream to subscribe to again, in order, over every check."""
        self.planned = self.check()

    def check(self) -> float | None:
        self.checks.append(self.now)
        self.stopped += self.state.expire(self.now)
        self.state.slots_to_ask(self.now)
        self.planned = self.state.next_check()
        return self.planned

    def woken(self) -> None:
        """After samples arrived: what the adapter does when they may be due sooner."""
        if self.state.sooner():
            self.check()

    def run(self, seconds: float) -> list[str]:
        """Let ``seconds`` pass, checking on time; the streams it found to subscribe to
        again."""
        end = self.now + seconds
        before = len(self.stopped)
        while self.planned is not None and self.planned <= end:
            self.now = self.planned
            self.check()
        self.now = end
        return self.stopped[before:]

    def stall(self, seconds: float) -> list[str]:
        """The gateway stalls: the next check comes ``seconds`` after it was planned."""
        assert self.planned is not None
        self.now = self.planned + seconds
        before = len(self.stopped)
        self.check()
        return self.stopped[before:]


def republish(
    state: CellState, now: float, *, queues: tuple[int, ...] = (0, 1), heartbeat: int = MOVING
) -> None:
    """The controller and the executor republish what they last said."""
    state.on_status(status(heartbeat=heartbeat), now)
    for group in queues:
        state.on_queue(group, queue(heartbeat=heartbeat), now)


def ready_cell(heartbeat: int = MOVING) -> tuple[FakeCell, Watchdog]:
    cell = FakeCell(2).ready(heartbeat)
    return cell, Watchdog(cell.state)


def beats(watchdog: Watchdog, seconds: float, queues: tuple[int, ...] = (0, 1)) -> list[str]:
    """Run for ``seconds``, the publishers republishing every short heartbeat (the executor
    only ``queues``)."""
    stopped = []
    for _ in range(round(seconds / HEARTBEAT_S)):
        stopped += watchdog.run(HEARTBEAT_S)
        republish(watchdog.state, watchdog.now, queues=queues)
        watchdog.woken()
    return stopped


def test_the_age_limit_is_a_few_of_the_announced_heartbeats() -> None:
    assert 3 <= STALE_HEARTBEATS <= 10
    assert stale_after_s(MOVING) == pytest.approx(SPAN)
    assert stale_after_s(AT_REST) == pytest.approx(REST_SPAN)


def test_nonsense_heartbeats_are_taken_within_the_bus_range() -> None:
    """A zero heartbeat must not make the watchdog spin, a huge one must not end ageing."""
    assert stale_after_s(0) == stale_after_s(-5) == stale_after_s(MOVING)
    assert stale_after_s(10**9) == stale_after_s(AT_REST)


def test_state_republished_in_time_is_kept() -> None:
    cell, watchdog = ready_cell()
    assert beats(watchdog, 20 * SPAN) == []
    assert readiness(cell, Source.SIMPLE_MESSAGE) == (True, 0)


def test_the_watchdog_wakes_only_when_something_could_be_stale() -> None:
    """No periodic check: the next is planned when the oldest stream would turn stale."""
    _, watchdog = ready_cell()
    assert watchdog.planned == pytest.approx(watchdog.now + SPAN)
    checks = len(watchdog.checks)
    beats(watchdog, SPAN / 2)
    assert len(watchdog.checks) == checks


def test_at_rest_state_is_kept_for_five_long_heartbeats() -> None:
    cell, watchdog = ready_cell(heartbeat=AT_REST)
    assert watchdog.planned == pytest.approx(watchdog.now + REST_SPAN)
    assert watchdog.run(REST_SPAN - HEARTBEAT_S) == []
    assert cell.state.status is not None
    assert watchdog.run(HEARTBEAT_S) == EVERY


def test_a_shorter_heartbeat_brings_the_next_check_forward() -> None:
    _, watchdog = ready_cell(heartbeat=AT_REST)
    watchdog.run(1.0)
    watchdog.state.on_queue(1, queue(heartbeat=MOVING), watchdog.now)
    assert watchdog.state.sooner()
    watchdog.woken()
    assert watchdog.planned == pytest.approx(watchdog.now + SPAN)
    assert watchdog.run(SPAN) == [queue_stream(1)]


def test_a_longer_heartbeat_does_not_wake_the_watchdog() -> None:
    _, watchdog = ready_cell()
    republish(watchdog.state, watchdog.now + HEARTBEAT_S, heartbeat=AT_REST)
    assert not watchdog.state.sooner()


def test_a_queue_state_not_refreshed_is_missing_and_the_cell_not_ready() -> None:
    cell, watchdog = ready_cell()
    stopped = beats(watchdog, SPAN + HEARTBEAT_S, queues=(0,))
    assert stopped == [queue_stream(1)]
    assert cell.state.groups[1].queue is None
    assert cell.state.groups[0].queue is not None
    assert readiness(cell, Source.SIMPLE_MESSAGE) == (False, INC_MOVE_ERROR)


def test_a_stale_controller_status_is_missing_and_ends_a_trajectory() -> None:
    cell, watchdog = ready_cell()
    count = cell.state.not_ready_count
    stopped = []
    for _ in range(STALE_HEARTBEATS + 1):
        stopped += watchdog.run(HEARTBEAT_S)
        for group in range(2):
            cell.state.on_queue(group, queue(), watchdog.now)

    assert stopped == [STATUS_STREAM]
    assert cell.state.status is None
    assert cell.state.not_ready_count > count
    assert readiness(cell, Source.SIMPLE_MESSAGE) == (False, INC_MOVE_ERROR)


def test_a_stopped_stream_is_logged_once_and_subscribed_again_until_heard(
    caplog: pytest.LogCaptureFixture,
) -> None:
    cell, watchdog = ready_cell()
    with caplog.at_level(logging.INFO, logger="gateway"):
        start = len(watchdog.checks)
        stopped = watchdog.run(4 * SPAN)
        tries = watchdog.checks[start:]
        after = beats(watchdog, 2 * SPAN)

    assert stopped == EVERY * 4
    assert tries == pytest.approx([watchdog.checks[start] + k * SPAN for k in range(4)])
    assert after == []
    assert readiness(cell, Source.SIMPLE_MESSAGE) == (True, 0)
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert [message.split()[0] for message in warned] == EVERY
    heard = [r.getMessage() for r in caplog.records if r.levelno == logging.INFO]
    assert heard == [f"{stream} heard again" for stream in EVERY]


def test_a_stream_never_heard_is_not_stale_and_plans_no_check() -> None:
    """At start-up nothing has been heard yet: the publishers may not run yet."""
    state = CellState(1)
    state.on_slot(0, slot())
    watchdog = Watchdog(state)
    assert watchdog.planned is None
    assert watchdog.run(10 * REST_SPAN) == []


def test_a_stall_of_the_gateway_itself_does_not_age_the_cell() -> None:
    """What was published while the gateway was stalled is still queued behind it."""
    cell, watchdog = ready_cell()
    assert watchdog.stall(10.0) == []
    republish(cell.state, watchdog.now)
    watchdog.woken()
    assert watchdog.run(SPAN / 2) == []
    assert readiness(cell, Source.SIMPLE_MESSAGE) == (True, 0)


def test_after_a_stall_a_silent_stream_has_a_short_grace_to_be_heard() -> None:
    _, watchdog = ready_cell()
    assert watchdog.stall(10.0) == []
    assert watchdog.planned == pytest.approx(watchdog.now + LATE_CHECK_S)
    assert watchdog.run(LATE_CHECK_S) == EVERY


def test_a_check_a_little_late_counts_in_full() -> None:
    """A loaded host delays the watchdog by tens of milliseconds: not a stall."""
    _, watchdog = ready_cell()
    assert watchdog.stall(LATE_CHECK_S / 2) == EVERY


def test_motion_is_not_ready_while_the_queue_states_are_stale() -> None:
    handler, cell = gateway()
    watchdog = Watchdog(cell.state)
    for _ in range(STALE_HEARTBEATS + 1):
        watchdog.run(HEARTBEAT_S)
        cell.state.on_status(status(), watchdog.now)
        watchdog.woken()
    watchdog.run(SPAN)

    ready = exchange(handler, motion_ctrl(Command.CHECK_MOTION_READY)).reply
    point = exchange(handler, traj_point(0, 0, 0.0, (0.0,) * 10, (0.0,) * 10)).reply

    assert cell.state.groups[0].queue is None
    assert verdict_of(ready) == (Result.FALSE, INC_MOVE_ERROR)
    assert verdict_of(point) == (Result.NOT_READY, INC_MOVE_ERROR)
    assert cell.sent == []
