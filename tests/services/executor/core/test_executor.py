"""ExecutorCore: ordered batch acceptance per epoch, clearing, and one (merged) entry per tick.

Batches are built here by hand: ``increments`` is little-endian int32, ``count`` rows of 8.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import msgspec
import pytest

from motocell.services.executor.core.executor import (
    BARRIER_TIMEOUT_TICKS,
    NOTICE_EVERY_NS,
    STALL_ALARM,
    ExecutorCore,
    stalled,
)
from motocell.services.executor.core.resting import REST_AFTER_NS
from motocell.services.executor.core.rings import RING_CAPACITY, BatchOutcome
from motocell.services.executor.core.states import Readiness
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S, HEARTBEAT_S, SILENT_HEARTBEATS
from motocell.shared.bus.schemas import (
    Alarm,
    ControllerStatus,
    GroupTick,
    IncrementBatch,
    Point,
    QueueState,
)
from motocell.shared.config import PositionLoop
from motocell.shared.motion.servo import Servos
from motocell.shared.protocol.constants import Result
from motocell.testing.statuses import ready_status

FIRST_EPOCH = 100
START = [[10, 20, 30, 40, 50, 60, 0, 0], [-5, 5, 0, 0, 0, 0, 0, 0]]


def batch(
    epoch: int,
    first_seq: int,
    rows: Sequence[Sequence[int]],
    partial: Sequence[int] = (),
    tool: int = 0,
) -> IncrementBatch:
    data = b"".join(struct.pack("<8i", *row, *([0] * (8 - len(row)))) for row in rows)
    return IncrementBatch(
        epoch=epoch,
        first_seq=first_seq,
        count=len(rows),
        increments=data,
        partial=list(partial),
        tool=tool,
        times_ns=[4_000_000 * (first_seq + i + 1) for i in range(len(rows))],
    )


def unit(value: int, axis: int = 0) -> list[int]:
    row = [0] * 8
    row[axis] = value
    return row


PERIOD_NS = 4_000_000
MS = 1_000_000


def status(
    motion_ready: bool = True,
    heartbeat_ms: int = 100,
    servo_on: bool = True,
    alarms: Sequence[Alarm] = (),
) -> ControllerStatus:
    return ready_status(
        servo_on=servo_on,
        alarms=list(alarms),
        motion_ready=motion_ready,
        tools=[0, 0],
        heartbeat_ms=heartbeat_ms,
    )


def set_ready(core: ExecutorCore, ready: bool, now_ns: int = 0) -> None:
    """What the executor hears from a live controller that says ``ready`` (or not)."""
    core.on_controller(True, now_ns)
    core.on_status(status(ready), now_ns)


def ready_core() -> ExecutorCore:
    core = ExecutorCore(START, FIRST_EPOCH)
    set_ready(core, True)
    return core


def applied(core: ExecutorCore, group: int = 0) -> list[int]:
    """Axis-0 increment of each tick until the ring is empty (and one more, empty, tick)."""
    moves = []
    while True:
        depth = core.queue_state(group).depth
        core.step()
        moves.append(core.last_increment[group][0])
        if depth == 0:
            return moves


# -- construction and queue_state ---------------------------------------------------------


def test_new_core_state() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    assert core.ready is False
    assert core.tick == 0
    assert [ring.epoch for ring in core.rings] == [100, 101]
    assert core.queue_state(0) == QueueState(
        epoch=100, received=0, depth=0, capacity=200, command_pulses=START[0], tick=0
    )
    assert core.queue_state(1).epoch == 101
    assert RING_CAPACITY == 200


def test_queue_state_numbers_follow_accepts_and_steps() -> None:
    core = ready_core()
    assert core.accept(0, batch(100, 0, [unit(1)] * 5)) is BatchOutcome.ACCEPTED
    assert core.accept(0, batch(100, 5, [unit(2)] * 3)) is BatchOutcome.ACCEPTED
    core.on_tick(PERIOD_NS, 0)
    core.on_tick(2 * PERIOD_NS, 0)
    state = core.queue_state(0)
    assert state == QueueState(
        epoch=100,
        received=8,
        depth=6,
        capacity=200,
        command_pulses=[12, 20, 30, 40, 50, 60, 0, 0],
        tick=2,
        ready=True,
    )
    assert core.queue_state(0).depth == 6
    assert core.queue_state(1) == QueueState(101, 0, 0, 200, START[1], 2, ready=True)
    # The state is a snapshot: changing it does not move the robot.
    state.command_pulses[0] = 999
    assert core.command[0][0] == 12


# -- accept (the ring's own checks: test_rings.py) -----------------------------------------


@pytest.mark.parametrize(
    "bad",
    [
        batch(100, 5, [unit(9)]),  # a gap
        batch(100, 4, [unit(1)] * 197),  # past the ring's 200 entries
        msgspec.structs.replace(batch(100, 4, [unit(1)]), count=3),  # sizes that do not add up
        None,  # undecodable
    ],
)
def test_a_batch_that_breaks_the_increment_path_stops_everything(
    bad: IncrementBatch | None,
) -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [unit(7)] * 4))
    core.accept(1, batch(101, 0, [unit(7)] * 4))
    assert core.accept(0, bad).breaks_increment_path
    assert [len(ring.entries) for ring in core.rings] == [0, 0]
    assert [ring.epoch for ring in core.rings] == [102, 103]
    assert [(n.result, n.subcode, n.value) for n in core.take_notices()] == [
        (Result.FAILURE, 0, 0)  # the IncMove error, group 0
    ]


def test_duplicates_and_stale_batches_change_nothing() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [unit(7)] * 4))
    before = core.queue_state(0)
    for outcome, b in [
        (BatchOutcome.DUPLICATE, batch(100, 0, [unit(9)] * 2)),
        (BatchOutcome.STALE, batch(99, 4, [unit(9)])),
        (BatchOutcome.STALE, batch(101, 4, [unit(9)])),
    ]:
        assert core.accept(0, b) is outcome
        assert core.queue_state(0) == before
    assert core.take_notices() == []
    assert applied(core) == [7, 7, 7, 7, 0]


def test_stale_epoch_is_refused_even_for_the_right_sequence() -> None:
    core = ready_core()
    assert core.accept(1, batch(100, 0, [unit(1)])) is BatchOutcome.STALE  # group 1 is 101
    assert core.accept(1, batch(101, 0, [unit(1)])) is BatchOutcome.ACCEPTED


def test_not_ready_refuses_and_renews_the_epoch() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    assert core.accept(0, batch(100, 0, [unit(1)])) is BatchOutcome.NOT_READY
    state = core.queue_state(0)
    assert (state.epoch, state.received, state.depth) == (102, 0, 0)
    assert core.queue_state(1).epoch == 101  # other groups untouched
    # The rest of that trajectory is now stale, even once ready again.
    set_ready(core, True)
    assert core.accept(0, batch(100, 1, [unit(1)])) is BatchOutcome.STALE
    assert core.accept(0, batch(102, 0, [unit(1)])) is BatchOutcome.ACCEPTED


def test_not_ready_with_a_stale_epoch_is_just_stale() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    assert core.accept(0, batch(7, 0, [unit(1)])) is BatchOutcome.STALE
    assert core.queue_state(0).epoch == 100


# -- clearing ---------------------------------------------------------------------------------


def test_clear_all_renews_every_epoch_and_empties_the_rings() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [unit(1)] * 3))
    core.accept(1, batch(101, 0, [unit(1)] * 2))
    core.step()
    core.clear_all()
    assert [core.queue_state(g).epoch for g in (0, 1)] == [102, 103]
    assert [core.queue_state(g).received for g in (0, 1)] == [0, 0]
    assert [core.queue_state(g).depth for g in (0, 1)] == [0, 0]
    assert core.command[0][0] == 11  # what was applied stays applied
    assert core.ready is True
    assert core.accept(0, batch(100, 3, [unit(1)])) is BatchOutcome.STALE
    assert core.accept(0, batch(102, 0, [unit(4)])) is BatchOutcome.ACCEPTED
    core.clear_all()
    assert [core.queue_state(g).epoch for g in (0, 1)] == [104, 105]


def test_set_ready_false_clears_every_ring() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [unit(1)] * 3))
    core.accept(1, batch(101, 0, [unit(1)] * 2))
    set_ready(core, False)
    assert core.ready is False
    assert [core.queue_state(g).depth for g in (0, 1)] == [0, 0]
    assert [core.queue_state(g).epoch for g in (0, 1)] == [102, 103]
    # Already not ready: no further renewal.
    set_ready(core, False)
    assert [core.queue_state(g).epoch for g in (0, 1)] == [102, 103]
    # Becoming ready does not renew either.
    set_ready(core, True)
    assert [core.queue_state(g).epoch for g in (0, 1)] == [102, 103]
    set_ready(core, True)
    assert [core.queue_state(g).epoch for g in (0, 1)] == [102, 103]


# -- step ---------------------------------------------------------------------------------


def test_step_applies_one_entry_per_group_per_tick() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [[1, 2, 3, 4, 5, 6, 0, 0], [10, 20, 30, 40, 50, 60, 0, 0]]))
    core.accept(1, batch(101, 0, [[-1, 1, 0, 0, 0, 0, 0, 0]]))
    core.step()
    assert core.last_increment == [(1, 2, 3, 4, 5, 6, 0, 0), (-1, 1, 0, 0, 0, 0, 0, 0)]
    assert core.command == [[11, 22, 33, 44, 55, 66, 0, 0], [-6, 6, 0, 0, 0, 0, 0, 0]]
    core.step()
    # Group 1's ring is empty: it gets zeros while group 0 keeps moving.
    assert core.last_increment == [(10, 20, 30, 40, 50, 60, 0, 0), (0,) * 8]
    assert core.command == [[21, 42, 63, 84, 105, 126, 0, 0], [-6, 6, 0, 0, 0, 0, 0, 0]]
    core.step()
    assert core.last_increment == [(0,) * 8, (0,) * 8]
    assert core.command[0] == [21, 42, 63, 84, 105, 126, 0, 0]
    assert core.group_ticks() == [
        GroupTick(
            [21, 42, 63, 84, 105, 126, 0, 0],
            [21, 42, 63, 84, 105, 126, 0, 0],
            [0] * 8,
            0,
            [0.0] * 8,
        ),
        GroupTick([-6, 6, 0, 0, 0, 0, 0, 0], [-6, 6, 0, 0, 0, 0, 0, 0], [0] * 8, 0, [0.0] * 8),
    ]


def test_all_eight_axes_are_applied() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [[1, -2, 3, -4, 5, -6, 7, -8]]))
    core.step()
    assert core.command[0] == [11, 18, 33, 36, 55, 54, 7, -8]


def test_partial_entry_is_merged_with_the_next_one() -> None:
    core = ready_core()
    # Entries: full, partial (off-grid waypoint), full, full.
    assert core.accept(0, batch(100, 0, [unit(1), unit(2), unit(30), unit(400)], partial=[1])) is (
        BatchOutcome.ACCEPTED
    )
    assert applied(core) == [1, 32, 400, 0]
    assert core.command[0][0] == 10 + 433


def test_chain_of_partials_is_merged_up_to_the_next_full_entry() -> None:
    core = ready_core()
    rows = [unit(1), unit(2), unit(4), unit(8), unit(16)]
    core.accept(0, batch(100, 0, rows, partial=[0, 1, 2]))
    assert applied(core) == [1 + 2 + 4 + 8, 16, 0]


def test_partial_across_batches_is_merged_with_the_next_batch_head() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [unit(1), unit(2)], partial=[1]))
    core.accept(0, batch(100, 2, [unit(4), unit(8)], partial=[1]))
    core.accept(0, batch(100, 4, [unit(16)]))
    # Partial indices are relative to their own batch: rows 1 and 3 overall.
    assert applied(core) == [1, 2 + 4, 8 + 16, 0]


def test_partial_at_the_tail_is_sent_alone() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [unit(1), unit(2)], partial=[1]))
    core.step()
    core.step()
    assert core.last_increment[0][0] == 2  # the next entry is not queued yet
    core.accept(0, batch(100, 2, [unit(4)]))
    core.step()
    assert core.last_increment[0][0] == 4
    assert core.command[0][0] == 17


def test_partial_is_not_merged_across_a_tool_change() -> None:
    core = ready_core()
    core.accept(0, batch(100, 0, [unit(1), unit(2)], partial=[1], tool=3))
    core.accept(0, batch(100, 2, [unit(4)], tool=5))
    assert applied(core) == [1, 2, 4, 0]


def test_nothing_is_applied_while_not_ready() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    for _ in range(3):
        core.step()
    assert core.command == START
    assert core.last_increment == [(0,) * 8, (0,) * 8]
    set_ready(core, True)
    core.accept(0, batch(100, 0, [unit(5)] * 3))
    core.step()
    set_ready(core, False)
    core.step()
    core.step()
    assert core.command[0][0] == 15
    assert core.last_increment[0] == (0,) * 8
    assert core.queue_state(0).depth == 0


@pytest.mark.parametrize("rows", [1, 37, 200])
def test_every_accepted_pulse_is_applied_exactly_once(rows: int) -> None:
    core = ready_core()
    increments = [[(i * 7919 + axis * 31) % 201 - 100 for axis in range(8)] for i in range(rows)]
    partial = [i for i in range(rows) if i % 5 == 2]
    assert core.accept(0, batch(100, 0, increments, partial)) is BatchOutcome.ACCEPTED
    ticks = 0
    while core.queue_state(0).depth:
        core.step()
        ticks += 1
    assert ticks == rows - sum(1 for i in partial if i < rows - 1)
    assert core.command[0] == [
        START[0][axis] + sum(row[axis] for row in increments) for axis in range(8)
    ]


# -- what the motion system refuses -----------------------------------------------------------


def test_an_increment_beyond_the_axis_maximum_is_refused_and_nothing_moves() -> None:
    limits = [[10] * 8 for _ in START]
    core = ExecutorCore(START, FIRST_EPOCH, max_increments=limits)
    set_ready(core, True)
    for group in range(len(START)):
        assert core.accept(group, batch(core.rings[group].epoch, 0, [unit(10), unit(11)]))
    assert core.step() == []
    assert core.last_increment[0][0] == 10
    assert core.step() == list(range(len(START)))
    assert all(increment[0] == 0 for increment in core.last_increment)
    assert core.command[0][0] == START[0][0] + 10


# Group 0's S axis may go from 0 to 100 pulses (it starts at 10); group 1 has no narrow limit.
RANGES = [([0] + [-1000] * 7, [100] + [1000] * 7), ([-1000] * 8, [1000] * 8)]


def ranged_core(*rows: list[int]) -> ExecutorCore:
    """A ready core with ``RANGES`` whose group 0 holds ``rows`` and group 1 one S-axis pulse
    per row."""
    core = ExecutorCore(START, FIRST_EPOCH, ranges=RANGES)
    set_ready(core, True)
    assert core.accept(0, batch(core.rings[0].epoch, 0, rows)) is BatchOutcome.ACCEPTED
    assert core.accept(1, batch(core.rings[1].epoch, 0, [unit(1)] * len(rows)))
    return core


def test_an_increment_that_lands_exactly_on_a_limit_is_accepted() -> None:
    core = ranged_core(unit(40), unit(50))
    assert core.step() == []
    assert core.step() == []
    assert core.command[0][0] == 100
    assert core.beyond_range == {}


@pytest.mark.parametrize("past", [unit(91), unit(-11)])
def test_an_increment_past_a_limit_is_refused_and_nothing_moves(past: list[int]) -> None:
    core = ranged_core(past)
    assert core.step() == [0]
    assert "axis 0" in core.beyond_range[0]
    assert "past its range [0, 100]" in core.beyond_range[0]
    assert core.command == START
    assert core.last_increment == [(0,) * 8, (0,) * 8]


def test_a_range_is_checked_on_every_motoman_axis() -> None:
    core = ExecutorCore(START, FIRST_EPOCH, ranges=[([0] * 8, [60] * 8)] * 2)
    set_ready(core, True)
    assert core.accept(0, batch(core.rings[0].epoch, 0, [unit(1, axis=5)]))
    assert core.step() == [0]
    assert "axis 5 would reach 61 pulses" in core.beyond_range[0]


def test_an_axis_outside_a_narrowed_range_may_move_back_towards_it() -> None:
    core = ExecutorCore([[150, *[0] * 7], [0] * 8], FIRST_EPOCH, ranges=RANGES)
    set_ready(core, True)
    assert core.accept(0, batch(core.rings[0].epoch, 0, [unit(-10), unit(1)]))
    assert core.step() == []
    assert core.command[0][0] == 140
    assert core.step() == [0]


def test_a_synchronized_start_that_waits_too_long_is_reported() -> None:
    core = ready_core()
    start = msgspec.structs.replace(
        batch(core.rings[0].epoch, 0, [unit(1)]), sync_id=5, sync_groups=[0, 1]
    )
    assert core.accept(0, start) is BatchOutcome.ACCEPTED
    for _ in range(BARRIER_TIMEOUT_TICKS):
        assert core.step() == []
        assert core.last_increment[0][0] == 0
    assert core.step() == [0]


# -- readiness (every transition: tests/services/executor/core/test_states.py) ---------------


def test_ready_needs_a_ready_status_from_a_live_controller() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    core.on_status(status(True), 0)
    assert not core.ready  # its token not seen yet: maybe a dead controller's last word
    core.on_controller(True, 0)
    assert not core.ready  # back: the next status decides
    core.on_status(status(True), 0)
    assert core.ready


def test_the_controller_going_away_clears_the_rings() -> None:
    core = ready_core()
    assert core.accept(0, batch(FIRST_EPOCH, 0, [unit(1)])) is BatchOutcome.ACCEPTED
    core.on_controller(False, 0)
    assert not core.ready
    assert core.queue_state(0).depth == 0
    assert core.rings[0].epoch != FIRST_EPOCH


# -- what the adapter sends ---------------------------------------------------------------


def test_the_queue_state_counts_the_entries_in_the_ring() -> None:
    # What CHECK_QUEUE_CNT answers, from the gateway's copy (motoros1 §2.3).
    core = ready_core()
    core.accept(1, batch(core.rings[1].epoch, 0, [unit(1), unit(1), unit(1)]))
    assert [core.queue_state(g).depth for g in (0, 1)] == [0, 3]


def test_every_queue_is_published_first() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    core.step()
    assert [group for group, _ in core.queue_updates(0)] == [0, 1]


def test_an_unchanged_queue_waits_for_the_heartbeat() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    core.queue_updates(0)
    heartbeat_ns = round(HEARTBEAT_S * 1e9)
    for now in range(PERIOD_NS, heartbeat_ns, PERIOD_NS):
        core.step()
        assert core.queue_updates(now) == []
    updates = core.queue_updates(heartbeat_ns)
    assert [group for group, _ in updates] == [0, 1]
    assert {state.heartbeat_ms for _, state in updates} == {100}


def test_a_changed_queue_is_published_at_once() -> None:
    core = ready_core()
    core.step()
    core.queue_updates(0)
    core.accept(1, batch(core.rings[1].epoch, 0, [unit(1)]))
    updates = core.queue_updates(MS)
    assert [(group, state.depth) for group, state in updates] == [(1, 1)]


def test_a_draining_ring_is_published_every_few_ticks_and_at_once_when_dry() -> None:
    core = ready_core()
    core.accept(0, batch(FIRST_EPOCH, 0, [unit(1)] * 25))
    core.queue_updates(0)
    published = []
    for tick in range(1, 28):
        core.on_tick(tick * PERIOD_NS, 0)
        depths = [
            state.depth for group, state in core.queue_updates(tick * PERIOD_NS) if group == 0
        ]
        published += [(tick, depth) for depth in depths]
    assert published == [(10, 15), (20, 5), (25, 0)]


def test_forced_queue_updates_include_unchanged_queues() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    core.step()
    core.queue_updates(0)
    assert len(core.queue_updates(MS, force=True)) == 2


def test_tick_report() -> None:
    core = ready_core()
    core.accept(0, batch(core.rings[0].epoch, 0, [unit(7)]))
    core.on_tick(deadline_ns=4_000_000, lateness_ns=120)
    tick = core.tick_report(deadline_ns=4_000_000, lateness_ns=120, missed=3)
    assert (tick.tick, tick.deadline_ns, tick.lateness_ns, tick.missed) == (1, 4_000_000, 120, 3)
    assert tick.motion_ready is True
    assert tick.groups[0].increment[0] == 7
    assert tick.groups[0].command_pulses[0] == START[0][0] + 7


# --- stalls -------------------------------------------------------------------------------


def test_a_tick_later_than_the_bound_is_a_stall() -> None:
    assert not stalled(12_000_000, 4_000_000, 3)
    assert stalled(12_000_001, 4_000_000, 3)
    assert not stalled(3_000_000_000, 4_000_000, 1000)


def stalled_core() -> ExecutorCore:
    """A ready core with entries queued, then a tick past the lateness bound (25 periods)."""
    core = ready_core()
    core.accept(0, batch(FIRST_EPOCH, 0, [unit(1)] * 5))
    assert core.on_tick(deadline_ns=0, lateness_ns=26 * PERIOD_NS)  # the clock restarts
    return core


def test_a_late_tick_clears_every_ring_applies_nothing_and_tells_the_controller() -> None:
    core = stalled_core()
    assert all(not ring.entries for ring in core.rings)
    assert core.rings[0].epoch != FIRST_EPOCH
    assert core.command == START
    assert core.readiness.state is Readiness.STALLED
    assert [(n.result, n.value) for n in core.take_notices()] == [(Result.FAILURE, STALL_ALARM)]


def test_a_late_tick_with_nothing_queued_stops_nothing() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    core.on_controller(True, 0)
    assert core.on_tick(deadline_ns=0, lateness_ns=26 * PERIOD_NS)  # restarts all the same
    assert core.take_notices() == []


STALL_STATUS = status(False, alarms=[Alarm(STALL_ALARM)])
"""What the controller says once it has raised the stall's alarm."""


def test_after_a_stall_statuses_are_old_news_until_one_shows_the_alarm() -> None:
    core = stalled_core()
    core.on_status(status(True), MS)
    assert not core.ready
    seen = []
    for when, heard in enumerate((status(False), STALL_STATUS, status(True)), start=2):
        core.on_status(heard, when * MS)  # first not ready for another reason: services missing
        seen.append(core.readiness.state)
    assert seen == [Readiness.STALLED, Readiness.WAITING, Readiness.READY]


def test_an_unconfirmed_stall_is_told_again_every_second() -> None:
    core = stalled_core()
    start = core.take_notices()[0]
    told = []
    for tick in range(1, 551):
        core.on_tick(tick * PERIOD_NS, 0)
        told += core.take_notices()
    assert [(n.result, n.value) for n in told] == [(start.result, start.value)] * 2  # 1 s, 2 s
    core.on_status(STALL_STATUS, 551 * PERIOD_NS)
    for tick in range(552, 1052):
        core.on_tick(tick * PERIOD_NS, 0)
    assert core.take_notices() == []


def test_an_unconfirmed_stall_is_told_again_as_soon_as_the_controller_says_ready() -> None:
    core = stalled_core()
    core.take_notices()
    core.on_status(status(True), MS)  # heard again (a router back), the notice not yet had
    assert len(core.take_notices()) == 1


def test_a_silent_controller_stops_a_ready_executor() -> None:
    core = ready_core()
    bound = SILENT_HEARTBEATS * 100 * MS
    assert not core.controller_silent(bound)
    assert core.controller_silent(bound + 1)
    core.accept(0, batch(FIRST_EPOCH, 0, [unit(1)] * 5))
    core.on_tick(bound + PERIOD_NS, 0)
    assert core.readiness.state is Readiness.STALLED
    assert core.command == START


def test_silence_counts_in_the_heartbeats_the_controller_announced() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    core.on_controller(True, 0)
    core.on_status(status(True, heartbeat_ms=1000), 0)
    assert not core.controller_silent(SILENT_HEARTBEATS * 1000 * MS)
    assert core.controller_silent(SILENT_HEARTBEATS * 1000 * MS + 1)


def test_silence_while_not_ready_is_no_stall() -> None:
    core = ExecutorCore(START, FIRST_EPOCH)
    set_ready(core, False)
    assert not core.controller_silent(100 * NOTICE_EVERY_NS)


# -- rest: the clock stops while nothing can move -------------------------------------------


def run_quiet(core: ExecutorCore, start_ns: int, duration_ns: int) -> int:
    """Ticks from ``start_ns`` for ``duration_ns``, with a status every 100 ms from a controller
    that keeps its readiness; the time of the last tick."""
    now = start_ns
    while now < start_ns + duration_ns:
        now += PERIOD_NS
        if now % (100 * MS) == 0:
            core.on_status(status(core.ready), now)
        core.on_tick(now, 0)
    return now


def test_the_clock_rests_after_a_quiet_second() -> None:
    core = ready_core()
    run_quiet(core, 0, REST_AFTER_NS)
    assert not core.rest.resting
    core.on_tick(REST_AFTER_NS + 2 * PERIOD_NS, 0)
    assert core.rest.resting
    tick = core.tick_report(0, 0, 0)
    assert tick.resting
    assert {state.heartbeat_ms for _, state in core.queue_updates(REST_AFTER_NS)} == {
        round(AT_REST_HEARTBEAT_S * 1000)
    }


def test_the_clock_runs_while_anything_is_queued_owed_or_settling() -> None:
    core = ExecutorCore(START, FIRST_EPOCH, servos=settling_servos(), max_lateness_periods=1000)
    set_ready(core, True)
    core.accept(0, batch(FIRST_EPOCH, 0, [unit(500)] * 3))
    promise(core, 7)  # a point whose increments have not come yet
    now = run_quiet(core, 0, 2 * REST_AFTER_NS)
    assert not core.rest.resting
    core.accept(0, through(FIRST_EPOCH, 3, [unit(500)], done=7))
    now = run_quiet(core, now, PERIOD_NS)
    assert not core.servos.at_rest
    while not core.quiet():  # the feedback settles well after the last increment
        now = run_quiet(core, now, PERIOD_NS)
        assert not core.rest.resting
    now = run_quiet(core, now, REST_AFTER_NS - PERIOD_NS)
    assert not core.rest.resting
    run_quiet(core, now, PERIOD_NS)
    assert core.rest.resting


def settling_servos() -> Servos:
    return Servos([PositionLoop()] * 2, PERIOD_NS / 1e9, START)


def test_a_point_or_a_batch_wakes_a_resting_clock() -> None:
    core = ready_core()
    now = run_quiet(core, 0, REST_AFTER_NS + PERIOD_NS)
    assert core.rest.resting
    core.on_point(0, Point(1, 0, 0.0, [], [], epoch=FIRST_EPOCH))
    assert not core.rest.resting
    run_quiet(core, now, REST_AFTER_NS + 2 * PERIOD_NS)
    assert core.rest.resting
    core.accept(0, batch(FIRST_EPOCH, 0, [unit(1)]))
    assert not core.rest.resting


def test_a_clock_woken_from_rest_keeps_the_short_heartbeat_it_announces() -> None:
    core = ready_core()
    now = run_quiet(core, 0, REST_AFTER_NS + PERIOD_NS)
    assert {s.heartbeat_ms for _, s in core.queue_updates(now)} == {1000}  # next in a second
    core.on_point(0, Point(1, 0, 0.0, [], [], epoch=FIRST_EPOCH))
    updates = core.queue_updates(now + PERIOD_NS)
    assert [(g, s.heartbeat_ms) for g, s in updates] == [(0, 100), (1, 100)]
    assert core.queue_updates(now + 2 * PERIOD_NS) == []
    heartbeat = now + PERIOD_NS + round(HEARTBEAT_S * 1e9)
    assert len(core.queue_updates(heartbeat)) == 2


def test_a_resting_clock_wakes_for_its_heartbeat() -> None:
    core = ready_core()
    now = run_quiet(core, 0, REST_AFTER_NS + 2 * PERIOD_NS)
    core.queue_updates(now)
    assert core.rest_deadline() == now + round(AT_REST_HEARTBEAT_S * 1e9)


def test_a_resting_clock_wakes_to_tell_an_unconfirmed_stall_again() -> None:
    core = stalled_core()  # told at 104 ms
    told_at = [26 * PERIOD_NS]
    now = told_at[0]
    core.take_notices()
    while not core.rest.resting:  # no status comes: the controller never confirms
        now += PERIOD_NS
        core.on_tick(now, 0)
        told_at += [now] * len(core.take_notices())
    assert told_at == [26 * PERIOD_NS, 26 * PERIOD_NS + NOTICE_EVERY_NS]
    core.queue_updates(now)
    assert core.rest_deadline() == told_at[-1] + NOTICE_EVERY_NS


# -- starved rings: increments that stop coming mid-trajectory ------------------------------


def promise(core: ExecutorCore, point_id: int, sequence: int = 1, epoch: int = 100) -> None:
    """The gateway published point ``point_id`` to group 0's interpolator."""
    core.on_point(0, Point(point_id, sequence, 0.1, [], [], epoch=epoch))


def through(epoch: int, first_seq: int, rows: Sequence[Sequence[int]], done: int) -> IncrementBatch:
    """A batch after which its interpolator is done with every point up to ``done``."""
    return msgspec.structs.replace(batch(epoch, first_seq, rows), through=done)


def starving_core() -> ExecutorCore:
    core = ExecutorCore(START, FIRST_EPOCH, max_lateness_periods=3)
    set_ready(core, True)
    return core


def test_a_ring_empty_while_owed_stops_motion_after_the_bound_and_only_then() -> None:
    core = starving_core()
    promise(core, 2)
    assert core.accept(0, through(100, 0, [unit(1)] * 2, done=1)) is BatchOutcome.ACCEPTED
    results = [core.step() for _ in range(2 + 3)]
    assert results == [[]] * 5  # two entries applied, then three empty ticks within the bound
    assert core.step() == [0]
    assert core.starved == {0}
    assert core.command[0][0] == START[0][0] + 2


def test_a_point_whose_entries_never_came_is_owed() -> None:
    """The ring ran dry at the end of one point, and the next one was published: its entries
    are owed even though no batch said so (the link to the interpolator was cut, say)."""
    core = starving_core()
    promise(core, 2)
    core.accept(0, through(100, 0, [unit(1)], done=2))
    promise(core, 3)
    assert [core.step() for _ in range(4)] == [[]] * 4
    assert core.step() == [0]


def test_a_ring_that_runs_dry_at_the_end_of_what_was_published_is_a_late_client() -> None:
    core = starving_core()
    promise(core, 2)
    core.accept(0, through(100, 0, [unit(1)] * 2, done=2))
    promise(core, 4, sequence=0)  # a next trajectory's start: nothing owed yet
    assert all(core.step() == [] for _ in range(50))
    assert core.starved == set()


def test_points_of_another_epoch_are_not_owed() -> None:
    core = starving_core()
    promise(core, 2, epoch=99)
    assert all(core.step() == [] for _ in range(20))


def test_a_batch_arriving_within_the_bound_ends_the_starvation() -> None:
    core = starving_core()
    promise(core, 2)
    core.accept(0, through(100, 0, [unit(1)], done=1))
    assert [core.step() for _ in range(4)] == [[]] * 4  # one entry, three empty ticks
    core.accept(0, through(100, 1, [unit(1)], done=1))
    assert [core.step() for _ in range(4)] == [[]] * 4  # the count starts again
    assert core.step() == [0]


def test_clearing_forgets_what_was_owed() -> None:
    core = starving_core()
    promise(core, 2)
    core.clear_all()
    assert all(core.step() == [] for _ in range(20))
