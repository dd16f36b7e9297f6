"""The motion port's request handling (motoros1-behaviour.md §2): every request gets exactly one
reply, in order, or a documented close without one."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from services.gateway.cell_view import CellView
from services.gateway.io import IoHandler
from services.gateway.points import (
    OK,
    PointData,
    Verdict,
    check_fields,
    check_start,
    check_time_limit,
    check_values,
    invalid,
)
from shared.bus.schemas import CommandRequest, Point
from shared.motion.kinematics import AxisMap
from shared.protocol.constants import (
    DH_LINKS,
    MAX_GROUPS,
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
"""The controller itself gives up after 5 s (§7.3); this only bounds a lost reply."""


class _Close:
    """Handler result: close the connection without replying (MotoROS 1.9.4+, §2.7)."""


CLOSE = _Close()


@dataclass(frozen=True)
class Answer:
    reply: Message | None
    close: bool = False


@dataclass
class GroupTrajectory:
    """What the gateway remembers of the trajectory a group is executing."""

    active: bool = False
    not_ready_count: int = 0
    last_sequence: int = -1
    last_time: float = 0.0


class MotionHandler:
    def __init__(self, view: CellView, io: IoHandler) -> None:
        self.view = view
        self.io = io
        self.maps = [AxisMap(group) for group in view.cell.groups]
        self.trajectories = [GroupTrajectory() for _ in view.cell.groups]
        # Unique across gateway restarts, so an executor never confuses two trajectories.
        self._sync_ids = time.time_ns() // 1000

    @property
    def groups(self) -> int:
        return len(self.maps)

    def handle(self, request: Message | UnknownMessage) -> Answer:
        """What to send for one request. A request that is itself a reply (comm type 3) is
        processed but never answered (MotoROS 1.9.4, "don't reply to replies")."""
        reply = self._dispatch(request)
        if isinstance(reply, _Close):
            return Answer(None, close=True)
        if request.comm_type == CommType.SERVICE_REPLY:
            return Answer(None)
        return Answer(reply)

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
        if track.active and track.not_ready_count != self.view.not_ready_count:
            # Motion-ready dropped since the trajectory began: the queues were cleared, so the
            # client has to start again with a sequence-0 point (§2.5 spec, §3.3).
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
        verdict = check_fields(data) or check_time_limit(data)
        if verdict is None:
            verdict = self._check_sequenced(data, body.sequence, busy_check_on_start=False)
        if verdict == OK and not self._duplicate(data, body.sequence):
            self._publish(data, body.sequence)
        return verdict

    def _check_sequenced(
        self, data: PointData, sequence: int, busy_check_on_start: bool
    ) -> Verdict:
        group = data.group_no
        axis_map = self.maps[group]
        track = self._track(group)
        if sequence < 0:
            return invalid(InvalidSubcode.SEQUENCE)
        if sequence == 0:
            if busy_check_on_start and not self.view.slot_free(group):
                return int(Result.BUSY), 0
            command = self.view.command_pulses(group)
            if command is None:
                return int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR)
            return check_values(data, axis_map) or check_start(data, axis_map, command) or OK
        if not track.active:
            # MotoROS would interpolate from a stale state after a stop; a trajectory must
            # (re)start with sequence 0 (spec §2.5: "a new trajectory will need to be
            # generated ... using the current position as a start position").
            return invalid(InvalidSubcode.SEQUENCE)
        if self._duplicate(data, sequence):
            # motoman_driver resends a point after a failed receive (client doc, step 4).
            return OK
        if not self.view.slot_free(group):
            return int(Result.BUSY), 0
        verdict = check_values(data, axis_map)
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
        if sequence == 0:
            track.active = True
            track.not_ready_count = self.view.not_ready_count
        track.last_sequence = sequence
        track.last_time = data.time
        point = Point(
            0,
            sequence,
            data.time,
            list(data.positions[:axes]),
            list(data.velocities[:axes]),
            sync_id=sync[0],
            sync_groups=sync[1],
        )
        self.view.publish_point(group, point)

    def point_ex(self, request: Message, body: JointTrajPtFullEx) -> Message:
        """§2.5: all or nothing across the listed groups, one reply per message. Unlike MotoROS
        every check (start position and speed included) runs before any group takes the point,
        so groups can never be de-synchronised by a late failure."""
        last_group = body.groups[-1].group_no
        ready, subcode = self.view.readiness()
        if not ready:
            return motion_reply(request, Result.NOT_READY, subcode, last_group)
        blocks = [
            PointData(g.group_no, g.valid_fields, g.time, g.positions, g.velocities)
            for g in body.groups
        ]
        seen: set[int] = set()
        for data in blocks:
            if not 0 <= data.group_no < self.groups or data.group_no in seen:
                return motion_reply(request, Result.INVALID, InvalidSubcode.GROUPNO, data.group_no)
            seen.add(data.group_no)
            verdict = (
                check_fields(data)
                or check_time_limit(data)
                or self._check_sequenced(data, body.sequence, busy_check_on_start=True)
            )
            if verdict != OK:
                return motion_reply(request, *verdict, data.group_no)
        sync: tuple[int, list[int]] = (0, [])
        if body.sequence == 0 and len(blocks) > 1:
            # The groups of one 2016 trajectory start in the same tick (executor barrier).
            self._sync_ids += 1
            sync = (self._sync_ids, [data.group_no for data in blocks])
        for data in blocks:
            if not self._duplicate(data, body.sequence):
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
        if not 0 <= body.tool <= 63:
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
