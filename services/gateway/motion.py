"""The motion port's request handling (motoros1-behaviour.md §2): every request gets exactly one
reply, in order, or a documented close without one."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

from services.gateway.cell_view import CellView
from services.gateway.io import IoHandler
from services.gateway.points import (
    OK,
    PointData,
    Verdict,
    check_fields,
    check_positions,
    check_speeds,
    check_start,
    check_time_limit,
    invalid,
)
from shared.bus.schemas import CommandRequest, Point
from shared.motion.kinematics import AxisMap
from shared.protocol.constants import (
    DH_LINKS,
    MAX_GROUPS,
    TOOL_NUMBERS,
    Command,
    CommType,
    InvalidSubcode,
    MsgType,
    NotReadySubcode,
    Result,
)
from shared.protocol.messages import (
    DhLink,
    GetDhParametersReply,
    JointTrajPtFull,
    JointTrajPtFullEx,
    Message,
    MotoMotionCtrl,
    ReadIOBit,
    ReadIOGroup,
    ReadMRegister,
    SelectTool,
    UnknownMessage,
    WriteIOBit,
    WriteIOGroup,
    WriteMRegister,
)
from shared.protocol.replies import invalid_reply, motion_reply, service_reply

log = logging.getLogger("gateway")

STOP_WAIT_S = 0.05
"""How long STOP_MOTION waits for every pending point to be dropped. MotoROS polls 20 x 1 ms
(§3.3); one Zenoh hop here can take longer than that on a loaded 2-core machine."""
START_TRAJ_MODE_TIMEOUT_S = 6.0
SLOTS_WAIT_S = 1.0
"""Interpolators report their slot at start and every 0.5 s; one just (re)started may not
have been heard from yet when the controller is ready."""
"""The controller itself gives up after 5 s (§7.3); this only bounds a lost reply."""


class _Close:
    """Handler result: close the connection without replying (MotoROS 1.9.4+, §2.7)."""


CLOSE = _Close()


@dataclass(frozen=True)
class Answer:
    reply: Message | None
    close: bool = False
    then: Callable[[], None] | None = None
    """Run once the reply is written."""


@dataclass
class GroupTrajectory:
    """What the gateway remembers of the trajectory a group is executing."""

    active: bool = False
    not_ready_count: int = 0
    start_id: int = 0
    """The point id of the sequence-0 point that began it."""
    segments: int = 0
    """Segments published since sequence 0."""
    last_sequence: int = -1
    last_time: float = 0.0


class MotionHandler:
    def __init__(self, view: CellView, io: IoHandler) -> None:
        self.view = view
        self.io = io
        self.maps = [AxisMap(group) for group in view.cell.groups]
        self.trajectories = [GroupTrajectory() for _ in view.cell.groups]
        self._outbox: list[tuple[int, Point]] = []
        self._period_s = view.cell.period_s
        # Unique across gateway restarts, so an executor never confuses two trajectories.
        self._sync_ids = time.time_ns() // 1000

    @property
    def groups(self) -> int:
        return len(self.maps)

    def handle(self, request: Message | UnknownMessage) -> Answer:
        """What to send for one request. A request that is itself a reply (comm type 3) is
        processed but never answered (MotoROS 1.9.4, "don't reply to replies")."""
        reply = self._dispatch(request)
        then = self._send_points if self._outbox else None
        if isinstance(reply, _Close):
            return Answer(None, close=True, then=then)
        if request.comm_type == CommType.SERVICE_REPLY:
            return Answer(None, then=then)
        return Answer(reply, then=then)

    def _send_points(self) -> None:
        for group, point in self._outbox:
            self.view.send_point(group, point)
        self._outbox.clear()

    def _dispatch(self, request: Message | UnknownMessage) -> Message | _Close:
        if isinstance(request, UnknownMessage):
            return invalid_reply(request)
        body = request.body
        match body:
            case JointTrajPtFull():
                return motion_reply(request, *self.point(body))
            case JointTrajPtFullEx():
                return self.point_ex(request, body)
            case MotoMotionCtrl():
                return self.command(request, body)
            case SelectTool():
                return motion_reply(request, *self.select_tool(body))
            case ReadIOBit() | WriteIOBit() | ReadIOGroup() | WriteIOGroup():
                # Served here too for backward compatibility, by the I/O port's handler (§2.2).
                return self.io.handle(request)
            case ReadMRegister() | WriteMRegister():
                # M-registers are an I/O-port service only: the motion port does not know the
                # types, so INVALID 3003 with group and sequence -1 (§2.2, §2.7).
                return motion_reply(request, Result.INVALID, InvalidSubcode.MSGTYPE)
        if request.msg_type == MsgType.PING:
            return service_reply(MsgType.PING, body)
        if request.msg_type == MsgType.MOTO_GET_DH_PARAMETERS:
            return service_reply(MsgType.MOTO_GET_DH_PARAMETERS, self.dh_parameters())
        # 13, 15, 2002, 2017 and the I/O port's M-register types: known sizes, no handler here.
        # MotoROS 1.9.4+ closes the connection without a reply (§2.7).
        log.warning("motion port: type %d has no handler here; closing", request.msg_type)
        return CLOSE

    # -- trajectory points ------------------------------------------------------------------
    def _track(self, group: int) -> GroupTrajectory:
        track = self.trajectories[group]
        if track.active and (
            track.not_ready_count != self.view.not_ready_count
            or self.view.trajectory_lost(group, track.start_id)
        ):
            # Motion-ready dropped since the trajectory began, or the interpolator dropped it
            # (its ring was cleared): the client has to start again with sequence 0 (§3.3).
            track.active = False
        return track

    def point(self, body: JointTrajPtFull) -> Verdict:
        """§2.4, in MotoROS's order."""
        ready, subcode = self.view.readiness()
        if not ready:
            return int(Result.NOT_READY), subcode
        data = PointData(
            body.group_no, body.valid_fields, body.time, body.positions, body.velocities
        )
        if not 0 <= data.group_no < self.groups:
            return invalid(InvalidSubcode.GROUPNO)
        if not self.view.slot_known(data.group_no):
            return int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR)
        verdict = check_fields(data) or check_time_limit(data)
        if verdict is not None:
            return verdict
        if body.sequence > 0 and self._duplicate(data, body.sequence):
            # motoman_driver resends a point after a failed receive (client doc, step 4).
            return OK
        # No BUSY check for sequence 0 on type 14 (§2.4 step 5): it waits in line instead.
        if body.sequence > 0 and not self._slot_free(data.group_no):
            return int(Result.BUSY), 0
        verdict = self._check_point(data, body.sequence)
        if verdict == OK:
            self._publish(data, body.sequence)
        return verdict

    def _slot_free(self, group: int) -> bool:
        """The pending slot is free, or as good as free: the one outstanding point's segment
        fits the ring, so only the interpolator's acknowledgement is missing (see CellView)."""
        return self.view.slot_free(group) or self.view.pending_fits(group)

    def _check_point(self, data: PointData, sequence: int) -> Verdict:
        """The data checks after the slot check (§2.4 steps 5-7, §2.5 processing pass)."""
        group = data.group_no
        axis_map = self.maps[group]
        if sequence < 0:
            return invalid(InvalidSubcode.SEQUENCE)
        verdict = check_positions(data, axis_map)
        if verdict is not None:
            return verdict
        if sequence == 0:
            command = self.view.command_pulses(group)
            if command is None:
                return int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR)
            return check_start(data, axis_map, command) or OK
        track = self._track(group)
        if not track.active:
            # MotoROS would interpolate from a stale state after a stop; a trajectory must
            # (re)start with sequence 0 (spec §2.5: "a new trajectory will need to be
            # generated ... using the current position as a start position").
            return invalid(InvalidSubcode.SEQUENCE)
        verdict = check_speeds(data, axis_map)
        if verdict is None and data.time <= track.last_time:
            # MotoROS silently drops a point whose time does not increase (§4.2); refusing it
            # tells the client its trajectory is wrong instead of skipping a waypoint.
            verdict = invalid(InvalidSubcode.DATA_TIME)
        return verdict or OK

    def _duplicate(self, data: PointData, sequence: int) -> bool:
        track = self.trajectories[data.group_no]
        return (
            track.active
            and sequence > 0
            and sequence == track.last_sequence
            and data.time == track.last_time
        )

    def _publish(
        self, data: PointData, sequence: int, sync: tuple[int, list[int]] = (0, [])
    ) -> None:
        group = data.group_no
        axes = self.maps[group].axes
        track = self.trajectories[group]
        point = Point(
            0,
            sequence,
            data.time,
            list(data.positions[:axes]),
            list(data.velocities[:axes]),
            sync_id=sync[0],
            sync_groups=sync[1],
        )
        # Ring entries of this point's segment: grid instants inside it plus the waypoint.
        entries = 0 if sequence == 0 else int((data.time - track.last_time) / self._period_s) + 2
        numbered = self.view.number_point(group, point, entries)
        # Sent after the reply is written (``Answer.then``): a real controller answers in
        # 0.34 ms, and the publish would add its own cost to every point's reply.
        self._outbox.append((group, numbered))
        if sequence == 0:
            track.active = True
            track.start_id = numbered.point_id
            track.segments = 0
            track.not_ready_count = self.view.not_ready_count
        else:
            track.segments += 1
        track.last_sequence = sequence
        track.last_time = data.time

    def point_ex(self, request: Message, body: JointTrajPtFullEx) -> Message:
        """§2.5: all or nothing across the listed groups, one reply per message (for the last
        listed group). MotoROS's pre-check pass (group, BUSY, fields) comes first; then every
        data check runs for every group before any group takes the point, so groups can never
        be de-synchronised by a late failure, as they can in MotoROS."""
        last_group = body.groups[-1].group_no
        ready, subcode = self.view.readiness()
        if not ready:
            return motion_reply(request, Result.NOT_READY, subcode, last_group)
        blocks = [
            PointData(g.group_no, g.valid_fields, g.time, g.positions, g.velocities)
            for g in body.groups
        ]
        if all(self._duplicate(data, body.sequence) for data in blocks):
            return motion_reply(request, Result.SUCCESS, 0, last_group)
        seen: set[int] = set()
        for data in blocks:
            group = data.group_no
            if not 0 <= group < self.groups or group in seen:
                return motion_reply(request, Result.INVALID, InvalidSubcode.GROUPNO, group)
            seen.add(group)
            if not self.view.slot_known(group):
                return motion_reply(
                    request, Result.NOT_READY, NotReadySubcode.INC_MOVE_ERROR, group
                )
            if not self._slot_free(group):
                return motion_reply(request, Result.BUSY, 0, group)
            verdict = check_fields(data)
            if verdict is not None:
                return motion_reply(request, *verdict, group)
        for data in blocks:
            # The 4 h limit is MotoROS's for type 14 only; its float-precision reason holds
            # for 2016 as much, so we apply it to both.
            verdict = check_time_limit(data) or self._check_point(data, body.sequence)
            if verdict != OK:
                return motion_reply(request, *verdict, data.group_no)
        sync: tuple[int, list[int]] = (0, [])
        if (
            body.sequence > 0
            and len(blocks) > 1
            and all(self.trajectories[data.group_no].segments == 0 for data in blocks)
        ):
            # The first segment of a 2016 trajectory: its groups start in the same tick
            # (executor barrier), so groups given the same times arrive in the same tick.
            self._sync_ids += 1
            sync = (self._sync_ids, [data.group_no for data in blocks])
        for data in blocks:
            self._publish(data, body.sequence, sync)
        return motion_reply(request, Result.SUCCESS, 0, last_group)

    # -- MOTO_MOTION_CTRL --------------------------------------------------------------------
    def command(self, request: Message, body: MotoMotionCtrl) -> Message | _Close:
        """§2.3. Every command answers; unknown ones get INVALID/3006 (MotoROS re-sends a stale
        reply buffer there [quirk])."""
        try:
            command = Command(body.command)
        except ValueError:
            return motion_reply(request, Result.INVALID, InvalidSubcode.COMMAND)
        match command:
            case Command.CHECK_MOTION_READY:
                ready, subcode = self.view.readiness()
                if ready:
                    return motion_reply(request, Result.TRUE, 0)
                return motion_reply(request, Result.FALSE, subcode)
            case Command.CHECK_QUEUE_CNT:
                reply = self.view.executor("queue_count", CommandRequest(group=body.group_no))
                if reply is None or reply.result != Result.SUCCESS:
                    return motion_reply(request, Result.FAILURE, -1)
                return motion_reply(request, Result.SUCCESS, reply.subcode)
            case Command.STOP_MOTION:
                return motion_reply(
                    request, Result.SUCCESS if self.stop_motion() else Result.FAILURE, 0
                )
            case Command.START_SERVOS | Command.RESET_ALARM:
                verb = "start_servos" if command is Command.START_SERVOS else "reset_alarm"
                return motion_reply(
                    request, *self._controller(verb, timeout=START_TRAJ_MODE_TIMEOUT_S)
                )
            case Command.STOP_SERVOS:
                self.stop_motion()
                return motion_reply(request, *self._controller("stop_servos"))
            case Command.START_TRAJ_MODE:
                result, subcode = self._controller(
                    "start_traj_mode", timeout=START_TRAJ_MODE_TIMEOUT_S
                )
                if result == Result.SUCCESS and not self.view.wait_slots_known(SLOTS_WAIT_S):
                    result = int(Result.FAILURE)
                if result == Result.FAILURE:
                    result, subcode = int(Result.NOT_READY), self.view.readiness()[1]
                return motion_reply(request, result, subcode)
            case Command.STOP_TRAJ_MODE:
                return motion_reply(
                    request, Result.SUCCESS if self.stop_traj_mode() else Result.FAILURE, 0
                )
            case Command.DISCONNECT:
                if self.stop_traj_mode():
                    return CLOSE  # 1.9.4+: closed without sending the reply (§2.3)
                return motion_reply(request, Result.FAILURE, 0)

    def _controller(self, verb: str, timeout: float = 2.0) -> Verdict:
        reply = self.view.controller(verb, timeout=timeout)
        if reply is None:
            return int(Result.FAILURE), 0
        return reply.result, reply.subcode

    def stop_motion(self) -> bool:
        """§3.3: clear every queue and pending point (all groups, whatever groupNo says); the
        trajectory is over, trajectory mode stays on."""
        for track in self.trajectories:
            track.active = False
        reply = self.view.executor("stop")
        cleared = reply is not None and reply.result == Result.SUCCESS
        return self.view.wait_slots_free(STOP_WAIT_S) and cleared

    def stop_traj_mode(self) -> bool:
        """§2.3: refuse while anything is queued; else STOP_MOTION and release the job."""
        for group in range(self.groups):
            reply = self.view.executor("queue_count", CommandRequest(group=group))
            if reply is None or reply.result != Result.SUCCESS or reply.subcode != 0:
                return False
        if not all(self.view.slot_free(g) for g in range(self.groups)):
            return False
        if not self.stop_motion():
            return False
        return self._controller("stop_traj_mode")[0] == Result.SUCCESS

    def select_tool(self, body: SelectTool) -> Verdict:
        if not 0 <= body.group_no < self.groups:
            return invalid(InvalidSubcode.GROUPNO)
        if body.tool not in TOOL_NUMBERS:
            return invalid(InvalidSubcode.DATA_TOOLNO)
        return self._controller_with(
            "select_tool", CommandRequest(group=body.group_no, value=body.tool)
        )

    def _controller_with(self, verb: str, request: CommandRequest) -> Verdict:
        reply = self.view.controller(verb, request)
        return (int(Result.FAILURE), 0) if reply is None else (reply.result, reply.subcode)

    def dh_parameters(self) -> GetDhParametersReply:
        """4 groups x 8 links; groups and links the cell does not have are zero (§1.2)."""
        zero = DhLink(0.0, 0.0, 0.0, 0.0)
        groups = []
        for index in range(MAX_GROUPS):
            links = [zero] * DH_LINKS
            if index < self.groups:
                for link, values in enumerate(self.view.cell.groups[index].model.dh):
                    links[link] = DhLink(*values)
            groups.append(tuple(links))
        return GetDhParametersReply(tuple(groups))
