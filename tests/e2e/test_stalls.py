"""A stalled service never causes late motion (docs/motion-safety.md).

Each test stops one process with SIGSTOP for STALL_S while a long trajectory streams, then
resumes it. Once the motion client has been told NOT_READY, no tick applies an increment of the
old trajectory; where the cell never says NOT_READY, motion stays correct (no tick moves an
axis more than its maximum per period, no catching up) and ends exactly on the goal. Either
way a new trajectory after START_TRAJ_MODE ends exactly on its goal.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import numpy as np
import pytest
import zenoh

from motocell.shared.bus.schemas import LateTicks
from motocell.shared.config import load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.messages import MotoMotionReply
from motocell.testing.client import (
    BUSY_RETRY_S,
    MotionClient,
    PlannedPoint,
    StateListener,
    point_messages,
    smooth_move,
)
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, SampleLog, TickLog
from tests.e2e.stalling import beyond_the_lease, stall

pytestmark = pytest.mark.cell

STALL_S = 3.0
"""Shorter than the 5 s lease, so no service is declared gone. A test whose
process went longer without running (a loaded machine) is skipped (``stalling``)."""
DEADLINE_S = 60.0
"""For what an idle machine does within a second or two: a bound for a hang, not a speed."""
MOVE_S = 4.0
POINTS = 17
OFFSET = 0.6
"""How far the long trajectory moves axis S, radians."""
STALL_ALARM = 4200
AXIS_MAP = AxisMap(load_cell().groups[0])
MAX_INCREMENTS = AXIS_MAP.max_increments(load_cell().period_s)


def pulses(ros: tuple[float, ...]) -> list[int]:
    """As the cell converts a position it received: Simple Message carries float32."""
    return AXIS_MAP.pad_moto(AXIS_MAP.ros_to_pulses(np.array(ros, dtype=np.float32)))


@dataclass
class Stream:
    """A trajectory streamed on its own thread, as motoman_driver does (BUSY: resend after
    5 ms); the first refusal ends it."""

    motion: MotionClient
    trajectory: list[PlannedPoint]
    accepted: int = 0
    refusal: MotoMotionReply | None = None
    refused_ns: int = 0
    """CLOCK_MONOTONIC when the refusal reached the client."""
    thread: threading.Thread = field(init=False)

    def __post_init__(self) -> None:
        self.thread = threading.Thread(target=self._run)
        self.thread.start()

    def _run(self) -> None:
        for message in point_messages(0, self.trajectory):
            reply = self.motion.motion(message)
            while reply.result == Result.BUSY:
                time.sleep(BUSY_RETRY_S)
                reply = self.motion.motion(message)
            if reply.result != Result.SUCCESS:
                self.refused_ns = time.monotonic_ns()
                self.refusal = reply
                return
            self.accepted += 1

    def join(self) -> None:
        self.thread.join(MOVE_S + STALL_S + DEADLINE_S)
        assert not self.thread.is_alive(), "the stream never ended"


def positions(state: StateListener) -> tuple[float, ...]:
    return tuple(state.wait_still(DEADLINE_S).groups[0].positions[:6])


def start_traj_mode(motion: MotionClient) -> None:
    """START_TRAJ_MODE until it succeeds: the cell may still be hearing from the process that
    was stopped."""

    def started() -> bool:
        return motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS

    wait_until(started, DEADLINE_S, "START_TRAJ_MODE to succeed")


def assert_arrives(state: StateListener, goal: tuple[float, ...]) -> None:
    target = pulses(goal)

    def there() -> bool:
        feedback = state.latest()
        return (
            feedback is not None
            and feedback.status is not None
            and feedback.status.in_motion == 0
            and pulses(tuple(feedback.groups[0].positions[:6])) == target
        )

    wait_until(there, DEADLINE_S, "the robot to stop exactly on the goal")


def assert_no_burst(ticks: TickLog, first: int) -> None:
    for tick in ticks.since(first):
        increment = tick.groups[0].increment
        assert all(abs(i) <= m for i, m in zip(increment, MAX_INCREMENTS, strict=True)), tick


def stalled_stream(
    motion: MotionClient, state: StateListener, pids: set[int], service: str
) -> tuple[Stream, tuple[float, ...]]:
    """Stream the long trajectory, stop ``pids`` for STALL_S once the robot moves, resume
    them, and wait for the stream to end; the stream and its goal. Skips the test if the stall
    ran on into the lease (alarms reset, for the module's next test)."""
    start_traj_mode(motion)
    start = positions(state)
    goal = (start[0] + (-OFFSET if start[0] > 0 else OFFSET), *start[1:])
    moving = Stream(motion, smooth_move(start, goal, MOVE_S, POINTS))
    state.wait_for(lambda f: f.status is not None and f.status.in_motion == 1, DEADLINE_S)
    lived = stall(pids, STALL_S)
    moving.join()
    reason = beyond_the_lease(lived, f"the {service}")
    if reason:
        motion.command(Command.RESET_ALARM)
        pytest.skip(reason)
    return moving, goal


def assert_nothing_late(ticks: TickLog, first: int, refused_ns: int) -> None:
    """No tick applied after the client was told NOT_READY moved the robot."""
    late = [
        tick
        for tick in ticks.since(first)
        if tick.deadline_ns + tick.lateness_ns > refused_ns and any(tick.groups[0].increment)
    ]
    moved = np.sum([t.groups[0].increment for t in late], axis=0) if late else 0
    assert not late, f"{len(late)} ticks moved after NOT_READY: {moved} pulses"


def recover_and_move(motion: MotionClient, state: StateListener) -> None:
    """RESET_ALARM and START_TRAJ_MODE, then a short trajectory that must end exactly."""
    assert motion.command(Command.RESET_ALARM).result == Result.SUCCESS
    start_traj_mode(motion)
    start = positions(state)
    goal = (start[0] + (-0.2 if start[0] > 0 else 0.2), *start[1:])
    moved = Stream(motion, smooth_move(start, goal, 1.0, 5))
    moved.join()
    assert moved.refusal is None, moved.refusal
    assert_arrives(state, goal)


STOPS_MOTION = {"executor", "controller", "router"}
"""The stalls that stop motion: the executor's own (its tick is late), and those that silence
the controller's status at the executor. The others only pause the stream or the state, but
for the interpolator's (``MAY_STOP_MOTION``)."""
MAY_STOP_MOTION = {"interpolator"}
"""A ring left empty while its interpolator owes it increments is a broken increment path
(docs/motion-safety.md, What a ring is owed): NOT_READY 5012. Whether the interpolator owed
any when it stopped (the rest of a segment, a point it had) or had sent all it had (the ring
then runs dry as for a late client, and the motion resumes) is a matter of where in the stream
the stop fell; each outcome is checked."""


def assert_late_ticks_said(late: SampleLog[LateTicks]) -> None:
    """The stopped executor's clock says on the bus that it missed periods, as soon as it runs
    again: its first tick after the stall came about STALL_S late."""

    def said() -> bool:
        return any(sample.lateness_ns >= STALL_S / 2 * 1e9 for sample in late.since(0))

    wait_until(said, DEADLINE_S, "the executor to say its clock missed periods")
    (first, *_) = late.since(0)
    assert first.periods >= 1 and first.missed_total >= first.periods, first


def pids_of(cell: RunningCell, service: str) -> set[int]:
    """The launcher runs the router in-process: stopping it stops supervision too."""
    return {cell.process.pid} if service == "router" else cell.service_pids(service)


@pytest.mark.parametrize(
    "service", ["executor", "controller", "router", "gateway", "interpolator", "broadcaster"]
)
def test_a_stalled_service_causes_no_late_motion(
    cell: RunningCell,
    bus: zenoh.Session,
    motion: MotionClient,
    state: StateListener,
    ticks: TickLog,
    service: str,
) -> None:
    stopped = pids_of(cell, service)
    assert stopped
    first = len(ticks)
    late = SampleLog(bus, cell.keys.executor_late, LateTicks)
    try:
        moving, goal = stalled_stream(motion, state, stopped, service)
        if service == "executor":
            assert_late_ticks_said(late)
    finally:
        late.subscriber.undeclare()
    if service in MAY_STOP_MOTION and moving.refusal is not None:
        assert moving.refusal.result == Result.NOT_READY, moving.refusal
        assert moving.refusal.subcode == NotReadySubcode.INC_MOVE_ERROR, moving.refusal
        positions(state)
        assert_nothing_late(ticks, first, moving.refused_ns)
    elif service in STOPS_MOTION:
        assert moving.refusal is not None, "the stall did not stop the trajectory"
        assert moving.refusal.result == Result.NOT_READY, moving.refusal
        shown = state.wait_for(
            lambda f: f.status is not None and f.status.error_code == STALL_ALARM, DEADLINE_S
        )
        assert shown.status is not None and shown.status.in_error == 1
        positions(state)  # still: every tick applied so far has been published
        assert_nothing_late(ticks, first, moving.refused_ns)
    else:
        assert moving.refusal is None, moving.refusal
        assert_arrives(state, goal)
    assert_no_burst(ticks, first)
    recover_and_move(motion, state)
