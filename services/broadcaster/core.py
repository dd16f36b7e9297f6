"""The broadcaster's decisions, no I/O: when a state snapshot is due, what it holds, and
which state clients the port keeps.

Snapshots follow the executor's ticks (default 10 ms, 100 Hz: the first tick at or after each
due time), so feedback leaves as soon as its tick arrives and the rate is exact on average even
when the state period is not a whole number of ticks. MotoROS 1.9 sends "work time + 25 ms"
per client, a little under 40 Hz (motoros1 §6); a steady configurable rate is what users ask
for (motoman#516).

Without ticks the state port still beats, from the last tick (``Pacing``): every state period
while the executor's clock rests (nothing moves, so the last tick is the robot as it is) and a
client is connected, every ``AT_REST_HEARTBEAT_S`` for observers only; every ``silence_s`` when
ticks stop unannounced (an executor stalled or gone), so clients see motion_possible drop
instead of silence.
"""

from __future__ import annotations

from enum import Enum
from typing import Protocol

import msgspec
import numpy as np

from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.bus.schemas import (
    CartesianPose,
    CommandReply,
    ControllerStatus,
    GroupState,
    RobotStatusFields,
    State,
    Tick,
)
from motocell.shared.config import Cell
from motocell.shared.motion.forward_kinematics import Chain, pose, tool_transform
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import TOOL_NUMBERS, Result

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

    def groups(self, tick: Tick, commanded: bool = True) -> list[GroupState]:
        """``commanded``: also the commanded joints, which only observers get; the state
        port's frames carry the feedback alone, and leaving the rest out halves the
        conversion every state period (``command_positions`` then stays empty)."""
        result = []
        for index, (axis_map, group) in enumerate(zip(self.maps, tick.groups, strict=True)):
            # What an axis moved this period, pulses per period to rad/s: the servo's feedback
            # (MotoROS sends the servo's speed feedback, motoros1 §6), and the command. A tick
            # of an executor older than the servo model carries no feedback_moved: then the
            # feedback was the command.
            moved = group.feedback_moved or group.increment
            positions = axis_map.ros_values(group.feedback_pulses)
            velocities = axis_map.ros_values(moved, self.per_second)
            if not commanded:
                result.append(GroupState(index, positions, velocities, command_positions=[]))
                continue
            result.append(
                GroupState(
                    group_no=index,
                    positions=positions,
                    velocities=velocities,
                    command_positions=axis_map.ros_values(group.command_pulses),
                    command_velocities=axis_map.ros_values(group.increment, self.per_second),
                )
            )
        return result


class Poses:
    """The flange and TCP poses of every arm group, at the feedback and the commanded position
    (docs/poses.md). Positioners and tracks carry no tool, so get none."""

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


class Pacing(Enum):
    """What sets the state port's beat now."""

    WAITING = "no tick yet: nothing to send"
    TICKS = "the executor's ticks"
    AT_REST = "the executor's clock rests: the broadcaster's own clock, from the last tick"
    SILENT = "ticks stopped unannounced: a beat every silence_s, from the last tick"


class Broadcaster:
    """Ticks in, numbered State snapshots out, at the cell's state period. Times are the
    broadcaster's own CLOCK_MONOTONIC seconds, passed in."""

    def __init__(self, cell: Cell, controller: ControllerView) -> None:
        self.feedback = Feedback(cell)
        self.schedule = Schedule(cell.state_period_ns)
        self.state_period_s = cell.state_period_ns / 1e9
        self.controller = controller
        self.silence_s = max(MIN_SILENCE_S, 3 * cell.state_period_ns / 1e9)
        """Ticks unheard this long while the executor's clock runs: it stalled or went."""
        self.last: Tick | None = None
        self.seq = 0
        self.poses = Poses(cell)
        self.tools: list[int] = []
        """The tool per group in the newest controller status a snapshot read, kept when the
        controller has none to give, so the TCP never jumps back to the flange for a snapshot
        (tool 0 until a status says otherwise)."""
        self._next_beat: float | None = None
        """When to send without a tick (``Pacing``); None: only on a tick."""
        self._last_tick_at = 0.0
        self._groups_of: tuple[Tick | None, list[GroupState]] = (None, [])

    @property
    def pacing(self) -> Pacing:
        if self.last is None:
            return Pacing.WAITING
        if self.last.resting:
            return Pacing.AT_REST
        return Pacing.TICKS if self._next_beat is None else Pacing.SILENT

    def on_tick(self, tick: Tick, now: float) -> State | None:
        """The snapshot to send now, if this tick is the first at or after the due time. The
        tick the executor rests after is always sent: it is the robot from now on."""
        self.last = tick
        self._last_tick_at = now
        if tick.resting:
            self._next_beat = now + self.state_period_s
            return self._snapshot(tick)
        self._next_beat = None
        if not self.schedule.due(tick.deadline_ns):
            return None
        return self._snapshot(tick)

    def on_wake(self, now: float, clients: bool) -> State | None:
        """Woken without a tick: the snapshot due now from the last tick, with the controller
        as it is now, if a beat is due (``Pacing``). ``clients``: a state client is
        connected."""
        if self.last is None:
            return None
        if self._next_beat is None:
            if now - self._last_tick_at < self.silence_s:
                return None
            self._next_beat = now  # ticks stopped unannounced
        elif self.last.resting and clients and self._next_beat > now + self.state_period_s:
            self._next_beat = now  # a client came while only observers were paced
        if now < self._next_beat:
            return None
        beat = self._beat_s(clients)
        self._next_beat += beat
        if self._next_beat <= now:
            self._next_beat = now + beat  # fell behind: no burst to catch up
        return self._snapshot(self.last)

    def next_wake(self, now: float, clients: bool) -> float | None:
        """When the caller must wake if no tick comes first (None: only for a tick)."""
        if self.last is None:
            return None
        if self._next_beat is None:
            return self._last_tick_at + self.silence_s
        if self.last.resting and clients:
            return min(self._next_beat, now + self.state_period_s)
        return self._next_beat

    def _beat_s(self, clients: bool) -> float:
        """How often to beat without ticks, in the pacing of the last tick."""
        if self.last is None or not self.last.resting:
            return self.silence_s
        return self.state_period_s if clients else AT_REST_HEARTBEAT_S

    def positions(self) -> CommandReply:
        """Where the newest tick left the robot (the commanded pulses of every group): where a
        restarted executor resumes. FAILURE before any tick."""
        last = self.last
        if last is None:
            return CommandReply(Result.FAILURE, detail="no tick heard yet")
        return CommandReply(Result.SUCCESS, pulses=[group.command_pulses for group in last.groups])

    def motion_queued(self) -> bool:
        """Whether the newest tick had motion data queued (no tick yet: nothing is)."""
        return self.last is not None and queued(self.last)

    def for_observers(self, state: State) -> State:
        """``state``, the newest snapshot, with its commanded joints and its arms' poses, for
        observers: computed after the TCP clients have their frames, which carry the feedback
        joints only."""
        tick = self._groups_of[0]
        if tick is None:
            return state
        groups = self.feedback.groups(tick)
        return self.poses.add(msgspec.structs.replace(state, groups=groups), self.tools)

    def _snapshot(self, tick: Tick) -> State:
        self.seq += 1
        status = self.controller.status()
        if status is not None:
            self.tools = status.tools
        if tick is not self._groups_of[0]:
            # A beat without ticks repeats the last tick: its feedback is converted once.
            self._groups_of = (tick, self.feedback.groups(tick, commanded=False))
        return State(
            seq=self.seq,
            tick=tick.tick,
            tick_ns=tick.deadline_ns + tick.lateness_ns,
            groups=self._groups_of[1],
            status=robot_status(status, tick, self.controller.alive()),
        )
