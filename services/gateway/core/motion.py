"""The motion port's request handling (motoros1 §2): every request gets exactly one
reply, in order, or a documented close without one. Points go to ``Trajectories``; the
MOTO_MOTION_CTRL commands (motoros1 §2.3) are answered here."""

from __future__ import annotations

import logging
from collections.abc import Iterator

from motocell.services.gateway.core.cell_port import CellPort, readiness
from motocell.services.gateway.core.points import Verdict, invalid
from motocell.services.gateway.core.response import Response
from motocell.services.gateway.core.robot_io import RobotIoHandler
from motocell.services.gateway.core.sources import Source
from motocell.services.gateway.core.trajectories import Trajectories
from motocell.shared.bus.schemas import CommandRequest
from motocell.shared.config import Cell
from motocell.shared.protocol.constants import (
    DH_LINKS,
    MAX_GROUPS,
    TOOL_NUMBERS,
    Command,
    CommType,
    InvalidSubcode,
    MsgType,
    Result,
)
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import (
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
from motocell.shared.protocol.replies import invalid_reply, motion_reply, service_reply

log = logging.getLogger("gateway")

STOP_WAIT_S = 0.05
"""How long STOP_MOTION waits for every pending point to be dropped. MotoROS polls 20 x 1 ms
(motoros1 §3.3); one Zenoh hop here can take longer than that on a loaded 2-core machine."""
START_TRAJ_MODE_TIMEOUT_S = 6.0
"""The controller itself gives up after 5 s (motoros1 §7.3); this only bounds a lost reply."""
SLOTS_WAIT_S = 1.0
"""An interpolator just (re)started may not have been heard from yet when the controller is
ready: its first slot, or its answer to the gateway's question (``CellState.slots_to_ask``),
is on its way."""


class _Close:
    """Handler result: close the connection without replying (MotoROS 1.9.4+, motoros1 §2.7)."""


CLOSE = _Close()

M_REGISTER_TYPES = frozenset({int(MsgType.MOTO_READ_MREGISTER), int(MsgType.MOTO_WRITE_MREGISTER)})
"""Types the codec knows (for the I/O port) that have no size on the motion port (motoros1 §1.2)."""


class MotionHandler:
    """One face's motion requests (``source``): the motion port's client, or the ROS 2 face's.
    Both handlers share the cell port, whose state says which face holds trajectory mode
    (``core.sources``): the other's points, CHECK_MOTION_READY and START_TRAJ_MODE are refused
    NOT_READY, and what would end the holder's motion (STOP_MOTION, STOP_TRAJ_MODE, DISCONNECT,
    a client gone) does nothing."""

    def __init__(
        self,
        cell: Cell,
        port: CellPort,
        io: RobotIoHandler,
        sync_ids: Iterator[int],
        source: Source,
    ) -> None:
        self.cell = cell
        self.port = port
        self.io = io
        self.source = source
        self.trajectories = Trajectories(cell, port, sync_ids, source)

    @property
    def groups(self) -> int:
        return len(self.cell.groups)

    @staticmethod
    def error_reply(error: PeerProtocolError) -> Message:
        """A frame the motion port cannot read: INVALID 3001/3002, and the connection is kept.
        An M-register type is unknown here whatever its length: 3003, as when well-formed."""
        if error.msg_type in M_REGISTER_TYPES:
            return invalid_reply(
                PeerProtocolError(str(error), InvalidSubcode.MSGTYPE, error.msg_type)
            )
        return invalid_reply(error)

    def respond(self, request: Message | UnknownMessage) -> Response:
        """What to send for one request. A request that is itself a reply (comm type 3) is
        processed but never answered (MotoROS 1.9.4, "don't reply to replies")."""
        reply = self._dispatch(request)
        then = self.trajectories.send_accepted if self.trajectories.unsent else None
        if isinstance(reply, _Close):
            return Response(None, close=True, then=then)
        if request.comm_type == CommType.SERVICE_REPLY:
            return Response(None, then=then)
        return Response(reply, then=then)

    def _dispatch(self, request: Message | UnknownMessage) -> Message | _Close:
        if isinstance(request, UnknownMessage):
            return invalid_reply(request)
        body = request.body
        match body:
            case JointTrajPtFull():
                with self.port.current():
                    return motion_reply(request, *self.trajectories.point(body))
            case JointTrajPtFullEx():
                with self.port.current():
                    return self.trajectories.point_ex(request, body)
            case MotoMotionCtrl():
                return self.command(request, body)
            case SelectTool():
                return motion_reply(request, *self.select_tool(body))
            case ReadIOBit() | WriteIOBit() | ReadIOGroup() | WriteIOGroup():
                # Served here too for backward compatibility, by the I/O port's handler
                # (motoros1 §2.2).
                return self.io.reply(request)
            case ReadMRegister() | WriteMRegister():
                # M-registers are an I/O-port service only: the motion port does not know the
                # types, so INVALID 3003 with group and sequence -1 (motoros1 §2.2, motoros1 §2.7).
                return motion_reply(request, Result.INVALID, InvalidSubcode.MSGTYPE)
        if request.msg_type == MsgType.PING:
            return service_reply(MsgType.PING, body)
        if request.msg_type == MsgType.MOTO_GET_DH_PARAMETERS:
            return service_reply(MsgType.MOTO_GET_DH_PARAMETERS, self.dh_parameters())
        # 13, 15, 2002, 2017 and the I/O port's M-register types: known sizes, no handler here.
        # MotoROS 1.9.4+ closes the connection without a reply (motoros1 §2.7).
        log.warning("motion port: type %d has no handler here; closing", request.msg_type)
        return CLOSE

    def command(self, request: Message, body: MotoMotionCtrl) -> Message | _Close:
        """motoros1 §2.3. Every command answers; unknown ones get INVALID/3006 (MotoROS
        re-sends a stale reply buffer there [quirk])."""
        try:
            command = Command(body.command)
        except ValueError:
            return motion_reply(request, Result.INVALID, InvalidSubcode.COMMAND)
        match command:
            case Command.CHECK_MOTION_READY:
                with self.port.current():
                    ready, subcode = readiness(self.port, self.source)
                if ready:
                    return motion_reply(request, Result.TRUE, 0)
                return motion_reply(request, Result.FALSE, subcode)
            case Command.CHECK_QUEUE_CNT:
                # From the executor's last published queue state, as fresh as a query to it
                # would be: the executor answers queries only at its next tick (up to 4 ms).
                with self.port.current() as state:
                    count = state.queue_count(body.group_no)
                if count is None:
                    return motion_reply(request, Result.FAILURE, -1)
                return motion_reply(request, Result.SUCCESS, count)
            case Command.STOP_MOTION:
                stopped = not self._other_holds() and self.stop_motion()
                return motion_reply(request, Result.SUCCESS if stopped else Result.FAILURE, 0)
            case Command.START_SERVOS | Command.RESET_ALARM:
                verb = "start_servos" if command is Command.START_SERVOS else "reset_alarm"
                return motion_reply(
                    request, *self._controller(verb, timeout=START_TRAJ_MODE_TIMEOUT_S)
                )
            case Command.STOP_SERVOS:
                self.stop_motion()
                return motion_reply(request, *self._controller("stop_servos"))
            case Command.START_TRAJ_MODE:
                return motion_reply(request, *self.start_traj_mode())
            case Command.STOP_TRAJ_MODE:
                return motion_reply(
                    request, Result.SUCCESS if self.stop_traj_mode() else Result.FAILURE, 0
                )
            case Command.DISCONNECT:
                if self.stop_traj_mode():
                    return CLOSE  # 1.9.4+: closed without sending the reply (motoros1 §2.3)
                return motion_reply(request, Result.FAILURE, 0)

    def _controller(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 2.0
    ) -> Verdict:
        reply = self.port.controller(verb, request, timeout=timeout)
        if reply is None:
            return int(Result.FAILURE), 0
        return reply.result, reply.subcode

    def _other_holds(self) -> bool:
        with self.port.current() as state:
            return state.held_by_other(self.source)

    def start_traj_mode(self) -> Verdict:
        """motoros1 §2.3: the controller starts the job; then every interpolator must be heard
        from and the executor taking increments, or the first point could not be numbered. A
        failure is answered NOT_READY with the reason (motoros1 §7.2). The face takes
        trajectory mode before it asks, unless the other face holds it (``core.sources``)."""
        with self.port.current() as state:
            if state.held_by_other(self.source):
                return int(Result.NOT_READY), readiness(self.port, self.source)[1]
            state.sources.begin_start(self.source)
        result, subcode = self._controller("start_traj_mode", timeout=START_TRAJ_MODE_TIMEOUT_S)
        state = self.port.state
        if result == Result.SUCCESS and not self.port.wait_for(state.rings_ready, SLOTS_WAIT_S):
            result = int(Result.FAILURE)
        with self.port.current():
            state.sources.end_start(self.source, started=result == Result.SUCCESS)
            if result == Result.FAILURE:
                result, subcode = int(Result.NOT_READY), readiness(self.port, self.source)[1]
        return result, subcode

    def stop_motion(self) -> bool:
        """motoros1 §3.3: clear every queue and pending point (all groups, whatever groupNo
        says); the trajectory is over, trajectory mode stays on."""
        self.trajectories.end_all()
        reply = self.port.executor("stop")
        cleared = reply is not None and reply.result == Result.SUCCESS
        return self.port.wait_for(self.port.state.slots_free, STOP_WAIT_S) and cleared

    def stop_traj_mode(self) -> bool:
        """motoros1 §2.3: refuse while anything is queued (a ring, as CHECK_QUEUE_CNT sees it,
        or a pending point), or while the other face holds trajectory mode; else STOP_MOTION
        and release the job, and the face gives trajectory mode up."""
        with self.port.current() as state:
            idle = state.idle() and not state.held_by_other(self.source)
        if not idle or not self.stop_motion():
            return False
        if self._controller("stop_traj_mode")[0] != Result.SUCCESS:
            return False
        with self.port.current() as state:
            state.sources.release(self.source)
        return True

    def disconnected(self) -> None:
        """The face's client went (the motion port's connection closed): its motion stops and
        it gives trajectory mode up; the other face's motion, if it holds it, goes on."""
        if self._other_holds():
            return
        self.stop_motion()
        with self.port.current() as state:
            state.sources.release(self.source)

    def select_tool(self, body: SelectTool) -> Verdict:
        if not 0 <= body.group_no < self.groups:
            return invalid(InvalidSubcode.GROUPNO)
        if body.tool not in TOOL_NUMBERS:
            return invalid(InvalidSubcode.DATA_TOOLNO)
        return self._controller("select_tool", CommandRequest(group=body.group_no, value=body.tool))

    def dh_parameters(self) -> GetDhParametersReply:
        """4 groups x 8 links; groups and links the cell does not have are zero (motoros1 §1.2)."""
        zero = DhLink(0.0, 0.0, 0.0, 0.0)
        groups = []
        for index in range(MAX_GROUPS):
            links = [zero] * DH_LINKS
            if index < self.groups:
                for link, values in enumerate(self.cell.groups[index].model.dh):
                    links[link] = DhLink(*values)
            groups.append(tuple(links))
        return GetDhParametersReply(tuple(groups))
