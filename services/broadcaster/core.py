"""The broadcaster's decisions, no I/O: when a state snapshot is due, what it holds, and
which state clients the port keeps.

Snapshots follow the executor's ticks (default 10 ms, 100 Hz: the first tick at or after each
due time), so feedback leaves as soon as its tick arrives and the rate is exact on average even
when the state period is not a whole number of ticks. MotoROS 1.9 sends "work time + 25 ms"
per client, a little under 40 Hz (motoros1 §6); a steady configurable rate is what users ask
for (motoman#516).
"""

from __future__ import annotations

from enum import Enum
from typing import Protocol

import msgspec
import numpy as np

from motocell.shared.bus.schemas import (
    CartesianPose,
    ControllerStatus,
    GroupState,
    RobotStatusFields,
    State,
    Tick,
)
from motocell.shared.config import Cell
from motocell.shared.motion.forward_kinematics import Chain, pose, tool_transform
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import TOOL_NUMBERS

IN_MOTION_PULSES = 30
"""in_motion also while |feedback - command| exceeds 30 pulses on any axis (motoros1 §6,
v1.8.1)."""

MIN_SILENCE_S = 0.05
MAX_STATE_CLIENTS = 4
"""MotoROS 1.9.4+ serves up to 4 state clients, each with its own sender (motoros1 §6)."""


class ControllerView(Protocol):
    """What the broadcaster knows of the controller; asked only when a snapshot is due."""

    def status(self) -> ControllerStatus | None:
        """The newest status published, if any."""
        ...

    def alive(self) -> bool:
        """Whether the controller's liveliness token is present."""
        ...


def in_motion(tick: Tick) -> bool:
    return any(
        group.depth > 0
        or any(
            abs(feedback - command) > IN_MOTION_PULSES
            for feedback, command in zip(group.feedback_pulses, group.command_pulses, strict=True)
        )
        for group in tick.groups
    )


def queued(tick: Tick) -> bool:
    """Motion data is queued for some group: MotoROS then refuses a 5th state client."""
    return any(group.depth > 0 for group in tick.groups)


class Admission(Enum):
    ACCEPT = "accept"
    REFUSE = "refuse"
    REPLACE_FIRST = "replace the first"


def admission(clients: int, motion_queued: bool) -> Admission:
    """What the state port does with a newcomer when ``clients`` are connected (motoros1 §6):
    up to 4; a 5th is refused while motion data is queued, otherwise slot 0 is closed and
    reused."""
    if clients < MAX_STATE_CLIENTS:
        return Admission.ACCEPT
    return Admission.REFUSE if motion_queued else Admission.REPLACE_FIRST


def robot_status(
    status: ControllerStatus | None, tick: Tick, controller_alive: bool
) -> RobotStatusFields:
    moving = int(in_motion(tick))
    if status is None or not controller_alive:
        # Without the controller nothing is known but that motion is impossible.
        return RobotStatusFields(-1, -1, -1, -1, moving, -1, 0)
    return RobotStatusFields(
        drives_powered=int(status.servo_on and not status.eco),
        e_stopped=int(status.estop),
        error_code=status.alarms[0].code if status.alarms else 0,
        in_error=int(bool(status.alarms)),
        in_motion=moving,
        # MotoROS sends 2 in PLAY, else 1 (the industrial_msgs convention; the FS100 capture
        # shows 2), not the 2012 spec's 0 = auto / 1 = manual.
        mode=2 if status.play else 1,
        motion_possible=int(status.motion_ready),
    )


class Feedback:
    """Turns a tick into per-group feedback in radians (or metres) and ROS joint order."""

    def __init__(self, cell: Cell) -> None:
        self.maps = [AxisMap(group) for group in cell.groups]
        self.per_second = 1e9 / cell.period_ns

    def groups(self, tick: Tick) -> list[GroupState]:
        result = []
        for index, (axis_map, group) in enumerate(zip(self.maps, tick.groups, strict=True)):
            # What an axis moved this period, pulses per period to rad/s: the servo's feedback
            # (MotoROS sends the servo's speed feedback, motoros1 §6), and the command. A tick
            # of an executor older than the servo model carries no feedback_moved: then the
            # feedback was the command.
            moved = group.feedback_moved or group.increment
            result.append(
                GroupState(
                    group_no=index,
                    positions=axis_map.pulses_to_ros(group.feedback_pulses).tolist(),
                    velocities=(axis_map.pulses_to_ros(moved) * self.per_second).tolist(),
                    command_positions=axis_map.pulses_to_ros(group.command_pulses).tolist(),
                    command_velocities=(
                        axis_map.pulses_to_ros(group.increment) * self.per_second
                    ).tolist(),
                )
            )
        return result


class Poses:
    """The flange and TCP poses of every arm group, at the feedback and the commanded position
    (ARCHITECTURE.md, Poses). Positioners and tracks carry no tool, so get none."""

    def __init__(self, cell: Cell) -> None:
        self.chains = {
            group.index: Chain(group.model) for group in cell.groups if group.model.kind == "robot"
        }
        self.tools = [tool_transform(cell.tool(number)) for number in TOOL_NUMBERS]

    def add(self, state: State, tools: list[int]) -> State:
        """``state`` with the poses of its arms; ``tools`` is the selected tool per group."""
        groups = [
            self._group(group, tools[group.group_no] if group.group_no < len(tools) else 0)
            for group in state.groups
        ]
        return msgspec.structs.replace(state, groups=groups)

    def _group(self, group: GroupState, tool: int) -> GroupState:
        chain = self.chains.get(group.group_no)
        if chain is None:
            return group
        # Both positions in one pass: 2 flanges, then 2 TCPs, then 4 poses at once.
        flanges = chain.flange(np.array([group.positions, group.command_positions]))
        frames = np.concatenate([flanges, flanges @ self.tools[tool]])
        positions, orientations = pose(frames)
        flange, command_flange, tcp, command_tcp = (
            CartesianPose(position, orientation)
            for position, orientation in zip(positions.tolist(), orientations.tolist(), strict=True)
        )
        return msgspec.structs.replace(
            group,
            tool=tool,
            flange=flange,
            tcp=tcp,
            command_flange=command_flange,
            command_tcp=command_tcp,
        )


class Schedule:
    """When to send state, on the executor's own clock: the first tick at or after each due
    time. Feedback then leaves the moment the tick that produced it arrives (no wait for a
    second clock), and the rate is exact on average even when the state period is not a
    whole number of ticks (10 ms at 4 ms: 8 and 12 ms alternately)."""

    def __init__(self, period_ns: int) -> None:
        self.period_ns = period_ns
        self.next_due: int | None = None

    def due(self, tick_ns: int) -> bool:
        if self.next_due is None:
            self.next_due = tick_ns
        if tick_ns < self.next_due:
            return False
        self.next_due += self.period_ns
        if self.next_due <= tick_ns:
            self.next_due = tick_ns + self.period_ns  # fell behind: no burst to catch up
        return True


class Broadcaster:
    """Ticks in, numbered State snapshots out, at the cell's state period."""

    def __init__(self, cell: Cell, controller: ControllerView) -> None:
        self.feedback = Feedback(cell)
        self.schedule = Schedule(cell.state_period_ns)
        self.controller = controller
        self.silence_s = max(MIN_SILENCE_S, 3 * cell.state_period_ns / 1e9)
        """Without ticks (no executor) the state port still beats this often, from the last
        tick, so clients see motion_possible drop instead of silence."""
        self.last: Tick | None = None
        self.seq = 0
        self.poses = Poses(cell)
        self.tools: list[int] = []
        """The tool per group in the newest controller status a snapshot read, kept when the
        controller has none to give, so the TCP never jumps back to the flange for a snapshot
        (tool 0 until a status says otherwise)."""

    def on_tick(self, tick: Tick) -> State | None:
        """The snapshot to send now, if this tick is the first at or after the due time."""
        self.last = tick
        if not self.schedule.due(tick.deadline_ns):
            return None
        return self._snapshot(tick)

    def motion_queued(self) -> bool:
        """Whether the newest tick had motion data queued (no tick yet: nothing is)."""
        return self.last is not None and queued(self.last)

    def on_silence(self) -> State | None:
        """No tick for ``silence_s``: the last tick again, with the controller as it is now."""
        if self.last is None:
            return None
        return self._snapshot(self.last)

    def with_poses(self, state: State) -> State:
        """``state`` with its arms' poses, for observers: computed after the TCP clients have
        their frames, which carry joints only."""
        return self.poses.add(state, self.tools)

    def _snapshot(self, tick: Tick) -> State:
        self.seq += 1
        status = self.controller.status()
        if status is not None:
            self.tools = status.tools
        return State(
            seq=self.seq,
            tick=tick.tick,
            tick_ns=tick.deadline_ns + tick.lateness_ns,
            groups=self.feedback.groups(tick),
            status=robot_status(status, tick, self.controller.alive()),
        )
