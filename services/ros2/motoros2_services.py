"""MotoROS2's mode, point-queue, error, I/O and tool services over the cell's one motion API
(``motion_api``): each is one Simple Message request, answered in MotoROS2's codes
(``core.codes``, ``core.point_queue``; MotoROS2's I/O result codes are MotoROS1's). No ROS 2
here: the node (``node``) serves them, and tests call them directly."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

from motocell.services.ros2.core.codes import NOT_READY_ALARM, motion_ready_code
from motocell.services.ros2.core.point_queue import Modes, MotionMode, QueuedPoint
from motocell.services.ros2.goal_runner import point_message
from motocell.shared.config import Group
from motocell.shared.protocol.constants import Command, InvalidSubcode, IoResult, Result
from motocell.shared.protocol.messages import (
    Message,
    MotoMotionReply,
    ReadIOBitReply,
    ReadIOGroupReply,
    ReadMRegisterReply,
    WriteIOBitReply,
    WriteIOGroupReply,
    WriteMRegisterReply,
)
from motocell.shared.protocol.replies import (
    motion_ctrl,
    read_io_bit,
    read_io_group,
    read_mregister,
    select_tool,
    write_io_bit,
    write_io_group,
    write_mregister,
)

SELECTION_OK = 0
"""MotoROS2's ``SelectionResultCodes``."""
SELECTION_REFUSED = {
    int(InvalidSubcode.GROUPNO): 401,  # INVALID_CONTROL_GROUP
    int(InvalidSubcode.DATA_TOOLNO): 402,  # INVALID_SELECTION_INDEX
}
INVALID_CONTROLLER_STATE = 400
INT32_MAX = 2**31 - 1
"""Simple Message's fields are int32; MotoROS2's addresses and numbers uint32: a larger one
names nothing the cell has."""
Reading = ReadIOBitReply | ReadIOGroupReply | ReadMRegisterReply
Writing = WriteIOBitReply | WriteIOGroupReply | WriteMRegisterReply

NOT_STOPPED = "Can't disable trajectory mode: increment queue not empty"
"""MotoROS2's words when stop_traj_mode is refused (the robot moves, or the other face holds
trajectory mode)."""


class Requests(Protocol):
    def request(self, message: Message) -> Message | None: ...


class Motoros2Services:
    def __init__(self, motion: Requests, groups: Sequence[Group], modes: Modes) -> None:
        self._motion = motion
        self._groups = groups
        self.modes = modes

    def _command(self, command: Command) -> MotoMotionReply | None:
        reply = self._motion.request(motion_ctrl(command))
        body = None if reply is None else reply.body
        return body if isinstance(body, MotoMotionReply) else None

    def start_traj_mode(self) -> int:
        """``start_traj_mode``: MotoROS2's ``MotionReadyEnum``."""
        return self._start(MotionMode.TRAJECTORY)

    def start_point_queue_mode(self) -> int:
        """``start_point_queue_mode``: as ``start_traj_mode``, for ``queue_traj_point``."""
        return self._start(MotionMode.POINT_QUEUE)

    def _start(self, mode: MotionMode) -> int:
        refusal = self.modes.refusal(mode)
        if refusal is not None:
            return refusal
        reply = self._command(Command.START_TRAJ_MODE)
        if reply is None:
            return motion_ready_code(Result.FAILURE, 0)
        code = motion_ready_code(reply.result, reply.subcode)
        self.modes.started(mode, code)
        return code

    def queue_traj_point(self, queued: QueuedPoint) -> int:
        """``queue_traj_point``: MotoROS2's ``QueueResultEnum``, or an ``InitTraj`` code for
        a first point it refuses."""
        numbered = self.modes.to_send(queued)
        if isinstance(numbered, int):
            return numbered
        reply = self._motion.request(point_message(self._groups, numbered.sequence, numbered.point))
        body = None if reply is None else reply.body
        if not isinstance(body, MotoMotionReply):
            return self.modes.answered(queued, int(Result.FAILURE), 0)
        return self.modes.answered(queued, body.result, body.subcode)

    def motion_ready(self) -> int:
        """CHECK_MOTION_READY in MotoROS2's codes: whether a goal may run now."""
        reply = self._command(Command.CHECK_MOTION_READY)
        if reply is None:
            return motion_ready_code(Result.FAILURE, 0)
        return motion_ready_code(reply.result, reply.subcode)

    def stop_traj_mode(self) -> tuple[bool, str]:
        """``stop_traj_mode`` (std_srvs/Trigger): refused while anything moves."""
        reply = self._command(Command.STOP_TRAJ_MODE)
        if reply is not None and reply.result == Result.SUCCESS:
            self.modes.stopped()
            return True, ""
        return False, NOT_STOPPED

    def reset_error(self) -> int:
        """``reset_error``: alarms and errors cleared (READY), or what stays: an alarm the
        controller keeps, an E-stop, which no service can clear."""
        reply = self._command(Command.RESET_ALARM)
        if reply is None:
            return motion_ready_code(Result.FAILURE, 0)
        if reply.result == Result.FAILURE:
            return NOT_READY_ALARM
        return motion_ready_code(reply.result, reply.subcode)

    # -- I/O and M-registers: (result code, value) ------------------------------------------
    def read_single_io(self, address: int) -> tuple[int, int]:
        return self._read(address, read_io_bit)

    def write_single_io(self, address: int, value: int) -> int:
        return self._write(address, value, write_io_bit)

    def read_group_io(self, address: int) -> tuple[int, int]:
        return self._read(address, read_io_group)

    def write_group_io(self, address: int, value: int) -> int:
        return self._write(address, value, write_io_group)

    def read_mregister(self, address: int) -> tuple[int, int]:
        return self._read(address, read_mregister)

    def write_mregister(self, address: int, value: int) -> int:
        return self._write(address, value, write_mregister)

    def _read(self, address: int, build: Callable[[int], Message]) -> tuple[int, int]:
        if address > INT32_MAX:
            return int(IoResult.READ_ADDRESS_INVALID), 0
        reply = self._motion.request(build(address))
        body = None if reply is None else reply.body
        if isinstance(body, Reading):
            return body.result_code, body.value
        return int(IoResult.READ_API_ERROR), 0

    def _write(self, address: int, value: int, build: Callable[[int, int], Message]) -> int:
        if address > INT32_MAX:
            return int(IoResult.WRITE_ADDRESS_INVALID)
        reply = self._motion.request(build(address, value))
        body = None if reply is None else reply.body
        if isinstance(body, Writing):
            return body.result_code
        return int(IoResult.WRITE_API_ERROR)

    def select_motion_tool(self, group: int, tool: int) -> int:
        """``select_motion_tool``: MotoROS2's ``SelectionResultCodes``."""
        if group > INT32_MAX:
            return SELECTION_REFUSED[int(InvalidSubcode.GROUPNO)]
        if tool > INT32_MAX:
            return SELECTION_REFUSED[int(InvalidSubcode.DATA_TOOLNO)]
        reply = self._motion.request(select_tool(group, tool))
        body = None if reply is None else reply.body
        if not isinstance(body, MotoMotionReply):
            return INVALID_CONTROLLER_STATE
        if body.result == Result.SUCCESS:
            return SELECTION_OK
        return SELECTION_REFUSED.get(body.subcode, INVALID_CONTROLLER_STATE)
