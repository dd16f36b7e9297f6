"""Every port as a client sees it: replies to every request type, bad input, connection limits."""

from __future__ import annotations

import socket
import struct

import pytest

from motocell.shared.protocol.constants import (
    Command,
    CommType,
    InvalidSubcode,
    IoResult,
    MsgType,
    ReplyType,
    Result,
)
from motocell.shared.protocol.messages import (
    Empty,
    GetDhParametersReply,
    Message,
    MotoMotionReply,
    ReadIOBitReply,
    ReadIOGroupReply,
    ReadMRegisterReply,
    RobotStatus,
    WriteIOBitReply,
    WriteIOGroupReply,
    WriteMRegisterReply,
)
from motocell.shared.protocol.replies import (
    get_dh_parameters,
    motion_ctrl,
    ping,
    read_io_bit,
    read_io_group,
    read_mregister,
    select_tool,
    state_message,
    write_io_bit,
    write_io_group,
    write_mregister,
)
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell

pytestmark = pytest.mark.cell

OT_MOTION_CONNECTED = 11124
OT_STATE_CONNECTED = 11125
OT_IO_CONNECTED = 11126


def body(reply: object) -> object:
    assert isinstance(reply, Message), reply
    return reply.body


def closed_by_server(client: MotionClient, timeout: float = 3.0) -> bool:
    client.sock.settimeout(timeout)
    try:
        return client.sock.recv(1) == b""
    except ConnectionResetError:
        return True


# -- the I/O port ------------------------------------------------------------------------------


def test_io_bits_groups_and_registers(cell: RunningCell) -> None:
    with cell.io() as io:
        assert body(io.request(write_io_bit(10010, 1))) == WriteIOBitReply(IoResult.OK)
        assert body(io.request(read_io_bit(10010))) == ReadIOBitReply(1, IoResult.OK)
        reply = io.request(write_io_group(1002, 0xA5))
        assert isinstance(reply, Message) and reply.reply_type == ReplyType.SUCCESS
        assert body(reply) == WriteIOGroupReply(IoResult.OK)
        assert body(io.request(read_io_group(1002))) == ReadIOGroupReply(0xA5, IoResult.OK)
        assert body(io.request(read_io_bit(10020))) == ReadIOBitReply(1, IoResult.OK)
        assert body(io.request(read_io_bit(10021))) == ReadIOBitReply(0, IoResult.OK)
        assert body(io.request(write_mregister(5, 0xBEEF))) == WriteMRegisterReply(IoResult.OK)
        reply = io.request(read_mregister(1_000_005))
        assert isinstance(reply, Message) and reply.msg_type == MsgType.MOTO_READ_MREGISTER
        assert body(reply) == ReadMRegisterReply(0xBEEF, IoResult.OK)


@pytest.mark.parametrize(
    ("request_message", "expected"),
    [
        (read_io_bit(19), ReadIOBitReply(0, IoResult.READ_ADDRESS_INVALID)),
        (read_io_bit(99999), ReadIOBitReply(0, IoResult.READ_ADDRESS_INVALID)),
        (write_io_bit(10, 1), WriteIOBitReply(IoResult.WRITE_ADDRESS_INVALID)),
        (write_io_bit(10010, 2), WriteIOBitReply(IoResult.WRITE_VALUE_INVALID)),
        (write_io_bit(10, 2), WriteIOBitReply(IoResult.WRITE_ADDRESS_INVALID)),
        (write_io_group(1002, 256), WriteIOGroupReply(IoResult.WRITE_VALUE_INVALID)),
        (read_mregister(1000), ReadMRegisterReply(0, IoResult.READ_ADDRESS_INVALID)),
        (write_mregister(560, 1), WriteMRegisterReply(IoResult.WRITE_ADDRESS_INVALID)),
        (write_mregister(5, 0x10000), WriteMRegisterReply(IoResult.WRITE_VALUE_INVALID)),
    ],
)
def test_io_refusals_carry_motoros_result_codes(
    cell: RunningCell, request_message: Message, expected: object
) -> None:
    with cell.io() as io:
        reply = io.request(request_message)
        assert isinstance(reply, Message)
        assert (reply.comm_type, reply.reply_type) == (CommType.SERVICE_REPLY, ReplyType.FAILURE)
        assert reply.body == expected


def test_io_port_answers_unknown_types_with_its_error_form(cell: RunningCell) -> None:
    with cell.io() as io:
        reply = io.request(ping())
        assert isinstance(reply, Message) and reply.msg_type == MsgType.MOTO_MOTION_REPLY
        error = reply.body
        assert isinstance(error, MotoMotionReply)
        assert (error.group_no, error.sequence) == (Result.INVALID, InvalidSubcode.MSGTYPE)
        assert body(io.request(read_io_bit(10010))) == ReadIOBitReply(1, IoResult.OK)


def test_connection_outputs_are_readable(cell: RunningCell) -> None:
    with cell.motion() as motion, cell.io() as io:
        motion.command(Command.CHECK_MOTION_READY)

        def both_on() -> bool:
            return all(
                body(io.request(read_io_bit(ot))) == ReadIOBitReply(1, IoResult.OK)
                for ot in (OT_MOTION_CONNECTED, OT_IO_CONNECTED)
            )

        wait_until(both_on, 5.0, "OT#893 and OT#895 on")


def test_the_state_output_follows_the_state_clients(cell: RunningCell) -> None:
    """OT#894 comes from the broadcaster, which serves the state port; OT#893 and OT#895 from
    the gateway: neither report undoes the other's."""
    with cell.io() as io:

        def output(ot: int) -> int:
            reply = body(io.request(read_io_bit(ot)))
            assert isinstance(reply, ReadIOBitReply)
            return reply.value

        with cell.state() as state:
            state.wait_for(lambda f: f.status is not None, 5.0)
            wait_until(lambda: output(OT_STATE_CONNECTED) == 1, 5.0, "OT#894 on")
            assert output(OT_IO_CONNECTED) == 1
        wait_until(lambda: output(OT_STATE_CONNECTED) == 0, 5.0, "OT#894 off")
        assert output(OT_IO_CONNECTED) == 1


# -- the motion port ---------------------------------------------------------------------------


def test_motion_port_serves_every_other_request(cell: RunningCell) -> None:
    with cell.motion() as motion:
        reply = motion.request(ping())
        assert reply == Message(MsgType.PING, CommType.SERVICE_REPLY, ReplyType.SUCCESS, Empty())
        assert body(motion.request(read_io_bit(10010))) == ReadIOBitReply(1, IoResult.OK)
        dh = body(motion.request(get_dh_parameters()))
        assert isinstance(dh, GetDhParametersReply) and len(dh.groups) == 4
        assert dh.groups[0][0].d == pytest.approx(0.330) and dh.groups[1][0].d == 0.0
        assert motion.motion(select_tool(0, 7, sequence=3)) == MotoMotionReply(
            0, 3, MsgType.MOTO_SELECT_TOOL, Result.SUCCESS, 0, (0.0,) * 10
        )
        refused = motion.motion(select_tool(0, 64))
        assert (refused.result, refused.subcode) == (Result.INVALID, InvalidSubcode.DATA_TOOLNO)
        refused = motion.motion(select_tool(1, 0))
        assert (refused.result, refused.subcode) == (Result.INVALID, InvalidSubcode.GROUPNO)
        unknown = motion.motion(motion_ctrl(200199, sequence=9))
        assert (unknown.result, unknown.subcode, unknown.sequence) == (
            Result.INVALID,
            InvalidSubcode.COMMAND,
            9,
        )
        mreg = motion.motion(read_mregister(5))
        assert (mreg.group_no, mreg.sequence, mreg.command, mreg.result, mreg.subcode) == (
            -1,
            -1,
            MsgType.MOTO_READ_MREGISTER,
            Result.INVALID,
            InvalidSubcode.MSGTYPE,
        )
        count = motion.motion(motion_ctrl(Command.CHECK_QUEUE_CNT, group_no=3))
        assert (count.result, count.subcode) == (Result.FAILURE, -1)


def test_garbage_gets_invalid_and_the_connection_survives(cell: RunningCell) -> None:
    with cell.motion() as motion:
        # A frame of unknown type 777 with a 4-byte body, then a short ROBOT_STATUS-typed one.
        motion.sock.sendall(struct.pack("<iiiii", 16, 777, 2, 0, 1))
        reply = motion.reader.next()
        assert isinstance(reply, Message) and isinstance(reply.body, MotoMotionReply)
        assert (reply.body.result, reply.body.subcode, reply.body.command) == (
            Result.INVALID,
            InvalidSubcode.MSGTYPE,
            777,
        )
        motion.sock.sendall(struct.pack("<iiiii", 16, MsgType.MOTO_MOTION_CTRL, 2, 0, 1))
        short = motion.reader.next()
        assert isinstance(short, Message) and isinstance(short.body, MotoMotionReply)
        assert (short.body.result, short.body.subcode) == (Result.INVALID, InvalidSubcode.MSGSIZE)
        motion.sock.sendall(struct.pack("<i", -5))
        negative = motion.reader.next()
        assert isinstance(negative, Message) and isinstance(negative.body, MotoMotionReply)
        assert negative.body.result == Result.INVALID
        assert motion.command(Command.CHECK_MOTION_READY).result in (Result.TRUE, Result.FALSE)


def test_state_messages_sent_to_the_motion_port_close_it(cell: RunningCell) -> None:
    with cell.motion() as motion:
        motion.send(state_message(MsgType.ROBOT_STATUS, RobotStatus(1, 0, 0, 0, 0, 2, 1)))
        assert closed_by_server(motion)


def test_replies_are_not_answered(cell: RunningCell) -> None:
    with cell.motion() as motion:
        as_reply = Message(MsgType.PING, CommType.SERVICE_REPLY, ReplyType.SUCCESS, Empty())
        motion.send(as_reply)
        reply = motion.command(Command.CHECK_MOTION_READY)
        assert reply.command == Command.CHECK_MOTION_READY


# -- connection limits -------------------------------------------------------------------------


def test_a_new_motion_client_replaces_an_idle_one(cell: RunningCell) -> None:
    with cell.motion() as first:
        first.command(Command.CHECK_MOTION_READY)
        with cell.motion() as second:
            assert second.command(Command.CHECK_MOTION_READY).command == Command.CHECK_MOTION_READY
            assert closed_by_server(first)


def test_a_new_motion_client_is_refused_while_the_robot_moves(cell: RunningCell) -> None:
    with cell.motion() as first, cell.state() as state:
        assert first.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        start = state.wait_still().groups[0].positions[:6]
        result = stream(first, smooth_move(start, tuple(p + 0.3 for p in start), 1.5, 8))
        assert result.points == 8
        with cell.motion() as second:
            assert closed_by_server(second)
        assert first.command(Command.CHECK_QUEUE_CNT).result == Result.SUCCESS
        assert first.command(Command.STOP_MOTION).result == Result.SUCCESS


def test_state_port_takes_four_clients_and_a_fifth_replaces_the_first(cell: RunningCell) -> None:
    listeners: list[StateListener] = []
    try:
        for _ in range(4):  # each kept at once: closed below, however the others fare
            listeners.append(cell.state())
        for listener in listeners:
            listener.wait_for(lambda f: f.status is not None, 5.0)
        fifth = cell.state()
        listeners.append(fifth)
        fifth.wait_for(lambda f: f.status is not None, 5.0)
        wait_until(lambda: listeners[0].closed, 5.0, "the first state client to be dropped")
        for listener in listeners[1:]:
            listener.wait_for(lambda f: f.status is not None, 5.0)
    finally:
        for listener in listeners:
            listener.close()


def test_a_client_that_connects_and_says_nothing_does_not_block_others(cell: RunningCell) -> None:
    with socket.create_connection((cell.host, cell.port_base + 2)):
        pass
    with cell.io() as io:
        assert body(io.request(read_io_bit(10010))) == ReadIOBitReply(1, IoResult.OK)
