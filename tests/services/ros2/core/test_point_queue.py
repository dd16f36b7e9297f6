"""MotoROS2's motion modes and point-queue mode, decided without I/O: one mode at a time, a
first point checked as a trajectory's start, later ones as segments, numbered and timed from
the first, and the mode ended by a stop of motion."""

from __future__ import annotations

import pytest

from motocell.services.ros2.core.codes import READY
from motocell.services.ros2.core.goal import InitTraj
from motocell.services.ros2.core.point_queue import (
    OTHER_MODE_ACTIVE,
    Modes,
    MotionMode,
    QueuedPoint,
    QueueResult,
)
from motocell.shared.protocol.constants import InvalidSubcode, NotReadySubcode, Result

NAMES = (("a1", "a2"), ("b1",))
ALL = ("a1", "a2", "b1")
S = 1_000_000_000


def queued(time_s: float, names: tuple[str, ...] = ALL, positions: int = 3) -> QueuedPoint:
    return QueuedPoint(names, round(time_s * S), (0.1,) * positions, (0.0,) * positions)


def in_point_queue_mode() -> Modes:
    modes = Modes(NAMES)
    modes.started(MotionMode.POINT_QUEUE, READY)
    return modes


def test_one_mode_at_a_time_and_the_same_one_again_goes_on() -> None:
    modes = Modes(NAMES)
    assert modes.refusal(MotionMode.TRAJECTORY) is None
    modes.started(MotionMode.TRAJECTORY, 107)  # not ready (HOLD): no mode
    assert modes.mode is MotionMode.INACTIVE
    modes.started(MotionMode.TRAJECTORY, READY)
    assert modes.refusal(MotionMode.POINT_QUEUE) == OTHER_MODE_ACTIVE
    assert modes.refusal(MotionMode.TRAJECTORY) is None
    modes.stopped()
    assert modes.refusal(MotionMode.POINT_QUEUE) is None


def test_a_point_outside_point_queue_mode_is_the_wrong_mode() -> None:
    modes = Modes(NAMES)
    assert modes.to_send(queued(0)) == QueueResult.WRONG_MODE
    modes.started(MotionMode.TRAJECTORY, READY)
    assert modes.to_send(queued(0)) == QueueResult.WRONG_MODE


def test_points_are_numbered_and_timed_from_the_first_taken() -> None:
    modes = in_point_queue_mode()
    first = modes.to_send(queued(2.0))
    assert not isinstance(first, int)
    assert (first.sequence, first.point.time_s) == (0, 0.0)
    assert first.point.groups == (((0.1, 0.1), (0.0, 0.0)), ((0.1,), (0.0,)))
    assert modes.answered(queued(2.0), Result.SUCCESS, 0) == QueueResult.SUCCESS
    second = modes.to_send(queued(2.5, names=("b1", "a2", "a1")))
    assert not isinstance(second, int)
    assert (second.sequence, second.point.time_s) == (1, 0.5)


def test_busy_keeps_the_point_for_the_client_to_send_again() -> None:
    modes = in_point_queue_mode()
    modes.answered(queued(0), Result.SUCCESS, 0)
    assert modes.answered(queued(1), Result.BUSY, 0) == QueueResult.BUSY
    again = modes.to_send(queued(1))
    assert not isinstance(again, int) and again.sequence == 1


@pytest.mark.parametrize(
    ("point", "code"),
    [
        (queued(0, names=("a1", "a1", "b1")), InitTraj.DUPLICATE_JOINT_NAME),
        (queued(0, names=("a1", "a2")), InitTraj.INCOMPLETE_JOINTLIST),
        (queued(0, names=("a1", "a2", "x")), InitTraj.INVALID_JOINTNAME),
        (queued(0, positions=2), InitTraj.WRONG_NUMBER_OF_POSITIONS),
        (QueuedPoint(ALL, 0, (0.1,) * 3, (0.0,)), InitTraj.WRONG_NUMBER_OF_VELOCITIES),
        (queued(-1), InitTraj.INVALID_TIME),
    ],
)
def test_a_first_point_is_checked_as_a_trajectorys_start(point: QueuedPoint, code: int) -> None:
    assert in_point_queue_mode().to_send(point) == code


@pytest.mark.parametrize(
    ("point", "code"),
    [
        (queued(1, names=("a1", "a2")), QueueResult.INVALID_JOINT_LIST),
        (queued(1, names=("a1", "a2", "x")), QueueResult.INVALID_JOINT_LIST),
        (queued(1, names=("a1", "a1", "b1")), InitTraj.DUPLICATE_JOINT_NAME),
        (queued(1, positions=2), QueueResult.UNABLE_TO_PROCESS_POINT),
        (queued(0.5), QueueResult.UNABLE_TO_PROCESS_POINT),
    ],
)
def test_a_later_point_is_checked_as_a_segment(point: QueuedPoint, code: int) -> None:
    modes = in_point_queue_mode()
    modes.answered(queued(0.5), Result.SUCCESS, 0)
    assert modes.to_send(point) == code


@pytest.mark.parametrize(
    ("subcode", "code"),
    [
        (InvalidSubcode.DATA_START_POS, InitTraj.INVALID_STARTING_POS),
        (InvalidSubcode.DATA_SPEED, InitTraj.INVALID_VELOCITY),
        (InvalidSubcode.DATA_POSITION, InitTraj.UNSPECIFIED),
    ],
)
def test_a_first_point_the_cell_refuses_says_why_as_a_start(subcode: int, code: int) -> None:
    modes = in_point_queue_mode()
    assert modes.answered(queued(0), Result.INVALID, subcode) == code
    assert modes.mode is MotionMode.POINT_QUEUE, "the client may send a better first point"


def test_a_later_point_the_cell_refuses_is_unable_to_process() -> None:
    modes = in_point_queue_mode()
    modes.answered(queued(0), Result.SUCCESS, 0)
    assert (
        modes.answered(queued(1), Result.INVALID, InvalidSubcode.DATA_SPEED)
        == QueueResult.UNABLE_TO_PROCESS_POINT
    )


@pytest.mark.parametrize(
    ("result", "subcode"),
    [(Result.NOT_READY, NotReadySubcode.HOLD), (Result.INVALID, InvalidSubcode.SEQUENCE)],
)
def test_a_stop_of_motion_ends_point_queue_mode(result: Result, subcode: int) -> None:
    """NOT_READY now, or a sequence a stop since ended: start again, from where the robot is."""
    modes = in_point_queue_mode()
    modes.answered(queued(0), Result.SUCCESS, 0)
    assert modes.answered(queued(1), result, subcode) == QueueResult.WRONG_MODE
    assert modes.mode is MotionMode.INACTIVE
    modes.started(MotionMode.POINT_QUEUE, READY)
    restarted = modes.to_send(queued(7))
    assert not isinstance(restarted, int) and restarted.sequence == 0
