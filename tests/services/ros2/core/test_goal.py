"""A FollowJointTrajectory goal as MotoROS2 takes it: every refusal of its checks, the points in
the cell's groups and order, and how a run that ended is judged and worded."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import pytest

from motocell.services.ros2.core.goal import (
    CANCEL_WORDS,
    Ending,
    FailTraj,
    Goal,
    GoalPoint,
    InitTraj,
    Plan,
    ending_words,
    error_code,
    judge,
    plan,
    refused_code,
)
from motocell.shared.protocol.constants import InvalidSubcode, Result

NAMES = [["a1", "a2"], ["s1"]]
"""Two groups: the face's joint order is a1, a2, s1."""
S = 1_000_000_000


def goal(names: tuple[str, ...] = ("s1", "a2", "a1"), **changes: Any) -> Goal:
    """Three points in a shuffled joint order, resting at both ends."""
    points = (
        GoalPoint(0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        GoalPoint(S, (0.3, 0.2, 0.1), (0.1, 0.1, 0.1)),
        GoalPoint(2 * S, (0.6, 0.4, 0.2), (0.0, 0.0, 0.0)),
    )
    return replace(Goal(names, points, {}, 0), **changes)


def test_the_points_go_per_group_in_the_faces_order() -> None:
    planned = plan(goal(), NAMES)
    assert isinstance(planned, Plan)
    assert planned.points[1].time_s == 1.0
    assert planned.points[1].groups == (((0.1, 0.2), (0.1, 0.1)), ((0.3,), (0.1,)))
    assert planned.goal == (0.2, 0.4, 0.6)
    assert (planned.duration_ns, planned.time_tolerance_ns) == (2 * S, S // 2)
    assert planned.tolerances == (0.01, 0.01, 0.01)


def test_a_goals_tolerances_zero_is_the_default_and_negative_unchecked() -> None:
    planned = plan(goal(position_tolerances={"a1": 0.5, "a2": -1.0}, time_tolerance_ns=-1), NAMES)
    assert isinstance(planned, Plan)
    assert planned.tolerances == (0.5, None, 0.01)
    assert planned.time_tolerance_ns is None


def point(time_ns: int, values: tuple[float, ...], speeds: tuple[float, ...]) -> GoalPoint:
    return GoalPoint(time_ns, values, speeds)


REST = (0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    ("changes", "refusal"),
    [
        ({"points": (point(0, REST, REST),) * 201}, InitTraj.TOO_BIG),
        ({"points": (point(0, REST, REST),)}, InitTraj.TOO_SMALL),
        ({"joint_names": ("a1", "a1", "s1")}, InitTraj.DUPLICATE_JOINT_NAME),
        ({"joint_names": ("a1", "a2", "x9")}, InitTraj.INVALID_JOINTNAME),
        (
            {"joint_names": ("a1", "a2"), "points": (point(0, REST[:2], REST[:2]),) * 2},
            InitTraj.INCOMPLETE_JOINTLIST,
        ),
        (
            {"points": (point(0, REST, REST), point(S, (0.0,), REST))},
            InitTraj.WRONG_NUMBER_OF_POSITIONS,
        ),
        (
            {"points": (point(0, REST, REST), point(S, REST, ()))},
            InitTraj.WRONG_NUMBER_OF_VELOCITIES,
        ),
        ({"points": (point(-1, REST, REST), point(S, REST, REST))}, InitTraj.INVALID_TIME),
        ({"points": (point(S, REST, REST), point(S, REST, REST))}, InitTraj.BACKWARD_TIME),
        (
            {"points": (point(0, REST, REST), point(S, REST, (0.1, 0.0, 0.0)))},
            InitTraj.INVALID_ENDING_VELOCITY,
        ),
    ],
)
def test_motoros2s_checks_refuse_with_its_code(changes: dict[str, Any], refusal: InitTraj) -> None:
    assert plan(goal(**changes), NAMES) is refusal


def test_the_error_code_is_ros_code_times_100000_less_motomans() -> None:
    assert error_code(-1, 209) == -100209
    assert error_code(-5, FailTraj.CANCEL) == -500300


@pytest.mark.parametrize(
    ("result", "subcode", "first", "code"),
    [
        (Result.INVALID, InvalidSubcode.DATA_START_POS, True, -100204),
        (Result.INVALID, InvalidSubcode.DATA_SPEED, True, -100205),
        (Result.INVALID, InvalidSubcode.DATA_POSITION, True, -100200),
        (Result.INVALID, InvalidSubcode.DATA_SPEED, False, -100303),
        (Result.NOT_READY, 5003, True, -100303),
    ],
)
def test_a_refused_point_is_the_goals_refusal_first_and_an_alarm_after(
    result: Result, subcode: int, first: bool, code: int
) -> None:
    assert refused_code(result, subcode, first) == code


def planned() -> Plan:
    result = plan(goal(), NAMES)
    assert isinstance(result, Plan)
    return result


def test_a_run_within_its_tolerances_succeeds() -> None:
    ending = judge(planned(), (0.205, 0.4, 0.6), 2 * S + S // 4)
    assert ending == Ending(0, elapsed_ns=2 * S + S // 4)
    assert (
        ending_words(ending, planned(), ["a1", "a2", "s1"]) == "Trajectory completed successfully!"
    )


def test_a_run_short_of_its_goal_names_the_joints() -> None:
    ending = judge(planned(), (0.2, 0.38, 0.6), 2 * S)
    assert ending.error_code == -500301
    assert ending_words(ending, planned(), ["a1", "a2", "s1"]).endswith("[a2: 0.0200 deviation]")


def test_a_run_too_late_says_both_times() -> None:
    ending = judge(planned(), (0.2, 0.4, 0.6), 3 * S)
    assert ending.error_code == -500302
    words = ending_words(ending, planned(), ["a1", "a2", "s1"])
    assert words.endswith("Target time was 2.000 seconds. Actual time was 3.000 seconds.")


def test_a_cancel_has_motoros2s_words() -> None:
    assert ending_words(Ending(-500300), planned(), []) == CANCEL_WORDS
