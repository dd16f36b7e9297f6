"""The pending-slot credits (GroupCredit) and what the gateway knows of the cell (CellState):
numbering, BUSY's look-ahead, interpolator restarts, readiness."""

from __future__ import annotations

import numpy as np
import pytest

from motocell.services.gateway.core.cell_state import CellState
from motocell.services.gateway.core.credits import GroupCredit
from motocell.services.gateway.core.sources import Source
from motocell.shared.bus.schemas import Point
from motocell.shared.config import LOOK_AHEAD_POINTS, parse_cell
from motocell.shared.motion.interpolation import Knot, Trajectory, max_segment_entries
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import NotReadySubcode
from tests.services.gateway.core.fake_cell import (
    CAPACITY,
    EPOCH,
    INSTANCE,
    NOW,
    queue,
    slot,
    status,
)

POINT = Point(0, 1, 0.1, [0.0] * 6, [0.0] * 6)
INC_MOVE_ERROR = int(NotReadySubcode.INC_MOVE_ERROR)


def credit(depth: int = 0) -> GroupCredit:
    """A group whose interpolator has been heard from, its ring holding ``depth`` entries."""
    group = GroupCredit(queue=queue(depth))
    group.on_slot(slot())
    return group


def test_a_group_not_heard_from_is_unknown_free_and_still() -> None:
    group = GroupCredit()
    assert not group.known
    assert group.free
    assert not group.moving
    assert not group.pending_fits()


def test_numbering_counts_up_and_carries_the_ring_epoch() -> None:
    group = credit()
    first = group.number(POINT, 0)
    second = group.number(POINT, 27)
    assert (first.point_id, second.point_id) == (1, 2)
    assert first.epoch == second.epoch == EPOCH
    assert list(group.outstanding) == [(1, 0), (2, 27)]
    assert not group.free
    assert group.moving


def test_an_older_slot_of_the_same_interpolator_is_ignored() -> None:
    """A slot the gateway asked for can arrive after one the interpolator published later."""
    group = credit()
    group.number(POINT, 0)
    group.number(POINT, 0)
    group.on_slot(slot(taken=2, trajectory_id=1))
    group.on_slot(slot(taken=1, trajectory_id=1))
    assert (group.taken, group.free) == (2, True)


def test_a_point_numbered_without_a_ring_carries_epoch_0() -> None:
    group = GroupCredit()
    assert group.number(POINT, 0).epoch == 0


def test_the_slot_frees_when_the_interpolator_has_taken_every_point() -> None:
    group = credit()
    group.number(POINT, 0)
    group.number(POINT, 5)
    group.on_slot(slot(taken=1))
    assert not group.free
    group.on_slot(slot(taken=2))
    assert group.free
    assert not group.moving


def test_pending_points_fit_while_their_segments_fit_the_ring() -> None:
    group = credit(depth=CAPACITY - 30)
    group.number(POINT, 30)
    assert group.pending_fits()
    group.number(POINT, 1)
    assert not group.pending_fits()  # 31 entries more than the 30 free


def test_pending_fits_forgets_points_the_interpolator_has_taken() -> None:
    group = credit(depth=CAPACITY - 30)
    group.number(POINT, 30)
    group.number(POINT, 30)
    assert not group.pending_fits()
    group.on_slot(slot(taken=1))
    assert group.pending_fits()
    assert list(group.outstanding) == [(2, 30)]


def test_taken_points_are_forgotten_even_when_nobody_asks_whether_they_fit() -> None:
    # Type-14 sequence-0 points skip the BUSY check, so pending_fits is never asked.
    group = credit()
    for taken in range(1, 1001):
        group.number(POINT, 0)
        group.on_slot(slot(taken=taken))
    assert list(group.outstanding) == []


def test_at_most_max_ahead_points_are_outstanding_even_when_they_fit() -> None:
    group = credit()
    for _ in range(LOOK_AHEAD_POINTS - 1):
        group.number(POINT, 1)
    assert group.pending_fits()
    group.number(POINT, 1)
    assert not group.pending_fits()


def outstanding_accepted(group: GroupCredit) -> int:
    """How many points (of 5 entries) the group accepts in a row, none taken."""
    count = 0
    while group.accepts_point() and count < 100:
        group.number(POINT, 5)
        count += 1
    return count


def test_one_pending_point_accepts_while_the_slot_is_free_or_the_look_ahead_fits() -> None:
    assert outstanding_accepted(credit(depth=CAPACITY)) == 1
    assert outstanding_accepted(credit()) == LOOK_AHEAD_POINTS


@pytest.mark.parametrize("pending_points", [2, 4, 32])
def test_a_deeper_fifo_accepts_that_many_points_whatever_the_ring_holds(
    pending_points: int,
) -> None:
    full = credit(depth=CAPACITY)
    full.pending_points = pending_points
    assert outstanding_accepted(full) == pending_points
    empty = credit()
    empty.pending_points = pending_points
    assert outstanding_accepted(empty) == max(pending_points, LOOK_AHEAD_POINTS)


def test_a_deeper_fifo_accepts_again_as_the_interpolator_takes_points() -> None:
    group = credit(depth=CAPACITY)
    group.pending_points = 4
    outstanding_accepted(group)
    group.on_slot(slot(taken=1))
    assert group.accepts_point()
    group.number(POINT, 5)
    assert not group.accepts_point()


def test_a_deeper_fifo_counts_from_what_a_restarted_interpolator_has_taken() -> None:
    group = credit(depth=CAPACITY)
    group.pending_points = 2
    outstanding_accepted(group)
    group.on_slot(slot(taken=0, instance=INSTANCE + 1))
    assert outstanding_accepted(group) == 2


def test_pending_fits_needs_the_ring_state() -> None:
    group = credit()
    group.number(POINT, 0)
    group.queue = None
    assert not group.pending_fits()


def test_pending_fits_only_when_every_unacknowledged_point_is_accounted_for() -> None:
    group = credit()
    group.number(POINT, 0)
    group.outstanding.clear()
    assert group.published - group.taken == 1
    assert not group.pending_fits()


def test_a_new_interpolator_instance_forgets_what_was_outstanding_and_ids_go_on() -> None:
    group = credit()
    for _ in range(3):
        group.number(POINT, 4)
    group.on_slot(slot(taken=0, instance=INSTANCE + 1))
    assert (group.instance, group.published, group.taken) == (INSTANCE + 1, 3, 3)
    assert group.free
    assert not group.outstanding
    assert group.number(POINT, 0).point_id == 4


def test_an_interpolator_back_from_missing_never_sees_an_old_id_again() -> None:
    """A router outage: the interpolator had received points 2 and 3 but taken only 1; its ring
    was cleared meanwhile, so it reports them taken (``Slot.taken_id`` = the last received).
    A new trajectory's first point must not reuse id 2 or 3, or the slot would call that
    trajectory lost before it started."""
    group = credit()
    for _ in range(3):
        group.number(POINT, 4)
    group.on_slot(slot(taken=1, trajectory_id=1))
    group.interpolator_gone()
    group.on_slot(slot(taken=3, trajectory_id=0))
    start = group.number(POINT, 0).point_id
    assert start == 4
    group.on_slot(slot(taken=4, trajectory_id=4))
    assert not group.trajectory_lost(start)


def test_a_restarted_gateway_continues_after_the_interpolators_last_point() -> None:
    group = GroupCredit(queue=queue())
    group.on_slot(slot(taken=41, trajectory_id=30))
    assert group.known
    assert group.free
    assert group.number(POINT, 0).point_id == 42


def test_a_gone_interpolator_is_unknown_until_the_next_one_reports() -> None:
    group = credit()
    group.interpolator_gone()
    assert not group.known
    group.on_slot(slot())
    assert group.known


@pytest.mark.parametrize(
    ("taken", "trajectory_id", "lost"),
    [
        (0, 0, False),  # the start point is not taken yet
        (5, 5, False),  # running the trajectory it began
        (6, 5, False),
        (5, 0, True),  # ring cleared: no trajectory any more
        (7, 7, True),  # another trajectory began since
    ],
)
def test_trajectory_lost(taken: int, trajectory_id: int, lost: bool) -> None:
    group = credit()
    group.on_slot(slot(taken=taken, trajectory_id=trajectory_id))
    assert group.trajectory_lost(5) is lost


def test_a_queued_ring_means_the_group_moves() -> None:
    assert credit(depth=1).moving
    assert not credit(depth=0).moving


# -- the whole cell ------------------------------------------------------------------------
def ready_state(groups: int = 2) -> CellState:
    state = CellState(groups)
    state.on_status(status(), NOW)
    for group in range(groups):
        state.on_queue(group, queue(), NOW)
        state.on_slot(group, slot())
    return state


def test_readiness_follows_the_controller_status() -> None:
    state = ready_state()
    assert state.readiness(True, Source.SIMPLE_MESSAGE) == (True, 0)
    state.on_status(status(ready=False, subcode=int(NotReadySubcode.SERVO_OFF)), NOW)
    assert state.readiness(True, Source.SIMPLE_MESSAGE) == (False, int(NotReadySubcode.SERVO_OFF))


def test_without_a_status_or_a_live_controller_nothing_is_ready() -> None:
    assert CellState(1).readiness(True, Source.SIMPLE_MESSAGE) == (False, INC_MOVE_ERROR)
    assert ready_state().readiness(False, Source.SIMPLE_MESSAGE) == (False, INC_MOVE_ERROR)


def test_ready_only_once_every_interpolator_and_ring_is_ready() -> None:
    state = CellState(2)
    state.on_status(status(), NOW)
    state.on_queue(0, queue(), NOW)
    state.on_queue(1, queue(), NOW)
    state.on_slot(0, slot())
    assert not state.rings_ready()
    assert state.readiness(True, Source.SIMPLE_MESSAGE) == (False, INC_MOVE_ERROR)
    state.on_slot(1, slot())
    assert state.rings_ready()
    state.on_queue(1, queue(ready=False), NOW)
    assert not state.rings_ready()


def test_not_ready_statuses_are_counted() -> None:
    state = ready_state()
    state.on_status(status(), NOW)
    assert state.not_ready_count == 0
    state.on_status(status(ready=False), NOW)
    state.on_status(status(ready=False), NOW)
    state.on_status(status(), NOW)
    assert state.not_ready_count == 2


def test_a_missing_executor_takes_every_ring_with_it() -> None:
    state = ready_state()
    state.on_status(status(ready=False, missing=["executor/0"]), NOW)
    assert [group.queue for group in state.groups] == [None, None]
    assert not state.rings_ready()


def test_a_missing_interpolator_makes_its_group_unknown() -> None:
    state = ready_state()
    state.on_status(
        status(ready=False, missing=["interpolator/1", "interpolator/9", "broadcaster/0"]), NOW
    )
    assert [group.known for group in state.groups] == [True, False]


def test_samples_for_groups_the_cell_does_not_have_are_ignored() -> None:
    state = ready_state(1)
    state.on_queue(1, queue(depth=5), NOW)
    state.on_slot(-1, slot(taken=9))
    assert len(state.groups) == 1
    assert state.groups[0].queue == queue()
    assert state.groups[0].taken == 0


def test_the_cell_moves_while_any_group_has_points_or_entries() -> None:
    state = ready_state()
    assert not state.moving()
    assert state.slots_free()
    state.groups[1].number(POINT, 3)
    assert state.moving()
    assert not state.slots_free()
    state.on_slot(1, slot(taken=1))
    state.on_queue(0, queue(depth=1), NOW)
    assert state.moving()
    assert state.slots_free()


# -- the look-ahead's entry count ----------------------------------------------------------
ARM6 = AxisMap(parse_cell({}).groups[0])
PERIOD_NS = 4_000_000


@pytest.mark.parametrize("anchor_ns", [0, 1, 1_999_999, 3_999_999])
@pytest.mark.parametrize("offset_ns", [0, 1, 2_000_000, 3_999_999, 4_000_000])
@pytest.mark.parametrize("duration_ns", [1, 3_999_999, 4_000_000, 4_000_001, 100_000_000])
def test_max_segment_entries_never_undercounts_the_interpolators_segment(
    anchor_ns: int, offset_ns: int, duration_ns: int
) -> None:
    zeros = np.zeros(6)
    start = Knot(anchor_ns, zeros, zeros)
    trajectory = Trajectory(ARM6, PERIOD_NS, start, np.zeros(6, dtype=np.int64))
    if offset_ns:
        trajectory.segment_to(Knot(anchor_ns + offset_ns, zeros, zeros))
    segment = trajectory.segment_to(Knot(anchor_ns + offset_ns + duration_ns, zeros, zeros))
    exact = segment.remaining
    assert exact <= max_segment_entries(duration_ns, PERIOD_NS) <= exact + 2


def test_max_segment_entries_of_a_100_ms_segment_at_4_ms() -> None:
    assert max_segment_entries(100_000_000, PERIOD_NS) == 27
