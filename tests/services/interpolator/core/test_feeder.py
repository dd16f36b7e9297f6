"""Feeder: points -> numbered IncrementBatch, credit flow control against QueueState.

``send`` is a list's append; QueueState updates are written by hand (or, in the streaming
tests, come from a real ExecutorCore through delayed "wires" in both directions).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence

import numpy as np
import pytest

from motocell.services.executor.core.executor import ExecutorCore
from motocell.services.executor.core.rings import BatchOutcome
from motocell.services.interpolator.core.feeder import MAX_BATCH, Feeder
from motocell.shared.bus.schemas import ControllerStatus, IncrementBatch, Point, QueueState, Slot
from motocell.shared.config import Group, load_cell, parse_cell
from motocell.shared.motion.kinematics import IntArray
from motocell.testing.statuses import ready_status
from tests.services.executor.core.test_executor import set_ready

PERIOD = 4_000_000
ARM6: Group = load_cell().groups[0]
PPU = np.array([58670.0, 58670.0, 58670.0, 32594.0, 32594.0, 21990.0])
ZERO6 = [0.0] * 6


def pulses(positions: Sequence[float]) -> list[int]:
    """Motoman-order pulses of an arm6 position (8 slots)."""
    return [*np.rint(np.array(positions) * PPU).astype(np.int64).tolist(), 0, 0]


def state(
    epoch: int = 1,
    received: int = 0,
    depth: int = 0,
    command: Sequence[int] = (0,) * 8,
    capacity: int = 200,
) -> QueueState:
    return QueueState(epoch, received, depth, capacity, list(command), tick=0)


def point(
    point_id: int,
    sequence: int,
    time: float,
    positions: Sequence[float] = ZERO6,
    velocities: Sequence[float] = ZERO6,
) -> Point:
    return Point(point_id, sequence, time, list(positions), list(velocities))


def rows(batch: IncrementBatch) -> IntArray:
    data: IntArray = (
        np.frombuffer(batch.increments, dtype="<i4").reshape(batch.count, 8).astype(np.int64)
    )
    return data


def total(batches: Sequence[IncrementBatch]) -> list[int]:
    return [int(v) for v in sum((rows(b).sum(axis=0) for b in batches), np.zeros(8, np.int64))]


class Harness:
    def __init__(self, group: Group = ARM6, start_buffer_periods: int = 0) -> None:
        self.sent: list[IncrementBatch] = []
        self.feeder = Feeder(
            group, PERIOD, send=self.sent.append, start_buffer_periods=start_buffer_periods
        )
        self.points: deque[Point] = deque()

    def feed(self, *points: Point) -> None:
        self.points.extend(points)
        self.feeder.progress(self.points)

    def queue(self, queue_state: QueueState) -> None:
        self.feeder.on_queue(queue_state)
        self.feeder.progress(self.points)


X = [0.1, -0.1, 0.2, 0.3, -0.3, 0.5]
Y = [0.2, 0.0, 0.1, 0.4, -0.2, 0.6]


def test_nothing_moves_before_the_first_queue_state() -> None:
    h = Harness()
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X))
    assert h.sent == []
    assert len(h.points) == 2
    assert h.feeder.room() == 0
    assert h.feeder.slot() == Slot(0, 0, 0, 0)


def test_sequence_0_is_taken_at_once_and_bases_on_the_command_pulses() -> None:
    h = Harness()
    command = [30, -20, 10, 0, 5, -5, 0, 0]
    h.queue(state(epoch=7, command=command))
    h.feed(point(1, 0, 0.0))
    assert h.sent == []
    assert h.feeder.slot() == Slot(1, 7, 1, 0, trajectory_id=1)
    h.feed(point(2, 1, 0.1, X, [0.2] * 6))
    assert len(h.sent) == 1
    batch = h.sent[0]
    assert (batch.epoch, batch.first_seq, batch.count, batch.tool) == (7, 0, 25, 0)
    assert batch.partial == []
    assert batch.times_ns == [PERIOD * k for k in range(1, 26)]
    assert rows(batch)[:, 6:].tolist() == [[0, 0]] * 25
    assert total(h.sent) == [p - c for p, c in zip(pulses(X), command, strict=True)]
    assert h.feeder.slot() == Slot(2, 7, 2, 25, trajectory_id=1)


def test_a_trajectory_from_rest_starts_after_the_start_buffer() -> None:
    h = Harness(start_buffer_periods=3)
    h.queue(state(epoch=7))
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X, [0.2] * 6))
    batch = h.sent[0]
    assert (batch.first_seq, batch.count) == (0, 28)
    assert rows(batch)[:3].tolist() == [[0] * 8] * 3  # held still for 3 periods
    assert rows(batch)[3].any()
    assert batch.times_ns[:4] == [0, 0, 0, PERIOD]
    assert total(h.sent) == pulses(X)  # the motion itself is unchanged
    h.feed(point(3, 1, 0.2, Y))
    assert h.sent[1].count == 25  # later segments are not held


def test_a_start_buffer_as_long_as_a_batch_fills_it_alone() -> None:
    h = Harness(start_buffer_periods=MAX_BATCH)
    h.queue(state())
    h.feed(point(1, 0, 0.0), point(2, 1, 0.4, X))  # 100 entries of motion
    assert [b.count for b in h.sent] == [MAX_BATCH, MAX_BATCH, MAX_BATCH]
    assert not rows(h.sent[0]).any()
    assert rows(h.sent[1])[0].any()
    assert total(h.sent) == pulses(X)


def test_a_trajectory_chained_onto_queued_motion_is_not_held() -> None:
    h = Harness(start_buffer_periods=3)
    h.queue(state(command=[0] * 8))
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X))
    assert h.sent[0].count == 28
    # Its entries are still queued when the next trajectory starts: no pause between them.
    h.feed(point(3, 0, 5.0, X), point(4, 1, 5.1, Y))
    assert h.sent[1].count == 25
    assert total(h.sent) == pulses(Y)


def test_off_grid_waypoint_is_flagged_partial() -> None:
    h = Harness()
    h.queue(state())
    h.feed(point(1, 0, 0.0), point(2, 1, 0.0101, X), point(3, 1, 0.02, Y))
    assert [b.count for b in h.sent] == [3, 3]
    assert [b.partial for b in h.sent] == [[2], []]
    assert [b.first_seq for b in h.sent] == [0, 3]
    assert h.sent[0].times_ns == [4_000_000, 8_000_000, 10_100_000]
    assert h.sent[1].times_ns == [12_000_000, 16_000_000, 20_000_000]


def test_never_sends_more_than_the_ring_has_room_for_and_sends_whole_batches() -> None:
    h = Harness()
    h.queue(state(depth=190))
    # A 0.4 s segment: 100 entries. Room: 200 - 190 - 0 in flight = 10, less than a batch.
    h.feed(point(1, 0, 0.0), point(2, 1, 0.4, X), point(3, 1, 0.5, Y))
    assert h.sent == []
    assert h.feeder.room() == 10
    assert h.feeder.slot().taken_id == 1  # the segment is not fully sent: slot still busy
    assert [p.point_id for p in h.points] == [3]

    # The executor played 40: room 200 - 150 - 0 = 50, a whole batch.
    h.queue(state(received=0, depth=150))
    assert [(b.first_seq, b.count) for b in h.sent] == [(0, 50)]
    assert h.feeder.slot().taken_id == 1

    # Stale state: the 50 entries just sent are still in flight.
    h.queue(state(received=0, depth=150))
    assert h.feeder.room() == 0
    assert len(h.sent) == 1
    h.queue(state(received=50, depth=170))
    assert h.feeder.room() == 30
    assert len(h.sent) == 1
    h.queue(state(received=50, depth=150))
    assert [(b.first_seq, b.count) for b in h.sent[1:]] == [(50, 50)]
    # The segment is all sent: point 2 is taken, point 3's 25 entries wait for room.
    assert h.feeder.slot().taken_id == 2

    # The rest of a segment goes as soon as it fits, even when shorter than a batch.
    h.queue(state(received=100, depth=175))
    assert [(b.first_seq, b.count) for b in h.sent[2:]] == [(100, 25)]
    assert h.feeder.slot() == Slot(3, 1, 3, 125, trajectory_id=1)
    assert total(h.sent) == pulses(Y)


def test_batches_are_at_most_max_batch_entries() -> None:
    h = Harness()
    h.queue(state())
    h.feed(point(1, 0, 0.0), point(2, 1, 1.0, X))  # 250 entries
    assert MAX_BATCH == 50
    assert [(b.first_seq, b.count) for b in h.sent] == [(0, 50), (50, 50), (100, 50), (150, 50)]
    assert h.feeder.room() == 0
    h.queue(state(received=200, depth=0))
    assert [(b.first_seq, b.count) for b in h.sent[4:]] == [(200, 50)]
    assert h.feeder.slot().taken_id == 2
    assert total(h.sent) == pulses(X)


def test_second_start_in_the_same_epoch_continues_from_the_trajectory_end() -> None:
    h = Harness()
    h.queue(state(command=[0] * 8))
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X))
    # A new trajectory starts at X while those entries are still queued: the executor's
    # command position (0) is stale, the base must be where the sent entries lead.
    h.feed(point(3, 0, 5.0, X), point(4, 1, 5.1, Y))
    assert [(b.epoch, b.first_seq, b.count) for b in h.sent] == [(1, 0, 25), (1, 25, 25)]
    assert h.sent[1].times_ns[0] == 5_004_000_000  # grid anchored at the new sequence 0
    assert total(h.sent) == pulses(Y)
    assert total(h.sent[1:]) == [y - x for y, x in zip(pulses(Y), pulses(X), strict=True)]


def test_restart_before_anything_was_sent_uses_the_fresh_command_pulses() -> None:
    h = Harness()
    h.queue(state(command=[0] * 8))
    h.feed(point(1, 0, 0.0))
    jogged = [7, -7, 3, 0, 0, 1, 0, 0]
    h.queue(state(command=jogged))  # same epoch, robot moved meanwhile, nothing sent
    h.feed(point(2, 0, 1.0), point(3, 1, 1.1, X))
    assert total(h.sent) == [p - j for p, j in zip(pulses(X), jogged, strict=True)]


def test_epoch_change_drops_the_trajectory_and_frees_the_slot() -> None:
    h = Harness()
    h.queue(state(epoch=4, depth=150))
    h.feed(point(1, 0, 0.0), point(2, 1, 0.4, X))
    assert [(b.first_seq, b.count) for b in h.sent] == [(0, 50)]
    assert h.feeder.slot().taken_id == 1

    stopped_at = [1000, 2000, 3000, 4000, 5000, 6000, 0, 0]
    h.queue(state(epoch=9, command=stopped_at))
    assert h.feeder.trajectory is None
    assert h.feeder.segment is None
    assert h.feeder.sent == 0
    # Point 2 counts as taken, and no trajectory runs any more.
    assert h.feeder.slot() == Slot(2, 9, 2, 50, trajectory_id=0)
    assert len(h.sent) == 1  # nothing more of the dropped segment

    # A continuation without a new start point is dropped (and taken).
    h.feed(point(3, 1, 0.5, Y))
    assert len(h.sent) == 1
    assert h.feeder.slot() == Slot(3, 9, 2, 50)

    # A new trajectory numbers its entries from 0 in the new epoch, based on the new command.
    h.feed(point(4, 0, 10.0, X), point(5, 1, 10.1, Y))
    assert [(b.epoch, b.first_seq, b.count) for b in h.sent[1:]] == [(9, 0, 25)]
    assert total(h.sent[1:]) == [y - s for y, s in zip(pulses(Y), stopped_at, strict=True)]
    assert h.feeder.slot() == Slot(5, 9, 4, 75, trajectory_id=4)


def test_epoch_change_while_idle_keeps_nothing() -> None:
    h = Harness()
    h.queue(state(epoch=1))
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X))
    h.queue(state(epoch=2, command=pulses(X)))
    h.feed(point(3, 1, 0.2, Y))  # the old trajectory is gone even though it had finished
    assert len(h.sent) == 1
    assert h.feeder.slot().taken_id == 3


def test_point_without_a_trajectory_is_dropped_and_taken() -> None:
    h = Harness()
    h.queue(state(epoch=3))
    h.feed(point(1, 1, 0.1, X), point(2, 5, 0.2, Y))
    assert h.sent == []
    assert h.feeder.slot() == Slot(2, 3, 0, 0)
    assert not h.points


def test_point_whose_time_does_not_increase_is_dropped_and_the_trajectory_kept() -> None:
    h = Harness()
    h.queue(state())
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X), point(3, 1, 0.1, Y), point(4, 1, 0.05, Y))
    assert len(h.sent) == 1
    assert h.feeder.slot() == Slot(4, 1, 2, 25, trajectory_id=1)
    h.feed(point(5, 1, 0.2, Y))
    assert [(b.first_seq, b.count) for b in h.sent] == [(0, 25), (25, 25)]
    assert h.sent[1].times_ns[0] == 104_000_000
    assert total(h.sent) == pulses(Y)


def test_tool_is_stamped_on_batches() -> None:
    h = Harness()
    h.feeder.tool = 12
    h.queue(state())
    h.feed(point(1, 0, 0.0), point(2, 1, 0.1, X))
    assert [b.tool for b in h.sent] == [12]


def test_tool_is_not_changed_mid_segment() -> None:
    h = Harness()
    h.feeder.tool = 1
    h.queue(state(depth=150))
    h.feed(point(1, 0, 0.0), point(2, 1, 0.4, X))  # 100 entries, room for 50
    h.feeder.tool = 2  # SELECT_TOOL while the segment is half sent
    h.queue(state(received=50, depth=0))
    assert [b.tool for b in h.sent] == [1, 1]


def status_with_tools(tools: list[int]) -> ControllerStatus:
    return ready_status(seq=0, tools=tools)


def test_the_groups_tool_comes_from_the_controller_status() -> None:
    second = parse_cell({"groups": [{"name": "R1"}, {"name": "R2"}]}).groups[1]
    h = Harness(second)
    h.feeder.on_status(status_with_tools([3, 9]))
    assert h.feeder.tool == 9


def test_a_status_without_the_groups_tool_means_tool_0() -> None:
    h = Harness()
    h.feeder.tool = 5
    h.feeder.on_status(status_with_tools([]))
    assert h.feeder.tool == 0


# -- streaming against a real ExecutorCore ----------------------------------------------------


def stream(
    points: list[Point], start: list[int], batch_delay: int, state_delay: int
) -> tuple[ExecutorCore, list[IncrementBatch]]:
    """Run feeder and executor tick by tick; each direction has its own delay in ticks."""
    core = ExecutorCore([start], first_epoch=1)
    set_ready(core, True)
    all_sent: list[IncrementBatch] = []
    outbox: list[IncrementBatch] = []
    feeder = Feeder(ARM6, PERIOD, send=outbox.append)
    pending = deque(points)
    to_core: deque[tuple[int, IncrementBatch]] = deque()
    to_feeder: deque[tuple[int, QueueState]] = deque([(0, core.queue_state(0))])
    tick = 0
    while pending or feeder.segment is not None or to_core or core.queue_state(0).depth:
        while to_feeder and to_feeder[0][0] <= tick:
            feeder.on_queue(to_feeder.popleft()[1])
        feeder.progress(pending)
        for batch in outbox:
            to_core.append((tick + batch_delay, batch))
        all_sent += outbox
        outbox.clear()
        while to_core and to_core[0][0] <= tick:
            assert core.accept(0, to_core.popleft()[1]) is BatchOutcome.ACCEPTED
        core.step()
        to_feeder.append((tick + state_delay, core.queue_state(0)))
        tick += 1
        assert tick < 100_000
    return core, all_sent


@pytest.mark.parametrize(("batch_delay", "state_delay"), [(0, 0), (1, 1), (3, 5), (7, 2)])
def test_streamed_trajectory_never_overflows_and_ends_exactly(
    batch_delay: int, state_delay: int
) -> None:
    rng = np.random.default_rng(batch_delay * 10 + state_delay)
    start = [120, -340, 560, 0, 0, 17, 0, 0]
    first = np.array(start[:6]) / PPU
    points = [point(1, 0, 0.0031, first.tolist())]
    t = 0.0031
    for i in range(60):
        t += float(rng.uniform(0.0005, 0.9))
        points.append(
            point(
                i + 2, i + 1, t, rng.uniform(-1, 1, 6).tolist(), rng.uniform(-0.5, 0.5, 6).tolist()
            )
        )
    core, sent = stream(points, start, batch_delay, state_delay)
    assert [b.first_seq for b in sent] == list(
        np.cumsum([0] + [b.count for b in sent[:-1]]).tolist()
    )
    assert all(b.count <= MAX_BATCH for b in sent)
    final = pulses(points[-1].positions)
    assert core.command[0] == final
    assert total(sent) == [f - s for f, s in zip(final, start, strict=True)]


def test_each_batch_says_which_points_it_is_done_with() -> None:
    """``through``: every entry of every point up to it has been sent; the executor counts the
    points the gateway published beyond it as owed."""
    h = Harness()
    h.queue(state())
    h.feed(point(1, 0, 0.0), point(2, 1, 0.4, X))  # 100 entries: two whole batches of 50
    assert [(b.count, b.through) for b in h.sent] == [(MAX_BATCH, 1), (MAX_BATCH, 2)]
    h.feed(point(3, 1, 0.5, Y), point(4, 1, 0.6, X))
    assert [(b.count, b.through) for b in h.sent[2:]] == [(25, 3), (25, 4)]


def test_a_dropped_point_counts_as_done() -> None:
    h = Harness()
    h.queue(state())
    h.feed(point(1, 1, 0.1, X))  # no trajectory start: dropped
    h.feed(point(2, 0, 0.0), point(3, 1, 0.1, X))
    assert [b.through for b in h.sent] == [3]
    assert h.feeder.slot().taken_id == 3
