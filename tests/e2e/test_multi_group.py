"""The dual-arm-positioner cell over real TCP: R1 (6 axes), R2 (7 axes), S1 (2-axis positioner)."""

from __future__ import annotations

import os
import signal
import socket
import struct
import threading

import numpy as np
import pytest
import zenoh

from motocell.shared.bus.keys import CellKeys
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.codec import Role, decode_frames
from motocell.shared.protocol.constants import (
    Command,
    InvalidSubcode,
    MsgType,
    NotReadySubcode,
    Result,
)
from motocell.shared.protocol.messages import JointFeedbackEx
from motocell.shared.protocol.replies import ex_group, traj_point, traj_point_ex
from motocell.testing.client import (
    Feedback,
    MotionClient,
    PlannedPoint,
    StateListener,
    smooth_move,
    stream,
    stream_ex,
    stream_messages,
)
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, TickLog

pytestmark = [
    pytest.mark.cell,
    pytest.mark.parametrize("cell", ["dual-arm-positioner.toml"], indirect=True),
]

GROUPS = (0, 1, 2)


@pytest.fixture
def maps(cell: RunningCell) -> list[AxisMap]:
    return [AxisMap(group) for group in cell.cell.groups]


def positions(feedback: Feedback, maps: list[AxisMap]) -> dict[int, tuple[float, ...]]:
    return {g: tuple(feedback.groups[g].positions[: maps[g].axes]) for g in GROUPS}


def pulses(axis_map: AxisMap, ros: tuple[float, ...]) -> list[int]:
    return axis_map.pad_moto(axis_map.ros_to_pulses(np.array(ros)))


def first_tick_at(ticks: TickLog, start: int, group: int, target: list[int]) -> int:
    for tick in ticks.since(start):
        if tick.groups[group].command_pulses == target:
            return tick.tick
    raise AssertionError(f"group {group} never reached {target}")


def first_moving_tick(ticks: TickLog, start: int, group: int) -> int:
    for tick in ticks.since(start):
        if any(tick.groups[group].increment):
            return tick.tick
    raise AssertionError(f"group {group} never moved")


def test_three_groups_streamed_as_2016_start_and_arrive_in_the_same_tick(
    ticks: TickLog, motion: MotionClient, state: StateListener, maps: list[AxisMap]
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = positions(state.wait_still(), maps)
    offsets = {0: 0.3, 1: 0.2, 2: 0.5}
    goals = {g: tuple(p + offsets[g] for p in start[g]) for g in GROUPS}
    # 0.15 s apart: no waypoint on the 4 ms grid.
    plans = {g: smooth_move(start[g], goals[g], 1.2, 9) for g in GROUPS}
    mark = len(ticks)

    result = stream_ex(motion, plans)

    assert result.points == 9, result.last_reply
    targets = {g: pulses(maps[g], goals[g]) for g in GROUPS}
    arrived = state.wait_for(
        lambda f: (
            f.status is not None
            and f.status.in_motion == 0
            and all(pulses(maps[g], positions(f, maps)[g]) == targets[g] for g in GROUPS)
        ),
        10.0,
    )
    assert arrived.ex is not None and arrived.ex.number_of_valid_groups == 3
    # A rest-to-rest move creeps its last pulses, so the tick each group "arrives" depends
    # on its resolution. Constant-velocity ramps move every group tens of pulses per tick
    # from the first period to the last, so first and last moving ticks are exact.
    start = positions(state.wait_still(), maps)
    speeds = {0: 0.25, 1: 0.2, 2: 0.5}
    ramps = {g: ramp(start[g], speeds[g], 0.6, 5) for g in GROUPS}
    mark = len(ticks)
    assert stream_ex(motion, ramps).points == 5
    ends = {g: pulses(maps[g], ramps[g][-1].positions) for g in GROUPS}
    state.wait_for(
        lambda f: (
            f.status is not None
            and f.status.in_motion == 0
            and all(pulses(maps[g], positions(f, maps)[g]) == ends[g] for g in GROUPS)
        ),
        10.0,
    )
    starts = {first_moving_tick(ticks, mark, g) for g in GROUPS}
    arrivals = {first_tick_at(ticks, mark, g, ends[g]) for g in GROUPS}
    assert len(starts) == 1, f"groups started in ticks {starts}"
    assert len(arrivals) == 1, f"groups arrived in ticks {arrivals}"
    assert arrivals.pop() - starts.pop() + 1 == round(0.6 / 0.004)


def ramp(
    start: tuple[float, ...], speed: float, duration: float, points: int
) -> list[PlannedPoint]:
    times = [duration * i / (points - 1) for i in range(points)]
    return [
        PlannedPoint(t, tuple(p + speed * t for p in start), (speed,) * len(start)) for t in times
    ]


def test_seven_axis_joint_order_both_ways(
    ticks: TickLog, motion: MotionClient, state: StateListener, maps: list[AxisMap]
) -> None:
    """R2 moves only its ROS joint 2 (E): that is Motoman axis 6, and feedback shows joint 2."""
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    before = positions(state.wait_still(), maps)[1]
    goal = tuple(p + (0.25 if joint == 2 else 0.0) for joint, p in enumerate(before))
    mark = len(ticks)
    # Single-group type 14 with robot_id = 1 in a multi-group cell.
    assert stream(motion, smooth_move(before, goal, 0.4, 5), group=1).points == 5
    after = (
        state.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and abs(f.groups[1].positions[2] - goal[2]) < 1e-4
            ),
            5.0,
        )
        .groups[1]
        .positions
    )
    assert all(abs(after[j] - before[j]) < 1e-4 for j in (0, 1, 3, 4, 5, 6))
    moved_axes = {
        axis
        for tick in ticks.since(mark)
        for axis, inc in enumerate(tick.groups[1].increment)
        if inc
    }
    assert moved_axes == {6}


class PointCounter:
    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self.count = 0
        self.lock = threading.Lock()
        self.subscriber = session.declare_subscriber(f"{keys.prefix}/group/*/point", self._count)

    def _count(self, _sample: zenoh.Sample) -> None:
        with self.lock:
            self.count += 1


def ex_point(
    sequence: int,
    time: float,
    where: dict[int, tuple[float, ...]],
    speed: dict[int, float] | None = None,
) -> object:
    speed = speed or {}
    return traj_point_ex(
        sequence,
        [ex_group(g, time, where[g], tuple(speed.get(g, 0.0) for _ in where[g])) for g in GROUPS],
    )


def test_a_2016_point_is_refused_whole_when_one_group_is_busy_or_invalid(
    cell: RunningCell,
    bus: zenoh.Session,
    motion: MotionClient,
    state: StateListener,
    maps: list[AxisMap],
) -> None:
    counter = PointCounter(bus, cell.keys)
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    here = positions(state.wait_still(), maps)
    assert motion.motion(ex_point(0, 0.0, here)).result == Result.SUCCESS  # type: ignore[arg-type]
    # R1 alone gets a 2 s segment: 500 entries, more than its 200-entry ring, so its
    # pending slot stays full for over a second.
    far = tuple(p + 0.2 for p in here[0])
    assert stream_messages(motion, [traj_point(0, 1, 2.0, far, (0.0,) * 6)]).points == 1
    wait_until(lambda: counter.count == 4, 5.0, "four points published")

    busy = motion.motion(ex_point(2, 3.0, {**here, 0: far}))  # type: ignore[arg-type]
    assert (busy.result, busy.subcode, busy.command) == (
        Result.BUSY,
        0,
        MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX,
    )
    too_fast = motion.motion(ex_point(2, 3.0, {**here, 0: far}, speed={2: 50.0}))  # type: ignore[arg-type]
    assert (too_fast.result, too_fast.subcode, too_fast.group_no) in {
        (Result.BUSY, 0, 0),
        (Result.INVALID, InvalidSubcode.DATA_SPEED, 2),
    }
    assert counter.count == 4, "no group took either point"
    assert motion.command(Command.STOP_MOTION).result == Result.SUCCESS
    # With every slot free, the speed error is the answer, still for no group at all.
    here = positions(state.wait_still(), maps)
    assert motion.motion(ex_point(0, 0.0, here)).result == Result.SUCCESS  # type: ignore[arg-type]
    wait_until(lambda: counter.count == 7, 5.0, "three more points published")
    refused = stream_messages(motion, [ex_point(1, 1.0, here, speed={2: 50.0})]).last_reply  # type: ignore[list-item]
    assert refused is not None
    assert (refused.result, refused.subcode, refused.group_no) == (
        Result.INVALID,
        InvalidSubcode.DATA_SPEED,
        2,
    )
    assert counter.count == 7
    motion.command(Command.STOP_MOTION)
    counter.subscriber.undeclare()


def test_feedback_ex_is_548_bytes_with_three_groups_every_cycle(cell: RunningCell) -> None:
    with socket.create_connection((cell.host, cell.port_base + 1)) as raw:
        data = b""
        while data.count(struct.pack("<ii", 40, MsgType.ROBOT_STATUS)) < 5:
            data += raw.recv(65536)
    frames = []
    offset = data.index(struct.pack("<ii", 144, MsgType.JOINT_FEEDBACK))
    while offset + 4 <= len(data):
        (length,) = struct.unpack_from("<i", data, offset)
        if offset + 4 + length > len(data):
            break
        frames.append(data[offset : offset + 4 + length])
        offset += 4 + length
    types = [struct.unpack_from("<i", f, 4)[0] for f in frames]
    cycle = [MsgType.JOINT_FEEDBACK] * 3 + [MsgType.MOTO_JOINT_FEEDBACK_EX, MsgType.ROBOT_STATUS]
    assert types[:10] == cycle * 2
    ex_frames = [f for f in frames if struct.unpack_from("<i", f, 4)[0] == 2017]
    assert {len(f) for f in ex_frames} == {548}
    decoded = decode_frames(ex_frames[0], Role.CLIENT)[0].body
    assert isinstance(decoded, JointFeedbackEx)
    assert decoded.number_of_valid_groups == 3 and len(decoded.groups) == 4
    assert [g.group_no for g in decoded.groups[:3]] == [0, 1, 2]
    assert decoded.groups[3].valid_fields == 0


def test_a_group_interpolator_restarted_mid_session(
    cell: RunningCell, motion: MotionClient, state: StateListener, maps: list[AxisMap]
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    (victim,) = cell.service_pids("interpolator", group=1)
    os.kill(victim, signal.SIGKILL)
    wait_until(
        lambda: (
            motion.command(Command.CHECK_MOTION_READY).subcode == NotReadySubcode.INC_MOVE_ERROR
        ),
        5.0,
        "NOT_READY 5012 while R2's interpolator is gone",
    )
    here = positions(state.wait_still(), maps)
    refused = motion.motion(ex_point(0, 0.0, here))  # type: ignore[arg-type]
    assert (refused.result, refused.subcode) == (
        Result.NOT_READY,
        NotReadySubcode.INC_MOVE_ERROR,
    )
    wait_until(
        lambda: motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE,
        15.0,
        "R2's interpolator back",
    )
    goals = {g: tuple(p - 0.05 for p in here[g]) for g in GROUPS}
    plans: dict[int, list[PlannedPoint]] = {
        g: smooth_move(here[g], goals[g], 0.4, 5) for g in GROUPS
    }
    assert stream_ex(motion, plans).points == 5
