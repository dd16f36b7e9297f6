"""MotoROS2's mode and error services over a scripted motion API: each one command, answered in
MotoROS2's codes."""

from __future__ import annotations

import pytest

from motocell.services.ros2.core.codes import READY, UNSPECIFIED, motion_ready_code
from motocell.services.ros2.core.point_queue import Modes
from motocell.services.ros2.core.topics import names_by_group
from motocell.services.ros2.motoros2_services import NOT_STOPPED, Motoros2Services, Requests
from motocell.shared.protocol.constants import (
    Command,
    InvalidSubcode,
    IoResult,
    MsgType,
    NotReadySubcode,
    Result,
)
from motocell.shared.protocol.messages import (
    Message,
    MotoMotionCtrl,
    MotoMotionReply,
    ReadIOBitReply,
    WriteMRegisterReply,
)
from tests.services.ros2.scripted import face_cell, face_of


def serving(motion: Requests) -> Motoros2Services:
    """The services of a one-arm cell's face over ``motion``."""
    cell = face_cell()
    return Motoros2Services(motion, cell.groups, Modes(names_by_group(cell, face_of(cell))))


class Answers:
    def __init__(self, result: Result | None, subcode: int = 0) -> None:
        self.result, self.subcode = result, subcode
        self.commands: list[int] = []

    def request(self, message: Message) -> Message | None:
        assert isinstance(message.body, MotoMotionCtrl)
        self.commands.append(message.body.command)
        if self.result is None:
            return None
        reply = MotoMotionReply(0, 0, message.body.command, int(self.result), self.subcode)
        return Message(int(MsgType.MOTO_MOTION_REPLY), 3, 1, reply)


@pytest.mark.parametrize(
    ("result", "subcode", "code"),
    [
        (Result.SUCCESS, 0, READY),
        (Result.TRUE, 0, READY),
        (Result.NOT_READY, NotReadySubcode.ESTOP, 103),
        (Result.FALSE, NotReadySubcode.INC_MOVE_ERROR, 112),
        (Result.NOT_READY, 5014, 114),
        (Result.NOT_READY, NotReadySubcode.SKILLSEND, UNSPECIFIED),
        (Result.FAILURE, 0, UNSPECIFIED),
    ],
)
def test_replies_are_motoros2s_motion_ready_codes(result: Result, subcode: int, code: int) -> None:
    assert motion_ready_code(result, subcode) == code


def test_start_traj_mode_is_one_command() -> None:
    answers = Answers(Result.NOT_READY, int(NotReadySubcode.HOLD))
    assert serving(answers).start_traj_mode() == 107
    assert answers.commands == [Command.START_TRAJ_MODE]


def test_stop_traj_mode_refused_says_why() -> None:
    assert serving(Answers(Result.FAILURE)).stop_traj_mode() == (False, NOT_STOPPED)
    assert serving(Answers(Result.SUCCESS)).stop_traj_mode() == (True, "")


def test_reset_error_that_fails_is_an_alarm_and_no_answer_unspecified() -> None:
    assert serving(Answers(Result.FAILURE)).reset_error() == 101
    assert serving(Answers(None)).reset_error() == UNSPECIFIED
    assert serving(Answers(Result.SUCCESS)).motion_ready() == READY


class IoAnswers:
    """Answers every I/O request with ``reply`` (its type's reply), counting the requests."""

    def __init__(
        self, reply: ReadIOBitReply | WriteMRegisterReply | MotoMotionReply | None
    ) -> None:
        self.reply = reply
        self.asked = 0

    def request(self, message: Message) -> Message | None:
        self.asked += 1
        if self.reply is None:
            return None
        return Message(int(MsgType.MOTO_READ_IO_BIT_REPLY), 3, 1, self.reply)


def test_a_read_gives_the_code_and_the_value_and_no_answer_an_api_error() -> None:
    assert serving(IoAnswers(ReadIOBitReply(1, 0))).read_single_io(10010) == (0, 1)
    assert serving(IoAnswers(None)).read_group_io(1001) == (IoResult.READ_API_ERROR, 0)
    assert serving(IoAnswers(WriteMRegisterReply(0))).write_mregister(1_000_010, 3) == 0
    assert serving(IoAnswers(None)).write_single_io(10010, 1) == IoResult.WRITE_API_ERROR


def test_an_address_beyond_simple_messages_int32_is_refused_without_asking() -> None:
    answers = IoAnswers(ReadIOBitReply(1, 0))
    services = serving(answers)
    assert services.read_single_io(2**31) == (IoResult.READ_ADDRESS_INVALID, 0)
    assert services.write_group_io(2**32 - 1, 1) == IoResult.WRITE_ADDRESS_INVALID
    assert services.select_motion_tool(2**31, 0) == 401
    assert answers.asked == 0


@pytest.mark.parametrize(
    ("result", "subcode", "code"),
    [
        (Result.SUCCESS, 0, 0),
        (Result.INVALID, InvalidSubcode.GROUPNO, 401),
        (Result.INVALID, InvalidSubcode.DATA_TOOLNO, 402),
        (Result.NOT_READY, 5005, 400),
    ],
)
def test_a_tool_selection_in_motoros2s_codes(result: Result, subcode: int, code: int) -> None:
    reply = MotoMotionReply(0, 0, 0, int(result), int(subcode))
    assert serving(IoAnswers(reply)).select_motion_tool(0, 1) == code
