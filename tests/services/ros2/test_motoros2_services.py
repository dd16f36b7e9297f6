"""MotoROS2's mode and error services over a scripted motion API: each one command, answered in
MotoROS2's codes."""

from __future__ import annotations

import pytest

from motocell.services.ros2.core.codes import READY, UNSPECIFIED, motion_ready_code
from motocell.services.ros2.motoros2_services import NOT_STOPPED, Motoros2Services
from motocell.shared.protocol.constants import Command, MsgType, NotReadySubcode, Result
from motocell.shared.protocol.messages import Message, MotoMotionCtrl, MotoMotionReply


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
    assert Motoros2Services(answers).start_traj_mode() == 107
    assert answers.commands == [Command.START_TRAJ_MODE]


def test_stop_traj_mode_refused_says_why() -> None:
    assert Motoros2Services(Answers(Result.FAILURE)).stop_traj_mode() == (False, NOT_STOPPED)
    assert Motoros2Services(Answers(Result.SUCCESS)).stop_traj_mode() == (True, "")


def test_reset_error_that_fails_is_an_alarm_and_no_answer_unspecified() -> None:
    assert Motoros2Services(Answers(Result.FAILURE)).reset_error() == 101
    assert Motoros2Services(Answers(None)).reset_error() == UNSPECIFIED
    assert Motoros2Services(Answers(Result.SUCCESS)).motion_ready() == READY
