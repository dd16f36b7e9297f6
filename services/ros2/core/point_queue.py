"""MotoROS2's motion modes and its point-queue mode, no I/O (docs/ros2.md, Point-queue mode).

MotoROS2 runs one motion mode at a time: ``start_traj_mode`` starts trajectory mode (the
FollowJointTrajectory action), ``start_point_queue_mode`` point-queue mode (the
``queue_traj_point`` service), ``stop_traj_mode`` ends either; starting the other one while one
runs is refused with NOT_READY_OTHER_TRAJ_MODE_ACTIVE (114). In point-queue mode each queued
point is a new segment from the one before: the first must be where the robot is, and each
later one comes once the cell has taken the one before (else BUSY, send it again). Point-queue
mode ends when motion stops being possible, so a robot that was stopped or moved meanwhile
starts again from where it is, with a new first point.

The cell already runs this as a Simple Message trajectory streamed point by point (one
pending point, motoros1 §3.1): a queued point is one JOINT_TRAJ_PT_FULL, its sequence number
counted from the mode's first point, its time from the first point's ``time_from_start``. So
the gateway checks it as it checks any client's, and its answer says what MotoROS2 says.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

from motocell.services.ros2.core.codes import READY
from motocell.services.ros2.core.goal import INVALID_POINT, InitTraj, PlannedPoint
from motocell.shared.protocol.constants import InvalidSubcode, Result

OTHER_MODE_ACTIVE = 114
"""MotionReadyEnum's NOT_READY_OTHER_TRAJ_MODE_ACTIVE."""


class MotionMode(Enum):
    INACTIVE = "no motion mode"
    TRAJECTORY = "trajectory mode"
    POINT_QUEUE = "point-queue mode"


class QueueResult(int, Enum):
    """MotoROS2's ``QueueResultEnum``; a first point's refusal is an ``InitTraj`` code."""

    SUCCESS = 1
    WRONG_MODE = 2
    BUSY = 4
    INVALID_JOINT_LIST = 5
    UNABLE_TO_PROCESS_POINT = 6


@dataclass(frozen=True)
class QueuedPoint:
    """What the face uses of a ``queue_traj_point`` request."""

    joint_names: tuple[str, ...]
    time_ns: int
    positions: tuple[float, ...]
    velocities: tuple[float, ...]


@dataclass(frozen=True)
class Numbered:
    """A point to send: its sequence number in the queue, and the point."""

    sequence: int
    point: PlannedPoint


class Modes:
    """The face's motion mode and, in point-queue mode, where its queue stands. One at a time:
    the node serves its services one after another."""

    def __init__(self, names_by_group: Sequence[Sequence[str]]) -> None:
        self._names_by_group = [tuple(names) for names in names_by_group]
        self.mode = MotionMode.INACTIVE
        self._taken = 0
        """Points the cell took since point-queue mode started: 0, the next is the first."""
        self._first_ns = 0
        self._last_ns = 0

    def refusal(self, wanted: MotionMode) -> int | None:
        """Why ``wanted`` cannot start now: another mode runs (114); None if it can."""
        if self.mode not in (MotionMode.INACTIVE, wanted):
            return OTHER_MODE_ACTIVE
        return None

    def started(self, wanted: MotionMode, code: int) -> None:
        """``wanted`` was asked for and the cell answered ``code``: it runs if READY. Asked
        again while it runs, it goes on where it stands (MotoROS2: already active)."""
        if code == READY and self.mode is MotionMode.INACTIVE:
            self.mode = wanted
            self._taken = 0

    def stopped(self) -> None:
        self.mode = MotionMode.INACTIVE

    def to_send(self, queued: QueuedPoint) -> Numbered | int:
        """The point to send for ``queued``, or the code that refuses it."""
        if self.mode is not MotionMode.POINT_QUEUE:
            return QueueResult.WRONG_MODE
        first = self._taken == 0
        refusal = self._refusal(queued, first)
        if refusal is not None:
            return refusal
        column = {name: index for index, name in enumerate(queued.joint_names)}
        groups = tuple(
            (
                tuple(queued.positions[column[name]] for name in names),
                tuple(queued.velocities[column[name]] for name in names),
            )
            for names in self._names_by_group
        )
        since_first_ns = 0 if first else queued.time_ns - self._first_ns
        return Numbered(self._taken, PlannedPoint(since_first_ns / 1e9, groups))

    def _refusal(self, queued: QueuedPoint, first: bool) -> int | None:
        """MotoROS2's checks: a first point as the start of a trajectory (``InitTraj``), a
        later one as a segment (``QueueResult``)."""
        names = queued.joint_names
        order = {name for names in self._names_by_group for name in names}
        if len(set(names)) != len(names):
            return InitTraj.DUPLICATE_JOINT_NAME
        if first:
            if len(names) != len(order):
                return InitTraj.INCOMPLETE_JOINTLIST
            if not set(names) <= order:
                return InitTraj.INVALID_JOINTNAME
            if len(queued.positions) != len(names):
                return InitTraj.WRONG_NUMBER_OF_POSITIONS
            if len(queued.velocities) != len(names):
                return InitTraj.WRONG_NUMBER_OF_VELOCITIES
            return InitTraj.INVALID_TIME if queued.time_ns < 0 else None
        if len(names) != len(order) or not set(names) <= order:
            return QueueResult.INVALID_JOINT_LIST
        if len(queued.positions) != len(names) or len(queued.velocities) != len(names):
            return QueueResult.UNABLE_TO_PROCESS_POINT
        if queued.time_ns <= self._last_ns:
            return QueueResult.UNABLE_TO_PROCESS_POINT  # MotoROS2: a backward time
        return None

    def answered(self, queued: QueuedPoint, result: int, subcode: int) -> int:
        """The cell's answer to the point sent for ``queued``, as MotoROS2 says it. A point
        refused because motion stopped being possible (NOT_READY, or INVALID for a sequence
        the stop ended) ends point-queue mode: WRONG_MODE, start it again."""
        first = self._taken == 0
        if result == Result.SUCCESS:
            if first:
                self._first_ns = queued.time_ns
            self._last_ns = queued.time_ns
            self._taken += 1
            return QueueResult.SUCCESS
        if result == Result.BUSY:
            return QueueResult.BUSY
        if result == Result.NOT_READY or (
            result == Result.INVALID and subcode == InvalidSubcode.SEQUENCE
        ):
            self.stopped()
            return QueueResult.WRONG_MODE
        if first and result == Result.INVALID:
            return INVALID_POINT.get(subcode, InitTraj.UNSPECIFIED)
        return QueueResult.UNABLE_TO_PROCESS_POINT
