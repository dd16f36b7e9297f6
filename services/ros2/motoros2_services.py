"""MotoROS2's mode and error services over the cell's one motion API (``motion_api``): each is
one Simple Message command, answered in MotoROS2's codes (``core.codes``). No ROS 2 here: the
node (``node``) serves them, and tests call them directly."""

from __future__ import annotations

from typing import Protocol

from motocell.services.ros2.core.codes import NOT_READY_ALARM, motion_ready_code
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.messages import Message, MotoMotionReply
from motocell.shared.protocol.replies import motion_ctrl

NOT_STOPPED = "Can't disable trajectory mode: increment queue not empty"
"""MotoROS2's words when stop_traj_mode is refused (the robot moves, or the other face holds
trajectory mode)."""


class Requests(Protocol):
    def request(self, message: Message) -> Message | None: ...


class Motoros2Services:
    def __init__(self, motion: Requests) -> None:
        self._motion = motion

    def _command(self, command: Command) -> MotoMotionReply | None:
        reply = self._motion.request(motion_ctrl(command))
        body = None if reply is None else reply.body
        return body if isinstance(body, MotoMotionReply) else None

    def start_traj_mode(self) -> int:
        """``start_traj_mode``: MotoROS2's ``MotionReadyEnum``."""
        reply = self._command(Command.START_TRAJ_MODE)
        if reply is None:
            return motion_ready_code(Result.FAILURE, 0)
        return motion_ready_code(reply.result, reply.subcode)

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
