"""The feeder's table, one test per row: a real ``Feeder`` is driven into the row's phase
through its inputs (queue states and points), the row's event is fed the same way, and what the
feeder then does is checked (its phase, the batches it sent, its slot, its counts). Each test
states its rule on its own, not by reading the table. Rows that cannot happen are tested by
feeding what would be their event: it does not happen, and handing a point over anyway is
refused as a bug."""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable

import pytest

from motocell.services.interpolator.core.feeder import MAX_BATCH, ImpossibleEventError
from motocell.services.interpolator.core.states import TRANSITIONS, FeederEvent, Phase
from motocell.shared.bus.schemas import Point, Slot
from tests.services.interpolator.core.test_feeder import (
    Harness,
    X,
    Y,
    point,
    pulses,
    rows,
    state,
    total,
)

START_BUFFER = 3
COMMAND = [1000, -2000, 3000, 0, 500, -500, 0, 0]
"""Where the robot stands when the cell starts (the ring's command pulses)."""

TESTED: set[tuple[Phase, FeederEvent]] = set()

TestFunction = Callable[..., None]


def row(phase: Phase, event: FeederEvent) -> Callable[[TestFunction], TestFunction]:
    """Mark a test as the one for the row (``phase``, ``event``)."""

    def mark(test: TestFunction) -> TestFunction:
        TESTED.add((phase, event))
        return test

    return mark


def idle() -> Harness:
    h = Harness(start_buffer_periods=START_BUFFER)
    h.queue(state(command=COMMAND))
    assert h.feeder.phase is Phase.IDLE
    return h


def started() -> Harness:
    """A trajectory's first point taken; a ring at rest with room for 60 entries."""
    h = Harness(start_buffer_periods=START_BUFFER)
    h.queue(state(command=COMMAND, capacity=60))
    h.feed(point(1, 0, 0.0))
    assert h.feeder.phase is Phase.STARTED
    return h


def sending() -> Harness:
    """Point 2's 100 entries: 50 sent, 50 waiting for room."""
    h = Harness(start_buffer_periods=START_BUFFER)
    h.queue(state(depth=150))
    h.feed(point(1, 0, 0.0), point(2, 1, 0.4, X))
    assert [b.count for b in h.sent] == [MAX_BATCH]
    assert h.feeder.phase is Phase.SENDING
    return h


def between() -> Harness:
    """Point 2's segment all sent (the start buffer and 25 entries), still queued."""
    h = Harness(start_buffer_periods=START_BUFFER)
    h.queue(state())
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X))
    assert [b.count for b in h.sent] == [START_BUFFER + 25]
    assert h.feeder.phase is Phase.BETWEEN
    return h


def test_every_phase_takes_every_event() -> None:
    assert set(TRANSITIONS) == set(itertools.product(Phase, FeederEvent))


def test_every_row_has_its_test() -> None:
    assert set(TRANSITIONS) == TESTED


# -- IDLE ----------------------------------------------------------------------------------


@row(Phase.IDLE, FeederEvent.FIRST_POINT)
def test_idle_a_first_point_starts_a_trajectory_from_the_command_position() -> None:
    h = idle()
    h.feed(point(1, 0, 0.0))
    assert h.feeder.phase is Phase.STARTED
    assert h.sent == []
    assert h.feeder.slot() == Slot(1, 1, 1, 0, trajectory_id=1)
    h.feed(point(2, 1, 0.1, X))
    assert total(h.sent) == [p - c for p, c in zip(pulses(X), COMMAND, strict=True)]


@row(Phase.IDLE, FeederEvent.NEXT_POINT)
def test_idle_a_next_point_has_nothing_to_extend_and_is_dropped_as_taken(
    caplog: pytest.LogCaptureFixture,
) -> None:
    h = idle()
    h.feed(point(7, 1, 0.1, X))
    assert h.feeder.phase is Phase.IDLE
    assert h.sent == []
    assert not h.points
    assert h.feeder.slot() == Slot(7, 1, 0, 0)
    assert "point 7 (sequence 1) without a trajectory start; dropped" in caplog.text


@row(Phase.IDLE, FeederEvent.UNREACHABLE_POINT)
def test_idle_no_point_is_behind_a_trajectory_that_is_not_there(
    caplog: pytest.LogCaptureFixture,
) -> None:
    h = idle()
    h.feed(point(7, 1, -5.0, X))
    assert h.feeder.phase is Phase.IDLE
    assert "without a trajectory start" in caplog.text
    assert h.feeder.slot() == Slot(7, 1, 0, 0)


@row(Phase.IDLE, FeederEvent.SEGMENT_SENT)
def test_idle_room_in_the_ring_sends_nothing() -> None:
    h = idle()
    h.queue(state(received=0, depth=0, command=COMMAND))
    assert h.feeder.phase is Phase.IDLE
    assert h.sent == []


@row(Phase.IDLE, FeederEvent.RING_CLEARED)
def test_idle_a_cleared_ring_counts_every_point_received_as_taken(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, "interpolator")
    h = idle()
    h.feed(point(5, 1, 0.1, X), point(3, 1, 0.2, Y))  # numbered out of order: 3 is the last
    assert h.feeder.slot().taken_id == 3
    h.queue(state(epoch=2))
    assert h.feeder.phase is Phase.IDLE
    assert h.feeder.slot() == Slot(5, 2, 0, 0)
    assert "trajectory dropped" not in caplog.text  # there was none


# -- STARTED -------------------------------------------------------------------------------


@row(Phase.STARTED, FeederEvent.FIRST_POINT)
def test_started_a_first_point_replaces_the_start_that_never_moved() -> None:
    h = started()
    h.feed(point(2, 0, 5.0, X))
    assert h.feeder.phase is Phase.STARTED
    assert h.sent == []
    assert h.feeder.slot() == Slot(2, 1, 2, 0, trajectory_id=2)
    h.feed(point(3, 1, 5.1, Y))
    # Anchored at the new start's time and position (nothing was sent from the old one).
    assert h.sent[0].times_ns[START_BUFFER] == 5_004_000_000
    assert total(h.sent) == [y - c for y, c in zip(pulses(Y), COMMAND, strict=True)]


@row(Phase.STARTED, FeederEvent.NEXT_POINT)
def test_started_the_first_segment_goes_after_the_start_buffer() -> None:
    h = started()
    h.feed(point(2, 1, 0.4, X))  # 100 entries and the start buffer; room for 60
    assert h.feeder.phase is Phase.SENDING
    assert [b.count for b in h.sent] == [MAX_BATCH]
    assert rows(h.sent[0])[:START_BUFFER].tolist() == [[0] * 8] * START_BUFFER
    assert rows(h.sent[0])[START_BUFFER].any()
    assert h.feeder.slot() == Slot(1, 1, 2, MAX_BATCH, trajectory_id=1)  # the slot stays full
    assert h.feeder.counts.busy_episodes == 1


@row(Phase.STARTED, FeederEvent.UNREACHABLE_POINT)
def test_started_a_point_not_after_the_start_is_dropped_and_the_start_kept(
    caplog: pytest.LogCaptureFixture,
) -> None:
    h = started()
    h.feed(point(2, 1, 0.0, X))
    assert h.feeder.phase is Phase.STARTED
    assert h.sent == []
    assert h.feeder.slot() == Slot(2, 1, 1, 0, trajectory_id=1)
    assert "point 2 dropped: its time is not after the previous point's" in caplog.text
    h.feed(point(3, 1, 0.1, X))
    assert h.sent[0].times_ns[START_BUFFER] == 4_000_000  # on the start's grid
    assert h.feeder.slot() == Slot(3, 1, 2, START_BUFFER + 25, trajectory_id=1)


@row(Phase.STARTED, FeederEvent.SEGMENT_SENT)
def test_started_room_in_the_ring_sends_nothing() -> None:
    h = started()
    h.queue(state(command=COMMAND, capacity=200))
    assert h.feeder.phase is Phase.STARTED
    assert h.sent == []


@row(Phase.STARTED, FeederEvent.RING_CLEARED)
def test_started_a_cleared_ring_ends_the_trajectory(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, "interpolator")
    h = started()
    h.queue(state(epoch=2))
    assert h.feeder.phase is Phase.IDLE
    assert h.feeder.slot() == Slot(1, 2, 1, 0, trajectory_id=0)
    assert "trajectory dropped" in caplog.text
    h.feed(point(2, 1, 0.1, X))  # it had nothing left to extend
    assert h.sent == []
    assert h.feeder.phase is Phase.IDLE


# -- SENDING -------------------------------------------------------------------------------


def a_point_waits_while_sending(waiting: Point) -> None:
    """``waiting`` stays queued, and nothing else changes, until the segment is all sent;
    handed over anyway, it is refused as a bug."""
    h = sending()
    h.feed(waiting)
    assert h.feeder.phase is Phase.SENDING
    assert list(h.points) == [waiting]
    assert len(h.sent) == 1
    assert h.feeder.slot() == Slot(1, 1, 2, MAX_BATCH, trajectory_id=1)
    with pytest.raises(ImpossibleEventError):
        h.feeder.take(waiting)
    assert h.feeder.phase is Phase.SENDING
    h.queue(state(received=MAX_BATCH, depth=0))
    assert not h.points
    assert h.feeder.slot().taken_id == waiting.point_id


@row(Phase.SENDING, FeederEvent.FIRST_POINT)
def test_sending_a_first_point_waits() -> None:
    a_point_waits_while_sending(point(3, 0, 5.0, X))


@row(Phase.SENDING, FeederEvent.NEXT_POINT)
def test_sending_a_next_point_waits() -> None:
    a_point_waits_while_sending(point(3, 1, 0.5, Y))


@row(Phase.SENDING, FeederEvent.UNREACHABLE_POINT)
def test_sending_a_point_no_segment_reaches_waits() -> None:
    a_point_waits_while_sending(point(3, 1, 0.0, Y))


@row(Phase.SENDING, FeederEvent.SEGMENT_SENT)
def test_sending_the_last_entry_sent_takes_the_point() -> None:
    h = sending()
    h.queue(state(received=MAX_BATCH, depth=0))
    assert h.feeder.phase is Phase.BETWEEN
    assert [(b.first_seq, b.count, b.through) for b in h.sent] == [
        (0, MAX_BATCH, 1),
        (MAX_BATCH, MAX_BATCH, 2),
    ]
    assert h.feeder.slot() == Slot(2, 1, 2, 2 * MAX_BATCH, trajectory_id=1)
    assert total(h.sent) == pulses(X)


@row(Phase.SENDING, FeederEvent.RING_CLEARED)
def test_sending_a_cleared_ring_drops_the_rest_of_the_segment(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, "interpolator")
    h = sending()
    h.queue(state(epoch=2))
    assert h.feeder.phase is Phase.IDLE
    assert len(h.sent) == 1
    assert h.feeder.slot() == Slot(2, 2, 2, MAX_BATCH, trajectory_id=0)
    assert h.feeder.sent == 0
    assert "trajectory dropped" in caplog.text


# -- BETWEEN -------------------------------------------------------------------------------


@row(Phase.BETWEEN, FeederEvent.FIRST_POINT)
def test_between_a_first_point_starts_where_the_sent_entries_lead() -> None:
    h = between()
    h.feed(point(3, 0, 5.0, X))
    assert h.feeder.phase is Phase.STARTED
    assert h.feeder.slot() == Slot(3, 1, 3, START_BUFFER + 25, trajectory_id=3)
    h.feed(point(4, 1, 5.1, Y))
    # Chained onto queued motion: no start buffer, and based on X, not the stale command.
    assert [b.count for b in h.sent[1:]] == [25]
    assert total(h.sent[1:]) == [y - x for y, x in zip(pulses(Y), pulses(X), strict=True)]


@row(Phase.BETWEEN, FeederEvent.NEXT_POINT)
def test_between_the_next_segment_goes_at_once() -> None:
    h = between()
    h.feed(point(3, 1, 1.1, Y))  # 250 entries; room for 172
    assert h.feeder.phase is Phase.SENDING
    assert [b.count for b in h.sent[1:]] == [MAX_BATCH] * 3
    assert h.sent[1].times_ns[0] == 104_000_000  # no start buffer
    assert h.feeder.slot() == Slot(2, 1, 3, START_BUFFER + 25 + 3 * MAX_BATCH, trajectory_id=1)


@row(Phase.BETWEEN, FeederEvent.UNREACHABLE_POINT)
def test_between_a_point_not_after_the_last_is_dropped_and_the_trajectory_kept(
    caplog: pytest.LogCaptureFixture,
) -> None:
    h = between()
    h.feed(point(3, 1, 0.1, Y), point(4, 1, 0.05, Y))
    assert h.feeder.phase is Phase.BETWEEN
    assert len(h.sent) == 1
    assert h.feeder.slot() == Slot(4, 1, 2, START_BUFFER + 25, trajectory_id=1)
    assert caplog.text.count("its time is not after the previous point's") == 2
    h.feed(point(5, 1, 0.2, Y))
    assert h.sent[1].times_ns[0] == 104_000_000
    assert total(h.sent) == pulses(Y)


@row(Phase.BETWEEN, FeederEvent.SEGMENT_SENT)
def test_between_room_in_the_ring_sends_nothing() -> None:
    h = between()
    h.queue(state(received=START_BUFFER + 25, depth=0))
    assert h.feeder.phase is Phase.BETWEEN
    assert len(h.sent) == 1


@row(Phase.BETWEEN, FeederEvent.RING_CLEARED)
def test_between_a_cleared_ring_ends_the_trajectory(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, "interpolator")
    h = between()
    h.queue(state(epoch=2, command=pulses(X)))
    assert h.feeder.phase is Phase.IDLE
    assert h.feeder.slot() == Slot(2, 2, 2, START_BUFFER + 25, trajectory_id=0)
    assert "trajectory dropped" in caplog.text
    h.feed(point(3, 1, 0.2, Y))  # the trajectory is gone even though it had finished
    assert len(h.sent) == 1
    assert h.feeder.slot().taken_id == 3


def test_a_feeder_goes_through_the_phases() -> None:
    h = Harness()
    seen = [h.feeder.phase]
    h.queue(state(depth=150))
    h.feed(point(1, 0, 0.0))
    seen.append(h.feeder.phase)
    h.feed(point(2, 1, 0.4, X))  # 100 entries, room for 50
    seen.append(h.feeder.phase)
    h.queue(state(received=50, depth=0))
    seen.append(h.feeder.phase)
    h.feed(point(3, 1, 0.5, Y))  # 25 entries fit at once
    seen.append(h.feeder.phase)
    h.queue(state(epoch=2))
    seen.append(h.feeder.phase)
    assert seen == [
        Phase.IDLE,
        Phase.STARTED,
        Phase.SENDING,
        Phase.BETWEEN,
        Phase.BETWEEN,
        Phase.IDLE,
    ]
