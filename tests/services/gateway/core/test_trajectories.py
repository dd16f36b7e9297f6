"""Trajectory points through the motion handler, on a fake cell: MotoROS's check order
(motoros1 §2.4), the pending slot and BUSY, duplicates, lost trajectories, and 2016's all or
nothing (motoros1 §2.5)."""

from __future__ import annotations

import msgspec
import pytest

from motocell.shared.config import LOOK_AHEAD_POINTS, parse_cell
from motocell.shared.protocol.constants import InvalidSubcode, NotReadySubcode, Result
from motocell.shared.protocol.messages import JointTrajPtExGroup, Message
from motocell.shared.protocol.replies import ex_group, traj_point, traj_point_ex
from tests.services.gateway.core.fake_cell import (
    CAPACITY,
    EPOCH,
    NOW,
    SYNC_SEED,
    exchange,
    gateway,
    queue,
    reply_of,
    slot,
    status,
    two_groups,
    verdict_of,
)

ZEROS = (0.0,) * 6
OK = (int(Result.SUCCESS), 0)
BUSY = (int(Result.BUSY), 0)
INC_MOVE_ERROR = (int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR))


def invalid(subcode: InvalidSubcode) -> tuple[int, int]:
    return int(Result.INVALID), int(subcode)


def point(
    sequence: int,
    time: float,
    positions: tuple[float, ...] = ZEROS,
    velocities: tuple[float, ...] = ZEROS,
    group: int = 0,
) -> Message:
    return traj_point(group, sequence, time, positions, velocities)


def ex(sequence: int, *groups: JointTrajPtExGroup) -> Message:
    return traj_point_ex(sequence, groups)


def both(time: float, velocities: tuple[float, ...] = ZEROS) -> list[JointTrajPtExGroup]:
    return [ex_group(0, time, ZEROS, velocities), ex_group(1, time, ZEROS, velocities)]


# -- JOINT_TRAJ_PT_FULL (14) ---------------------------------------------------------------
def test_sequence_0_is_answered_first_and_published_after_the_reply() -> None:
    handler, cell = gateway()
    response = handler.respond(point(0, 0.0))
    assert verdict_of(response.reply) == OK
    assert cell.sent == []
    assert response.then is not None
    response.then()
    [(group, sent)] = cell.sent
    assert group == 0
    assert (sent.point_id, sent.sequence, sent.epoch, sent.time) == (1, 0, EPOCH, 0.0)
    assert sent.positions == list(ZEROS)
    assert sent.sync_groups == []


def test_a_refused_point_publishes_nothing() -> None:
    handler, cell = gateway()
    response = handler.respond(point(1, 0.1))
    assert verdict_of(response.reply) == invalid(InvalidSubcode.SEQUENCE)
    assert response.then is None
    assert cell.state.groups[0].published == 0


def test_not_ready_is_answered_with_the_controllers_subcode() -> None:
    handler, cell = gateway()
    cell.state.on_status(status(ready=False, subcode=int(NotReadySubcode.HOLD)), NOW)
    reply = exchange(handler, point(0, 0.0)).reply
    assert verdict_of(reply) == (int(Result.NOT_READY), int(NotReadySubcode.HOLD))
    assert cell.sent == []


def test_without_a_live_controller_points_are_not_ready() -> None:
    handler, cell = gateway()
    cell.alive = False
    assert verdict_of(exchange(handler, point(0, 0.0)).reply) == INC_MOVE_ERROR


def test_a_group_the_cell_does_not_have_is_invalid() -> None:
    handler, _ = gateway()
    reply = exchange(handler, point(0, 0.0, group=1)).reply
    assert verdict_of(reply) == invalid(InvalidSubcode.GROUPNO)


def test_missing_fields_and_times_beyond_4_hours_are_refused_before_the_slot() -> None:
    handler, cell = gateway()
    request = point(0, 0.0)
    no_velocity = msgspec.structs.replace(
        request, body=msgspec.structs.replace(request.body, valid_fields=3)
    )
    reply = exchange(handler, no_velocity).reply
    assert verdict_of(reply) == invalid(InvalidSubcode.DATA_INSUFFICIENT)
    too_late = point(0, 14400.0)
    assert verdict_of(exchange(handler, too_late).reply) == invalid(InvalidSubcode.DATA_TIME)
    assert cell.sent == []


def test_the_start_point_must_be_within_30_pulses_of_the_commanded_position() -> None:
    handler, cell = gateway()
    cell.state.on_queue(0, queue(command_pulses=[58670 * 2, 0, 0, 0, 0, 0, 0, 0]), NOW)
    far = exchange(handler, point(0, 0.0))
    assert verdict_of(far.reply) == invalid(InvalidSubcode.DATA_START_POS)
    near = exchange(handler, point(0, 0.0, positions=(2.0, 0, 0, 0, 0, 0)))
    assert verdict_of(near.reply) == OK
    assert [sent.positions[0] for _, sent in cell.sent] == [2.0]


def test_a_negative_sequence_is_invalid() -> None:
    handler, _ = gateway()
    assert verdict_of(exchange(handler, point(-1, 0.0)).reply) == invalid(InvalidSubcode.SEQUENCE)


def test_points_after_the_start_are_numbered_with_their_segments_entries() -> None:
    handler, cell = gateway()
    for sequence in range(3):
        assert verdict_of(exchange(handler, point(sequence, 0.1 * sequence)).reply) == OK
    assert [(p.point_id, p.sequence) for _, p in cell.sent] == [(1, 0), (2, 1), (3, 2)]
    # 100 ms at 4 ms: at most 24 grid instants inside, one more off-grid, and the waypoint.
    assert list(cell.state.groups[0].outstanding) == [(1, 0), (2, 27), (3, 27)]


def test_a_speed_over_the_limit_is_refused_after_the_start() -> None:
    handler, _ = gateway()
    exchange(handler, point(0, 0.0))
    fast = point(1, 0.1, velocities=(7.0, 0, 0, 0, 0, 0))
    assert verdict_of(exchange(handler, fast).reply) == invalid(InvalidSubcode.DATA_SPEED)


def test_a_time_that_does_not_increase_is_refused() -> None:
    handler, _ = gateway()
    exchange(handler, point(0, 0.5))
    assert verdict_of(exchange(handler, point(1, 0.5)).reply) == invalid(InvalidSubcode.DATA_TIME)
    assert verdict_of(exchange(handler, point(1, 0.4)).reply) == invalid(InvalidSubcode.DATA_TIME)


def test_busy_once_the_look_ahead_points_are_outstanding() -> None:
    handler, cell = gateway()
    for sequence in range(LOOK_AHEAD_POINTS):
        assert verdict_of(exchange(handler, point(sequence, 0.1 * sequence)).reply) == OK
    busy = exchange(handler, point(LOOK_AHEAD_POINTS, 0.1 * LOOK_AHEAD_POINTS))
    assert verdict_of(busy.reply) == BUSY
    assert reply_of(busy.reply).group_no == 0
    assert len(cell.sent) == LOOK_AHEAD_POINTS


def test_busy_ends_when_the_interpolator_takes_the_points() -> None:
    handler, cell = gateway()
    for sequence in range(LOOK_AHEAD_POINTS):
        exchange(handler, point(sequence, 0.1 * sequence))
    cell.take_all()
    assert verdict_of(exchange(handler, point(3, 0.3)).reply) == OK


def test_busy_when_the_outstanding_segments_do_not_fit_the_ring() -> None:
    handler, cell = gateway()
    cell.state.on_queue(0, queue(depth=CAPACITY - 26), NOW)
    assert verdict_of(exchange(handler, point(0, 0.0)).reply) == OK
    assert verdict_of(exchange(handler, point(1, 0.1)).reply) == OK  # its 27 entries unchecked
    assert verdict_of(exchange(handler, point(2, 0.2)).reply) == BUSY  # 27 > 26 free
    cell.state.on_slot(0, slot(taken=1, trajectory_id=1))
    assert verdict_of(exchange(handler, point(2, 0.2)).reply) == BUSY
    cell.state.on_queue(0, queue(depth=CAPACITY - 27), NOW)
    assert verdict_of(exchange(handler, point(2, 0.2)).reply) == OK


def test_pending_points_4_accepts_four_points_the_ring_has_no_room_for() -> None:
    handler, cell = gateway(parse_cell({"pending_points": 4}))
    cell.state.on_queue(0, queue(depth=CAPACITY), NOW)
    exchange(handler, point(0, 0.0))
    cell.take_all()
    for sequence in range(1, 5):
        assert verdict_of(exchange(handler, point(sequence, 0.1 * sequence)).reply) == OK
    assert verdict_of(exchange(handler, point(5, 0.5)).reply) == BUSY
    cell.state.on_slot(0, slot(taken=2, trajectory_id=1))
    assert verdict_of(exchange(handler, point(5, 0.5)).reply) == OK


def test_pending_points_4_holds_every_group_of_a_2016_to_it() -> None:
    handler, cell = gateway(
        parse_cell({"groups": [{"name": "R1"}, {"name": "R2"}], "pending_points": 4})
    )
    for group in (0, 1):
        cell.state.on_queue(group, queue(depth=CAPACITY), NOW)
    exchange(handler, ex(0, *both(0.0)))
    cell.take_all(0)
    cell.take_all(1)
    for sequence in range(1, 5):
        assert verdict_of(exchange(handler, ex(sequence, *both(0.1 * sequence))).reply) == OK
    busy = exchange(handler, ex(5, *both(0.5))).reply
    assert verdict_of(busy) == BUSY
    assert reply_of(busy).group_no == 0


def test_sequence_0_waits_in_line_instead_of_busy() -> None:
    handler, cell = gateway()
    for sequence in range(LOOK_AHEAD_POINTS):
        exchange(handler, point(sequence, 0.1 * sequence))
    assert verdict_of(exchange(handler, point(0, 0.0)).reply) == OK
    assert cell.sent[-1][1].sequence == 0


def test_a_resent_point_is_answered_success_without_publishing_it_again() -> None:
    handler, cell = gateway()
    exchange(handler, point(0, 0.0))
    exchange(handler, point(1, 0.1))
    resent = exchange(handler, point(1, 0.1))
    assert verdict_of(resent.reply) == OK
    assert resent.then is None
    assert len(cell.sent) == 2
    assert cell.state.groups[0].published == 2


def test_a_resend_is_recognised_even_while_the_slot_is_busy() -> None:
    handler, _ = gateway()
    for sequence in range(LOOK_AHEAD_POINTS):
        exchange(handler, point(sequence, 0.1 * sequence))
    assert verdict_of(exchange(handler, point(LOOK_AHEAD_POINTS - 1, 0.2)).reply) == OK


def test_a_trajectory_is_over_once_motion_ready_dropped() -> None:
    handler, cell = gateway()
    exchange(handler, point(0, 0.0))
    cell.state.on_status(status(ready=False), NOW)
    cell.state.on_status(status(), NOW)
    reply = exchange(handler, point(1, 0.1)).reply
    assert verdict_of(reply) == invalid(InvalidSubcode.SEQUENCE)
    assert verdict_of(exchange(handler, point(0, 0.0)).reply) == OK


def test_a_trajectory_the_interpolator_dropped_is_over() -> None:
    handler, cell = gateway()
    exchange(handler, point(0, 0.0))
    cell.state.on_slot(0, slot(taken=1, trajectory_id=0))  # its ring was cleared
    reply = exchange(handler, point(1, 0.1)).reply
    assert verdict_of(reply) == invalid(InvalidSubcode.SEQUENCE)


def test_a_trajectory_still_running_goes_on() -> None:
    handler, cell = gateway()
    exchange(handler, point(0, 0.0))
    cell.state.on_slot(0, slot(taken=1, trajectory_id=1))
    assert verdict_of(exchange(handler, point(1, 0.1)).reply) == OK


def test_an_interpolator_not_heard_from_again_makes_points_not_ready() -> None:
    handler, cell = gateway()
    cell.state.on_status(status(missing=["interpolator/0"]), NOW)
    assert verdict_of(exchange(handler, point(0, 0.0)).reply) == INC_MOVE_ERROR


# -- MOTO_JOINT_TRAJ_PT_FULL_EX (2016) -----------------------------------------------------
def test_2016_takes_every_group_and_replies_once_for_the_last() -> None:
    handler, cell = gateway(two_groups())
    reply = exchange(handler, ex(0, *both(0.0))).reply
    assert verdict_of(reply) == OK
    assert reply_of(reply).group_no == 1
    assert [(group, p.point_id, p.sequence) for group, p in cell.sent] == [(0, 1, 0), (1, 1, 0)]


def test_the_first_segment_of_a_2016_trajectory_is_synchronised() -> None:
    handler, cell = gateway(two_groups())
    exchange(handler, ex(0, *both(0.0)))
    exchange(handler, ex(1, *both(0.1)))
    cell.take_all(0)
    cell.take_all(1)
    exchange(handler, ex(2, *both(0.2)))
    syncs = [(group, p.sequence, p.sync_id, p.sync_groups) for group, p in cell.sent]
    assert syncs == [
        (0, 0, 0, []),
        (1, 0, 0, []),
        (0, 1, SYNC_SEED + 1, [0, 1]),
        (1, 1, SYNC_SEED + 1, [0, 1]),
        (0, 2, 0, []),
        (1, 2, 0, []),
    ]


def test_each_2016_trajectory_gets_a_sync_id_of_its_own() -> None:
    handler, cell = gateway(two_groups())
    for _ in range(2):
        exchange(handler, ex(0, *both(0.0)))
        exchange(handler, ex(1, *both(0.1)))
        cell.take_all(0, trajectory_id=cell.sent[-4][1].point_id)
        cell.take_all(1, trajectory_id=cell.sent[-3][1].point_id)
    assert sorted({p.sync_id for _, p in cell.sent} - {0}) == [SYNC_SEED + 1, SYNC_SEED + 2]


def test_a_2016_point_for_one_group_is_not_synchronised() -> None:
    handler, cell = gateway(two_groups())
    exchange(handler, ex(0, ex_group(1, 0.0, ZEROS, ZEROS)))
    exchange(handler, ex(1, ex_group(1, 0.1, ZEROS, ZEROS)))
    assert [p.sync_id for _, p in cell.sent] == [0, 0]


def test_a_failing_check_in_a_later_group_publishes_nothing_for_any_group() -> None:
    handler, cell = gateway(two_groups())
    exchange(handler, ex(0, *both(0.0)))
    sent_before = list(cell.sent)
    fast = (7.0, 0, 0, 0, 0, 0)
    response = exchange(
        handler, ex(1, ex_group(0, 0.1, ZEROS, ZEROS), ex_group(1, 0.1, ZEROS, fast))
    )
    assert verdict_of(response.reply) == invalid(InvalidSubcode.DATA_SPEED)
    assert reply_of(response.reply).group_no == 1
    assert response.then is None
    assert cell.sent == sent_before
    assert [group.published for group in cell.state.groups] == [1, 1]
    assert [track.segments for track in handler.trajectories.tracks] == [0, 0]


def test_a_failing_start_check_in_a_later_group_publishes_nothing() -> None:
    handler, cell = gateway(two_groups())
    cell.state.on_queue(1, queue(command_pulses=[1000, 0, 0, 0, 0, 0, 0, 0]), NOW)
    reply = exchange(handler, ex(0, *both(0.0))).reply
    assert verdict_of(reply) == invalid(InvalidSubcode.DATA_START_POS)
    assert reply_of(reply).group_no == 1
    assert cell.sent == []


def test_2016_busy_names_the_busy_group_and_publishes_nothing() -> None:
    handler, cell = gateway(two_groups())
    exchange(handler, ex(0, *both(0.0)))
    for sequence in range(1, LOOK_AHEAD_POINTS):
        exchange(handler, point(sequence, 0.1 * sequence, group=1))
    sent = len(cell.sent)
    reply = exchange(handler, ex(LOOK_AHEAD_POINTS, *both(0.1 * LOOK_AHEAD_POINTS))).reply
    assert verdict_of(reply) == BUSY
    assert reply_of(reply).group_no == 1
    assert len(cell.sent) == sent


def test_2016_refuses_a_group_listed_twice_or_missing() -> None:
    handler, cell = gateway(two_groups())
    twice = exchange(handler, ex(0, ex_group(1, 0.0, ZEROS, ZEROS), ex_group(1, 0.0, ZEROS, ZEROS)))
    assert verdict_of(twice.reply) == invalid(InvalidSubcode.GROUPNO)
    unknown = exchange(
        handler, ex(0, ex_group(0, 0.0, ZEROS, ZEROS), ex_group(2, 0.0, ZEROS, ZEROS))
    )
    assert verdict_of(unknown.reply) == invalid(InvalidSubcode.GROUPNO)
    assert reply_of(unknown.reply).group_no == 2
    assert cell.sent == []


@pytest.mark.parametrize("bad", [2, 3, 4, 2**31 - 1, -1, -2, -(2**31)])
@pytest.mark.parametrize("position", [0, 1])
def test_2016_a_group_number_the_cell_lacks_is_invalid_3004_and_the_port_goes_on(
    bad: int, position: int
) -> None:
    handler, cell = gateway(two_groups())
    exchange(handler, ex(0, *both(0.0)))
    exchange(handler, ex(1, *both(0.1)))
    cell.take_all(0)
    cell.take_all(1)
    # The groups listed with it are resends of the point just taken: nothing before the group
    # check may look the bad number up (it raised IndexError and closed the port).
    listed = [ex_group(0, 0.1, ZEROS, ZEROS)]
    listed.insert(position, ex_group(bad, 0.1, ZEROS, ZEROS))
    response = exchange(handler, ex(1, *listed))
    assert not response.close
    assert verdict_of(response.reply) == invalid(InvalidSubcode.GROUPNO)
    assert reply_of(response.reply).group_no == bad
    assert len(cell.sent) == 4
    assert verdict_of(exchange(handler, ex(2, *both(0.2))).reply) == OK


def test_2016_group_minus_1_is_not_taken_for_the_last_group() -> None:
    handler, cell = gateway(two_groups())
    exchange(handler, ex(0, *both(0.0)))
    exchange(handler, ex(1, *both(0.1)))
    # -1 indexes the last group's track in Python: a resend of its point must still be refused.
    reply = exchange(handler, ex(1, ex_group(-1, 0.1, ZEROS, ZEROS))).reply
    assert verdict_of(reply) == invalid(InvalidSubcode.GROUPNO)
    assert len(cell.sent) == 4


def test_2016_not_ready_answers_for_the_last_group() -> None:
    handler, cell = gateway(two_groups())
    cell.state.on_status(status(ready=False, subcode=int(NotReadySubcode.SERVO_OFF)), NOW)
    reply = exchange(handler, ex(0, *both(0.0))).reply
    assert verdict_of(reply) == (int(Result.NOT_READY), int(NotReadySubcode.SERVO_OFF))
    assert reply_of(reply).group_no == 1


def test_a_resent_2016_point_is_answered_success_without_publishing() -> None:
    handler, cell = gateway(two_groups())
    exchange(handler, ex(0, *both(0.0)))
    exchange(handler, ex(1, *both(0.1)))
    resent = exchange(handler, ex(1, *both(0.1)))
    assert verdict_of(resent.reply) == OK
    assert len(cell.sent) == 4


def test_2016_applies_the_4_hour_limit_too() -> None:
    handler, cell = gateway(two_groups())
    reply = exchange(handler, ex(0, *both(14400.0))).reply
    assert verdict_of(reply) == invalid(InvalidSubcode.DATA_TIME)
    assert cell.sent == []


def test_a_three_group_cell_synchronises_only_the_listed_groups() -> None:
    cell_config = parse_cell({"groups": [{"name": "R1"}, {"name": "R2"}, {"name": "R3"}]})
    handler, cell = gateway(cell_config)
    listed = (ex_group(0, 0.0, ZEROS, ZEROS), ex_group(2, 0.0, ZEROS, ZEROS))
    exchange(handler, ex(0, *listed))
    exchange(handler, ex(1, ex_group(0, 0.1, ZEROS, ZEROS), ex_group(2, 0.1, ZEROS, ZEROS)))
    assert [(g, p.sync_groups) for g, p in cell.sent if p.sequence == 1] == [
        (0, [0, 2]),
        (2, [0, 2]),
    ]
