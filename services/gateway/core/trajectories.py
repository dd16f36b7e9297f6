"""Trajectory points (JOINT_TRAJ_PT_FULL 14, MOTO_JOINT_TRAJ_PT_FULL_EX 2016): checked in
MotoROS's order (motoros1 §2.4-2.6) against what the gateway already holds, then
numbered for the group's interpolator and sent once the reply is written."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from motocell.services.gateway.core.cell_port import CellPort, readiness
from motocell.services.gateway.core.points import (
    OK,
    PointData,
    Verdict,
    check_fields,
    check_positions,
    check_speeds,
    check_start,
    check_time_limit,
    invalid,
    position_bounds,
)
from motocell.services.gateway.core.sources import Source
from motocell.services.gateway.core.states import TRANSITIONS, TrajectoryEvent, TrajectoryState
from motocell.shared.bus.schemas import Point
from motocell.shared.config import Cell
from motocell.shared.motion.interpolation import max_segment_entries, time_to_ns
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import InvalidSubcode, NotReadySubcode, Result
from motocell.shared.protocol.messages import JointTrajPtFull, JointTrajPtFullEx, Message
from motocell.shared.protocol.replies import motion_reply

Sync = tuple[int, tuple[int, ...]]
"""A 2016 sync id and the groups that start together; (0, ()) for none."""
NO_SYNC: Sync = (0, ())


@dataclass
class GroupTrajectory:
    """What the gateway remembers of the trajectory a group is executing."""

    state: TrajectoryState = TrajectoryState.NONE
    not_ready_count: int = 0
    start_id: int = 0
    """The point id of the sequence-0 point that began it."""
    segments: int = 0
    """Segments published since sequence 0."""
    last_sequence: int = -1
    last_time: float = 0.0

    def on(self, event: TrajectoryEvent) -> Verdict | None:
        """Take ``event`` (``states.TRANSITIONS``); the refusal its row answers the point with."""
        self.state, refusal = TRANSITIONS[(self.state, event)]
        return refusal


class Trajectories:
    """Every group's trajectory as the gateway follows it, and the points accepted into them,
    waiting to be sent."""

    def __init__(self, cell: Cell, port: CellPort, sync_ids: Iterator[int], source: Source) -> None:
        self.port = port
        self.source = source
        self.maps = [AxisMap(group) for group in cell.groups]
        self.position_bounds = [position_bounds(axis_map) for axis_map in self.maps]
        self.tracks = [GroupTrajectory() for _ in cell.groups]
        self.period_ns = cell.period_ns
        self.sync_ids = sync_ids
        """The 2016 sync ids, shared by both faces' handlers. They must differ across gateway
        restarts (counting from the start time in µs does), so an executor never confuses two
        trajectories."""
        self._outbox: list[tuple[int, Point]] = []

    @property
    def groups(self) -> int:
        return len(self.maps)

    @property
    def unsent(self) -> bool:
        return bool(self._outbox)

    def send_accepted(self) -> None:
        """Publish the points accepted since the last call. Run after the reply is written:
        the publish would add its own cost to every point's reply, which a real controller
        gives in about a third of a millisecond (docs/reply-path.md)."""
        for group, point in self._outbox:
            self.port.send_point(group, point)
        self._outbox.clear()

    def end_all(self) -> None:
        """STOP_MOTION: every group's trajectory is over."""
        for track in self.tracks:
            track.on(TrajectoryEvent.STOPPED)

    def _track(self, group: int) -> GroupTrajectory:
        """The group's trajectory, told first what ended it since it began, if anything did."""
        track = self.tracks[group]
        state = self.port.state
        if track.not_ready_count != state.not_ready_count:
            track.on(TrajectoryEvent.READINESS_DROPPED)
        elif state.groups[group].trajectory_lost(track.start_id):
            track.on(TrajectoryEvent.DROPPED_BY_INTERPOLATOR)
        return track

    def point(self, body: JointTrajPtFull) -> Verdict:
        """motoros1 §2.4, in MotoROS's order."""
        ready, subcode = readiness(self.port, self.source)
        if not ready:
            return int(Result.NOT_READY), subcode
        data = PointData(
            body.group_no, body.valid_fields, body.time, body.positions, body.velocities
        )
        if not 0 <= data.group_no < self.groups:
            return invalid(InvalidSubcode.GROUPNO)
        if not self.port.state.groups[data.group_no].known:
            return int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR)
        verdict = check_fields(data) or check_time_limit(data)
        if verdict is not None:
            return verdict
        if body.sequence > 0 and self._duplicate(data, body.sequence):
            # motoman_driver resends a point after a failed receive (docs/spec/driver-client.md).
            return OK
        # No BUSY check for sequence 0 on type 14 (motoros1 §2.4 step 5): it waits in line instead.
        if body.sequence > 0 and not self._slot_free(data.group_no):
            return int(Result.BUSY), 0
        verdict = self._check_point(data, body.sequence)
        if verdict == OK:
            self._accept(data, body.sequence)
        return verdict

    def point_ex(self, request: Message, body: JointTrajPtFullEx) -> Message:
        """motoros1 §2.5: all or nothing across the listed groups, one reply per message (for
        the last listed group). MotoROS's pre-check pass (group, BUSY, fields) comes first;
        then every data check runs for every group before any group takes the point, so groups
        can never be de-synchronised by a late failure, as they can in MotoROS."""
        if not body.groups:
            # The codec refuses a group count below 1 (3001); a body built without groups
            # gets the same answer, never a reply for a group it does not name.
            return motion_reply(request, Result.INVALID, InvalidSubcode.MSGSIZE)
        last_group = body.groups[-1].group_no
        ready, subcode = readiness(self.port, self.source)
        if not ready:
            return motion_reply(request, Result.NOT_READY, subcode, last_group)
        blocks = [
            PointData(g.group_no, g.valid_fields, g.time, g.positions, g.velocities)
            for g in body.groups
        ]
        if self._resent(blocks, body.sequence):
            return motion_reply(request, Result.SUCCESS, 0, last_group)
        refusal = self._pre_check(blocks)
        if refusal is None:
            refusal = self._data_check(blocks, body.sequence)
        if refusal is not None:
            verdict, group = refusal
            return motion_reply(request, *verdict, group)
        sync = NO_SYNC
        if (
            body.sequence > 0
            and len(blocks) > 1
            and all(self.tracks[data.group_no].segments == 0 for data in blocks)
        ):
            # The first segment of a 2016 trajectory: its groups start in the same tick
            # (executor barrier), so groups given the same times arrive in the same tick.
            sync = (next(self.sync_ids), tuple(data.group_no for data in blocks))
        for data in blocks:
            self._accept(data, body.sequence, sync)
        return motion_reply(request, Result.SUCCESS, 0, last_group)

    def _resent(self, blocks: list[PointData], sequence: int) -> bool:
        """Every listed group already took this very point. Asked before the pre-check, so a
        resend is recognised while a slot is busy; only of a message whose group numbers the
        pre-check would accept, as they index the tracks (a number out of range is the
        pre-check's INVALID 3004, never a lookup)."""
        return self._groups_listed_once(blocks) and all(
            self._duplicate(data, sequence) for data in blocks
        )

    def _groups_listed_once(self, blocks: list[PointData]) -> bool:
        """Each listed group is one the cell has, and none is listed twice."""
        numbers = [data.group_no for data in blocks]
        return len(set(numbers)) == len(numbers) and all(0 <= n < self.groups for n in numbers)

    def _pre_check(self, blocks: list[PointData]) -> tuple[Verdict, int] | None:
        """MotoROS's first pass over a 2016's groups: group number, slot, fields. A group's
        number is checked before anything is looked up by it."""
        seen: set[int] = set()
        for data in blocks:
            group = data.group_no
            if not 0 <= group < self.groups or group in seen:
                return invalid(InvalidSubcode.GROUPNO), group
            seen.add(group)
            if not self.port.state.groups[group].known:
                return (int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR)), group
            if not self._slot_free(group):
                return (int(Result.BUSY), 0), group
            verdict = check_fields(data)
            if verdict is not None:
                return verdict, group
        return None

    def _data_check(self, blocks: list[PointData], sequence: int) -> tuple[Verdict, int] | None:
        """Every data check for every group, before any group takes the point."""
        for data in blocks:
            # The 4 h limit is MotoROS's for type 14 only; its float-precision reason holds
            # for 2016 as much, so we apply it to both.
            verdict = check_time_limit(data) or self._check_point(data, sequence)
            if verdict != OK:
                return verdict, data.group_no
        return None

    def _slot_free(self, group: int) -> bool:
        """The group's pending-point FIFO takes another point (``GroupCredit.accepts_point``)."""
        return self.port.state.groups[group].accepts_point()

    def _check_point(self, data: PointData, sequence: int) -> Verdict:
        """The data checks after the slot check (motoros1 §2.4 steps 5-7, motoros1 §2.5
        processing pass)."""
        group = data.group_no
        axis_map = self.maps[group]
        if sequence < 0:
            return invalid(InvalidSubcode.SEQUENCE)
        verdict = check_positions(data, self.position_bounds[group])
        if verdict is not None:
            return verdict
        if sequence == 0:
            queue = self.port.state.groups[group].queue
            if queue is None:
                return int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR)
            return check_start(data, axis_map, queue.command_pulses) or OK
        track = self._track(group)
        refusal = track.on(TrajectoryEvent.LATER_POINT)
        if refusal is not None:
            return refusal
        verdict = check_speeds(data, axis_map)
        if verdict is None and data.time <= track.last_time:
            # MotoROS silently drops a point whose time does not increase (motoros1 §4.2);
            # refusing it tells the client its trajectory is wrong instead of skipping a
            # waypoint.
            verdict = invalid(InvalidSubcode.DATA_TIME)
        return verdict or OK

    def _duplicate(self, data: PointData, sequence: int) -> bool:
        track = self.tracks[data.group_no]
        return (
            track.state is TrajectoryState.RUNNING
            and sequence > 0
            and sequence == track.last_sequence
            and data.time == track.last_time
        )

    def _accept(self, data: PointData, sequence: int, sync: Sync = NO_SYNC) -> None:
        """Number the point for its group and queue it for ``send_accepted``."""
        group = data.group_no
        axes = self.maps[group].axes
        track = self.tracks[group]
        point = Point(
            0,
            sequence,
            data.time,
            list(data.positions[:axes]),
            list(data.velocities[:axes]),
            sync_id=sync[0],
            sync_groups=list(sync[1]),
        )
        entries = 0
        if sequence > 0:
            duration_ns = time_to_ns(data.time) - time_to_ns(track.last_time)
            entries = max_segment_entries(duration_ns, self.period_ns)
        numbered = self.port.state.groups[group].number(point, entries)
        self._outbox.append((group, numbered))
        if sequence == 0:
            track.on(TrajectoryEvent.STARTED)
            track.start_id = numbered.point_id
            track.segments = 0
            track.not_ready_count = self.port.state.not_ready_count
        else:
            track.segments += 1
        track.last_sequence = sequence
        track.last_time = data.time
