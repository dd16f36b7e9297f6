"""One FollowJointTrajectory goal run against the cell (docs/ros2.md, FollowJointTrajectory): its
points streamed to the one motion API as motoman_driver streams them (a BUSY point sent again
after 5 ms), feedback every ``action_feedback_publisher_period``, stopped on a cancel or an
alarm, ended once the robot has come to rest after the trajectory's time. No ROS 2 here: the
node runs it on its action's thread and turns what it says into messages."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Protocol

from motocell.services.ros2.core.goal import (
    INVALID_GOAL,
    Ending,
    FailTraj,
    Plan,
    PlannedPoint,
    Streamed,
    error_code,
    judge,
    refused_code,
    streamed,
)
from motocell.shared.bus.schemas import State
from motocell.shared.config import Group
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.messages import Message, MotoMotionReply
from motocell.shared.protocol.replies import ex_group, motion_ctrl, traj_point, traj_point_ex

BUSY_RETRY_S = 0.005
"""motoman_driver resends a BUSY point after 5 ms."""
CANCELLED = error_code(-5, FailTraj.CANCEL)


class Requests(Protocol):
    def request(self, message: Message) -> Message | None: ...


def point_message(groups: Sequence[Group], sequence: int, point: PlannedPoint) -> Message:
    """JOINT_TRAJ_PT_FULL for a cell of one group, MOTO_JOINT_TRAJ_PT_FULL_EX for more, as
    motoman_driver sends them."""
    if len(groups) == 1:
        ((positions, velocities),) = point.groups
        return traj_point(groups[0].index, sequence, point.time_s, positions, velocities)
    blocks = [
        ex_group(group.index, point.time_s, positions, velocities)
        for group, (positions, velocities) in zip(groups, point.groups, strict=True)
    ]
    return traj_point_ex(sequence, blocks)


def positions_of(state: State, groups: Sequence[Group]) -> list[float]:
    return [
        value for group in groups for value in state.groups[group.index].positions[: group.axes]
    ]


class GoalRunner:
    def __init__(
        self,
        motion: Requests,
        newest: Callable[[], State | None],
        groups: Sequence[Group],
        feedback_period_ns: int,
        *,
        monotonic_ns: Callable[[], int] = time.monotonic_ns,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self._motion = motion
        self._newest = newest
        self._groups = groups
        self._feedback_period_ns = feedback_period_ns
        self._monotonic_ns = monotonic_ns
        self._sleep = sleep

    def run(
        self, plan: Plan, cancelled: Callable[[], bool], feedback: Callable[[State], None]
    ) -> Ending:
        messages = [
            point_message(self._groups, sequence, point)
            for sequence, point in enumerate(plan.points)
        ]
        sent = 0
        started_ns = next_feedback_ns = self._monotonic_ns()
        while True:
            if cancelled():
                self._stop_motion()
                return Ending(CANCELLED)
            while sent < len(messages):
                reply = self._reply(messages[sent])
                step = streamed(reply.result)
                if step is Streamed.AGAIN:
                    break
                if step is Streamed.REFUSED:
                    self._stop_motion()
                    return Ending(refused_code(reply.result, reply.subcode, first=sent == 0))
                sent += 1
            now = self._monotonic_ns()
            state = self._newest()
            if state is not None:
                if now >= next_feedback_ns:
                    feedback(state)
                    next_feedback_ns = now + self._feedback_period_ns
                if _faulted(state):
                    self._stop_motion()
                    return Ending(error_code(INVALID_GOAL, FailTraj.ALARM))
                resting = state.status.in_motion == 0 and state.tick_ns > started_ns
                if sent == len(messages) and now - started_ns >= plan.duration_ns and resting:
                    return judge(plan, positions_of(state, self._groups), now - started_ns)
            self._sleep(BUSY_RETRY_S)

    def _reply(self, message: Message) -> MotoMotionReply:
        reply = self._motion.request(message)
        body = None if reply is None else reply.body
        if isinstance(body, MotoMotionReply):
            return body
        return MotoMotionReply(0, 0, 0, int(Result.FAILURE), 0)  # no answer: refused

    def _stop_motion(self) -> None:
        self._motion.request(motion_ctrl(Command.STOP_MOTION))


def _faulted(state: State) -> bool:
    """An alarm, an error or an E-stop while the goal runs: MotoROS2 stops it."""
    status = state.status
    return status.in_error == 1 or status.e_stopped == 1
