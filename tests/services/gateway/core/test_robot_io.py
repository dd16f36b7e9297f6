"""The I/O port's handler on a fake cell (motoros1 §8): each request becomes a controller
command, the reply carries its result code, a silent controller an API error, and nothing
closes."""

from __future__ import annotations

import msgspec
import pytest

from motocell.services.gateway.core.robot_io import IO_TIMEOUT_S, RobotIoHandler
from motocell.shared.bus.schemas import CommandReply, CommandRequest
from motocell.shared.protocol.constants import InvalidSubcode, IoResult, MsgType, ReplyType, Result
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import (
    Body,
    Message,
    MotoMotionReply,
    ReadIOBitReply,
    ReadIOGroupReply,
    ReadMRegisterReply,
    UnknownMessage,
    WriteIOBitReply,
    WriteIOGroupReply,
    WriteMRegisterReply,
)
from motocell.shared.protocol.replies import (
    motion_ctrl,
    ping,
    read_io_bit,
    read_io_group,
    read_mregister,
    write_io_bit,
    write_io_group,
    write_mregister,
)
from tests.services.gateway.core.fake_cell import FakeCell

READ = 7
"""What the fake controller reads from any address."""
ANSWERED = CommandReply(0, value=READ)
VERBS = ("read_bit", "write_bit", "read_group", "write_group", "read_register", "write_register")

EXCHANGES = [
    (
        read_io_bit(27010),
        "read_bit",
        CommandRequest(value=27010),
        MsgType.MOTO_READ_IO_BIT_REPLY,
        ReadIOBitReply(READ, 0),
    ),
    (
        write_io_bit(27010, 1),
        "write_bit",
        CommandRequest(value=27010, args=[1]),
        MsgType.MOTO_WRITE_IO_BIT_REPLY,
        WriteIOBitReply(0),
    ),
    (
        read_io_group(1001),
        "read_group",
        CommandRequest(value=1001),
        MsgType.MOTO_READ_IO_GROUP_REPLY,
        ReadIOGroupReply(READ, 0),
    ),
    (
        write_io_group(1001, 200),
        "write_group",
        CommandRequest(value=1001, args=[200]),
        MsgType.MOTO_WRITE_IO_GROUP_REPLY,
        WriteIOGroupReply(0),
    ),
    (
        read_mregister(5),
        "read_register",
        CommandRequest(value=5),
        MsgType.MOTO_READ_MREGISTER,
        ReadMRegisterReply(READ, 0),
    ),
    (
        write_mregister(5, -3),
        "write_register",
        CommandRequest(value=5, args=[-3]),
        MsgType.MOTO_WRITE_MREGISTER,
        WriteMRegisterReply(0),
    ),
]


def io(reply: CommandReply | None = ANSWERED) -> tuple[RobotIoHandler, FakeCell]:
    cell = FakeCell(1)
    for verb in VERBS:
        cell.replies[f"controller/{verb}"] = reply
    return RobotIoHandler(cell), cell


@pytest.mark.parametrize(("request_", "verb", "command", "reply_type", "body"), EXCHANGES)
def test_each_request_is_one_controller_command(
    request_: Message, verb: str, command: CommandRequest, reply_type: MsgType, body: Body
) -> None:
    handler, cell = io()
    reply = handler.reply(request_)
    assert (reply.msg_type, reply.reply_type, reply.body) == (
        reply_type,
        ReplyType.SUCCESS,
        body,
    )
    [call] = cell.calls
    assert (call.service, call.verb, call.request, call.timeout) == (
        "controller",
        verb,
        command,
        IO_TIMEOUT_S,
    )


def test_the_controllers_result_code_is_the_replys() -> None:
    handler, _ = io(CommandReply(int(IoResult.READ_ADDRESS_INVALID)))
    reply = handler.reply(read_io_bit(1))
    assert reply.body == ReadIOBitReply(0, IoResult.READ_ADDRESS_INVALID)
    assert reply.reply_type == ReplyType.FAILURE


@pytest.mark.parametrize(("request_", "verb", "command", "reply_type", "body"), EXCHANGES)
def test_a_controller_that_does_not_answer_is_an_api_error(
    request_: Message, verb: str, command: CommandRequest, reply_type: MsgType, body: Body
) -> None:
    handler, _ = io(None)
    reply = handler.reply(request_)
    writes = ("write_bit", "write_group", "write_register")
    code = IoResult.WRITE_API_ERROR if verb in writes else IoResult.READ_API_ERROR
    failed = msgspec.structs.replace(body, result_code=int(code))
    if hasattr(failed, "value"):
        failed = msgspec.structs.replace(failed, value=0)
    assert (reply.reply_type, reply.body) == (ReplyType.FAILURE, failed)


def unknown_type_reply(subcode: InvalidSubcode = InvalidSubcode.MSGTYPE) -> MotoMotionReply:
    """MotoROS's I/O error reply: result in groupNo, subcode in sequence (motoros1 §8)."""
    return MotoMotionReply(int(Result.INVALID), int(subcode), 0, 0, 0, (0.0,) * 10)


@pytest.mark.parametrize(
    "request_",
    [ping(), motion_ctrl(200101), UnknownMessage(99, 2, 0, b"")],
    ids=["ping", "motion command", "unknown"],
)
def test_other_types_get_the_unknown_type_reply(request_: Message | UnknownMessage) -> None:
    handler, cell = io()
    reply = handler.reply(request_)
    assert reply.msg_type == MsgType.MOTO_MOTION_REPLY
    assert reply.body == unknown_type_reply()
    assert cell.calls == []


def test_the_answer_always_replies_and_never_closes() -> None:
    handler, _ = io(None)
    response = handler.respond(read_io_bit(1))
    assert response.reply is not None
    assert not response.close
    assert response.then is None


def test_an_unreadable_frame_gets_the_io_error_reply() -> None:
    error = PeerProtocolError("short", InvalidSubcode.MSGSIZE, msg_type=2003)
    assert RobotIoHandler.error_reply(error).body == unknown_type_reply(InvalidSubcode.MSGSIZE)
