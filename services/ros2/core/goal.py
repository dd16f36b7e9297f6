"""A FollowJointTrajectory goal as MotoROS2 takes it, no I/O: whether it can run, the points the
cell is sent, and how the run ended (docs/ros2.md, FollowJointTrajectory).

MotoROS2 accepts every goal and aborts the ones it refuses at once, with
``error_code = ros_code * 100000 - motoman_code``: ``INVALID_GOAL`` (-1) with the reason from
``InitTrajEnum`` (2xx) or ``MotionReadyEnum`` (1xx); a finished run outside its tolerances is
``GOAL_TOLERANCE_VIOLATED`` (-5) with 301 (position) or 302 (time); a cancel -5 with 300; an
alarm or error during the run -1 with 303.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum

from motocell.shared.protocol.constants import InvalidSubcode, Result

MAX_POINTS = 200
"""MotoROS2's longest trajectory."""
DEFAULT_POSITION_TOLERANCE = 0.01
"""rad or m, where a goal's tolerance for a joint is 0 (MotoROS2's default)."""
DEFAULT_TIME_TOLERANCE_NS = 500_000_000
"""Where a goal's time tolerance is 0 (MotoROS2's default); a negative one is not checked."""

SUCCESSFUL, INVALID_GOAL, GOAL_TOLERANCE_VIOLATED = 0, -1, -5
"""control_msgs' FollowJointTrajectory result codes MotoROS2 uses."""


class InitTraj(int, Enum):
    """MotoROS2's ``InitTrajEnum``: why a goal does not start."""

    UNSPECIFIED = 200
    TOO_SMALL = 201
    TOO_BIG = 202
    INVALID_STARTING_POS = 204
    INVALID_VELOCITY = 205
    INVALID_JOINTNAME = 206
    INCOMPLETE_JOINTLIST = 207
    INVALID_TIME = 208
    WRONG_MODE = 209
    BACKWARD_TIME = 210
    WRONG_NUMBER_OF_POSITIONS = 211
    WRONG_NUMBER_OF_VELOCITIES = 212
    INVALID_ENDING_VELOCITY = 213
    DUPLICATE_JOINT_NAME = 215


class FailTraj(int, Enum):
    """MotoROS2's reasons a goal that ran did not succeed."""

    CANCEL = 300
    POSITION = 301
    TIME = 302
    ALARM = 303


INVALID_POINT = {
    int(InvalidSubcode.DATA_START_POS): InitTraj.INVALID_STARTING_POS,
    int(InvalidSubcode.DATA_SPEED): InitTraj.INVALID_VELOCITY,
    int(InvalidSubcode.DATA_TIME): InitTraj.INVALID_TIME,
}
"""The cell's refusal of a point (INVALID, motoros1 §2.4) as MotoROS2 says it; others are
UNSPECIFIED."""


def error_code(ros_code: int, motoman_code: int) -> int:
    return ros_code * 100_000 - motoman_code


@dataclass(frozen=True)
class GoalPoint:
    time_ns: int
    positions: tuple[float, ...]
    velocities: tuple[float, ...]


@dataclass(frozen=True)
class Goal:
    """What the face uses of a goal: MotoROS2 reads the trajectory, the goal tolerances and the
    goal time tolerance, nothing else."""

    joint_names: tuple[str, ...]
    points: tuple[GoalPoint, ...]
    position_tolerances: Mapping[str, float]
    time_tolerance_ns: int


@dataclass(frozen=True)
class PlannedPoint:
    time_s: float
    groups: tuple[tuple[tuple[float, ...], tuple[float, ...]], ...]
    """Per group: its positions and velocities, in ROS order."""


@dataclass(frozen=True)
class Plan:
    points: tuple[PlannedPoint, ...]
    goal: tuple[float, ...]
    """The last point, every joint in the face's order (``joint_states``')."""
    tolerances: tuple[float | None, ...]
    """Per joint in that order; None: not checked."""
    duration_ns: int
    time_tolerance_ns: int | None


def plan(goal: Goal, names_by_group: Sequence[Sequence[str]]) -> Plan | InitTraj:
    """The points to send for ``goal``, or why MotoROS2 would not start it (its checks)."""
    order = [name for names in names_by_group for name in names]
    refusal = _refusal(goal, order)
    if refusal is not None:
        return refusal
    column = {name: index for index, name in enumerate(goal.joint_names)}
    points = []
    for point in goal.points:
        groups = tuple(
            (
                tuple(point.positions[column[name]] for name in names),
                tuple(point.velocities[column[name]] for name in names),
            )
            for names in names_by_group
        )
        points.append(PlannedPoint(point.time_ns / 1e9, groups))
    last = goal.points[-1]
    tolerances = tuple(_tolerance(goal.position_tolerances.get(name, 0.0)) for name in order)
    time_tolerance = goal.time_tolerance_ns or DEFAULT_TIME_TOLERANCE_NS
    return Plan(
        tuple(points),
        tuple(last.positions[column[name]] for name in order),
        tolerances,
        last.time_ns,
        None if time_tolerance < 0 else time_tolerance,
    )


def _tolerance(given: float) -> float | None:
    if given < 0:
        return None
    return given or DEFAULT_POSITION_TOLERANCE


def _refusal(goal: Goal, order: Sequence[str]) -> InitTraj | None:
    points, names = goal.points, goal.joint_names
    if len(points) > MAX_POINTS:
        return InitTraj.TOO_BIG
    if len(points) < 2:
        return InitTraj.TOO_SMALL
    if len(set(names)) != len(names):
        return InitTraj.DUPLICATE_JOINT_NAME
    if not set(names) <= set(order):
        return InitTraj.INVALID_JOINTNAME
    if len(names) != len(order):
        return InitTraj.INCOMPLETE_JOINTLIST
    return _point_refusal(points, len(names))


def _point_refusal(points: Sequence[GoalPoint], joints: int) -> InitTraj | None:
    if any(len(point.positions) != joints for point in points):
        return InitTraj.WRONG_NUMBER_OF_POSITIONS
    if any(len(point.velocities) != joints for point in points):
        return InitTraj.WRONG_NUMBER_OF_VELOCITIES
    if points[0].time_ns < 0:
        return InitTraj.INVALID_TIME
    if any(later.time_ns <= earlier.time_ns for earlier, later in itertools.pairwise(points)):
        return InitTraj.BACKWARD_TIME
    if any(points[-1].velocities):
        return InitTraj.INVALID_ENDING_VELOCITY
    return None


class Streamed(Enum):
    NEXT = "the point was taken: send the next"
    AGAIN = "BUSY: send it again shortly"
    REFUSED = "the cell refused the trajectory"


def streamed(result: int) -> Streamed:
    if result == Result.SUCCESS:
        return Streamed.NEXT
    if result == Result.BUSY:
        return Streamed.AGAIN
    return Streamed.REFUSED


def refused_code(result: int, subcode: int, first: bool) -> int:
    """The result's error code for a point the cell refused: the first point's refusal is the
    goal's (INVALID_GOAL and why); a later one, or NOT_READY, means the run was stopped by an
    alarm or error, as MotoROS2 sees it."""
    if first and result == Result.INVALID:
        return error_code(INVALID_GOAL, INVALID_POINT.get(subcode, InitTraj.UNSPECIFIED))
    return error_code(INVALID_GOAL, FailTraj.ALARM)


@dataclass(frozen=True)
class Ending:
    error_code: int
    violators: tuple[tuple[int, float], ...] = ()
    """Joints (index in the face's order) outside their tolerance, and by how much."""
    elapsed_ns: int = 0
    """How long the run took, for a run that ended on its own."""


def judge(plan: Plan, actual: Sequence[float], elapsed_ns: int) -> Ending:
    """A run that ended: within its goal tolerances (SUCCESSFUL), or which one it missed,
    position first, as MotoROS2 checks."""
    violators = tuple(
        (index, abs(target - reached))
        for index, (target, reached, tolerance) in enumerate(
            zip(plan.goal, actual, plan.tolerances, strict=True)
        )
        if tolerance is not None and abs(target - reached) > tolerance
    )
    if violators:
        return Ending(error_code(GOAL_TOLERANCE_VIOLATED, FailTraj.POSITION), violators, elapsed_ns)
    tolerance = plan.time_tolerance_ns
    if tolerance is not None and abs(elapsed_ns - plan.duration_ns) > tolerance:
        return Ending(error_code(GOAL_TOLERANCE_VIOLATED, FailTraj.TIME), elapsed_ns=elapsed_ns)
    return Ending(SUCCESSFUL, elapsed_ns=elapsed_ns)


CANCEL_WORDS = "Goal was cancelled by the user."
ENDING_WORDS: dict[int, str] = {
    FailTraj.CANCEL: CANCEL_WORDS,
    FailTraj.ALARM: "Goal was aborted due to an alarm or error (check RobotStatus messages).",
}
"""MotoROS2's words for the endings that carry nothing more."""


def ending_words(ending: Ending, plan: Plan, names: Sequence[str]) -> str:
    """The result's ``error_string``, in MotoROS2's words, for a run that started."""
    if ending.error_code == SUCCESSFUL:
        return "Trajectory completed successfully!"
    reason = -(ending.error_code % -100_000)
    if reason == FailTraj.POSITION:
        deviations = "".join(f" [{names[i]}: {off:.4f} deviation]" for i, off in ending.violators)
        return (
            "Final position was outside tolerance. Check robot safety-limits that could be "
            f"inhibiting motion.{deviations}"
        )
    if reason == FailTraj.TIME:
        return (
            f"Execution time was outside tolerance. Target time was {plan.duration_ns / 1e9:.3f} "
            f"seconds. Actual time was {ending.elapsed_ns / 1e9:.3f} seconds."
        )
    return ENDING_WORDS.get(reason, "")
