"""Hypothesis on the motion port's core, on a fake cell: every group, sequence and count field of
2016 (MOTO_JOINT_TRAJ_PT_FULL_EX) and 2017 (MOTO_JOINT_FEEDBACK_EX) a client can send gets its
documented answer, and nothing raises.

- 2016: exactly one MOTO_MOTION_REPLY for the message (command 2016, its sequence, one of its
  listed groups); a group the cell lacks or lists twice is never accepted; a refused message
  publishes nothing, an accepted one one point per listed group.
- 2016's group count against the body: 1-4 and a size that fits it (exact, or padded to 4
  groups) is decoded; anything else is INVALID 3001 and the connection is kept.
- 2017 is the controller's message: a client sending it is closed without a reply
  (motoros1 §2.7), whatever its count and slots; a 2017 of the wrong size is INVALID 3001.

Byte-level cases run through the motion port's own loop (``tcp.serve_requests``) on a socket
pair, so "one reply per request, in order, or a close" is the server's, not a copy of it.
"""

from __future__ import annotations

import socket
import struct
import threading
from dataclasses import dataclass

from hypothesis import given
from hypothesis import strategies as st

from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.core.response import Response
from motocell.services.gateway.tcp import serve_requests
from motocell.shared.config import Cell, parse_cell
from motocell.shared.protocol.codec import CLOSED, NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.constants import MAX_GROUPS, InvalidSubcode, MsgType, Result
from motocell.shared.protocol.layouts import JOINT_BLOCK, JOINT_BLOCK_SIZE
from motocell.shared.protocol.messages import (
    JointFeedback,
    JointFeedbackEx,
    JointTrajPtExGroup,
    JointTrajPtFull,
    JointTrajPtFullEx,
    Message,
    MotoMotionReply,
    UnknownMessage,
)
from motocell.shared.protocol.replies import ex_group, state_message, traj_point_ex
from tests.services.gateway.core.fake_cell import FakeCell, exchange, gateway

I32_MIN, I32_MAX = -(2**31), 2**31 - 1
i32 = st.integers(I32_MIN, I32_MAX)
edges = st.sampled_from([I32_MIN, I32_MIN + 1, I32_MAX - 1, I32_MAX])
group_numbers = st.integers(-2, MAX_GROUPS + 1) | edges | i32
sequences = st.integers(-2, 4) | edges | i32
group_counts = st.integers(-2, MAX_GROUPS + 2) | edges | i32
times = st.sampled_from([0.0, 0.1, 0.2, 0.3]) | st.floats(width=32)
fields = st.sampled_from([7, 15]) | st.integers(0, 15) | i32
f32 = st.floats(width=32)
ZEROS = (0.0,) * 10
joints = st.just(ZEROS) | st.tuples(*[f32] * 10)
ex_groups = st.builds(JointTrajPtExGroup, group_numbers, fields, times, joints, joints, joints)
ex_bodies = st.builds(
    JointTrajPtFullEx, sequences, st.lists(ex_groups, min_size=1, max_size=MAX_GROUPS).map(tuple)
)
feedback_slots = st.builds(JointFeedback, group_numbers, fields, times, joints, joints, joints)
REPLY_RESULTS = {int(r) for r in (Result.SUCCESS, Result.BUSY, Result.INVALID, Result.NOT_READY)}


def cell_of(groups: int) -> Cell:
    return parse_cell({"groups": [{"name": f"R{g + 1}"} for g in range(groups)]})


@st.composite
def motion_ports(draw: st.DrawFn) -> tuple[MotionHandler, FakeCell]:
    """A ready cell of 1, 2 or 4 groups: idle, or running a 2016 trajectory of every group
    (its last point taken or still pending, so resends, BUSY and sequence checks all happen)."""
    groups = draw(st.sampled_from([1, 2, 4]))
    handler, cell = gateway(cell_of(groups))
    if draw(st.booleans()):
        for sequence, time in enumerate((0.0, 0.1)):
            every = [ex_group(g, time, ZEROS, ZEROS) for g in range(groups)]
            assert exchange(handler, traj_point_ex(sequence, every)).reply is not None
        if draw(st.booleans()):
            for group in range(groups):
                cell.take_all(group)
    return handler, cell


def motion_reply_of(reply: Message | None) -> MotoMotionReply:
    assert reply is not None
    assert reply.msg_type == MsgType.MOTO_MOTION_REPLY
    assert isinstance(reply.body, MotoMotionReply)
    return reply.body


def listed_badly(body: JointTrajPtFullEx, groups: int) -> bool:
    numbers = [g.group_no for g in body.groups]
    return len(set(numbers)) != len(numbers) or not all(0 <= n < groups for n in numbers)


# ------------------------------------------------------------------------------ 2016 bodies


@given(motion_ports(), st.lists(ex_bodies, min_size=1, max_size=6))
def test_every_2016_gets_one_reply_and_a_bad_group_is_never_taken(
    port: tuple[MotionHandler, FakeCell], bodies: list[JointTrajPtFullEx]
) -> None:
    handler, cell = port
    for body in bodies:
        sent = len(cell.sent)
        response = exchange(handler, Message(MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX, 2, 0, body))
        assert not response.close
        reply = motion_reply_of(response.reply)
        assert (reply.command, reply.sequence) == (
            MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX,
            body.sequence,
        )
        assert reply.group_no in {g.group_no for g in body.groups}
        assert reply.result in REPLY_RESULTS
        published = cell.sent[sent:]
        if reply.result != Result.SUCCESS:
            assert published == []
        if listed_badly(body, handler.groups):
            assert reply.result != Result.SUCCESS
        if reply.result == Result.INVALID and reply.subcode == InvalidSubcode.GROUPNO:
            assert listed_badly(body, handler.groups)
        if published:
            assert [group for group, _ in published] == [g.group_no for g in body.groups]


@given(motion_ports(), sequences, group_numbers, fields, times)
def test_every_14_gets_one_reply_for_its_group(
    port: tuple[MotionHandler, FakeCell], sequence: int, group: int, valid: int, time: float
) -> None:
    handler, _ = port
    body = JointTrajPtFull(group, sequence, valid, time, ZEROS, ZEROS, ZEROS)
    response = exchange(handler, Message(MsgType.JOINT_TRAJ_PT_FULL, 2, 0, body))
    reply = motion_reply_of(response.reply)
    assert (reply.group_no, reply.sequence, reply.command) == (group, sequence, 14)
    if not 0 <= group < handler.groups:
        assert (reply.result, reply.subcode) == (Result.INVALID, InvalidSubcode.GROUPNO)


def test_a_2016_body_without_groups_is_invalid_3001() -> None:
    handler, cell = gateway()
    body = JointTrajPtFullEx(1, ())
    reply = motion_reply_of(exchange(handler, Message(2016, 2, 0, body)).reply)
    assert (reply.result, reply.subcode, reply.group_no) == (
        Result.INVALID,
        InvalidSubcode.MSGSIZE,
        -1,
    )
    assert cell.sent == []


# ------------------------------------------------------------------------------ the wire


@dataclass
class Served:
    replies: list[Message]
    closed_by_server: bool


def serve(handler: MotionHandler, data: bytes, order: ByteOrder) -> Served:
    """``data`` sent to the motion port's loop, then the client's half closed: every reply, and
    whether the server ended the connection itself (a handler's close)."""
    client, server = socket.socketpair()
    failures: list[BaseException] = []
    closes: list[bool] = []

    def respond(request: Message | UnknownMessage) -> Response:
        response = handler.respond(request)
        closes.append(response.close)
        return response

    def run() -> None:
        try:
            serve_requests(server, order, respond, handler.error_reply)
        except BaseException as error:  # re-raised in the test's thread
            failures.append(error)
        finally:
            server.close()

    thread = threading.Thread(target=run, name="motion-port")
    thread.start()
    client.sendall(data)
    client.shutdown(socket.SHUT_WR)
    replies = read_all(client, order)
    thread.join()
    client.close()
    if failures:
        raise failures[0]
    return Served(replies, any(closes))


def read_all(sock: socket.socket, order: ByteOrder) -> list[Message]:
    codec = SimpleMessageCodec(Role.CLIENT, order)
    replies: list[Message] = []
    while True:
        event = codec.next_event()
        if event is NEED_DATA:
            codec.receive_data(sock.recv(65536))
        elif event is CLOSED:
            return replies
        else:
            assert isinstance(event, Message), event
            replies.append(event)


def frame(msg_type: int, body: bytes, order: ByteOrder) -> bytes:
    return struct.pack(order.struct_prefix + "4i", 12 + len(body), msg_type, 2, 0) + body


def block(order: ByteOrder, group: int, valid: int, time: float) -> bytes:
    return struct.pack(order.struct_prefix + JOINT_BLOCK, group, valid, time, *[0.0] * 30)


@st.composite
def ex_frames(draw: st.DrawFn, order: ByteOrder) -> tuple[bytes, bool]:
    """A 2016 whose count says anything, with 0-4 blocks, padded to the 4-group size or not;
    and whether the codec can read it (count 1-4 and a size that fits the count)."""
    count, sequence = draw(group_counts), draw(sequences)
    blocks = draw(st.lists(st.tuples(group_numbers, fields, times), max_size=MAX_GROUPS))
    body = struct.pack(order.struct_prefix + "2i", count, sequence)
    body += b"".join(block(order, *b) for b in blocks)
    full = 8 + MAX_GROUPS * JOINT_BLOCK_SIZE
    if draw(st.booleans()):
        body = body.ljust(full, b"\0")
    readable = 1 <= count <= MAX_GROUPS and len(body) in (8 + count * JOINT_BLOCK_SIZE, full)
    return frame(MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX, body, order), readable


@given(motion_ports(), st.sampled_from(list(ByteOrder)), st.data())
def test_a_2016_count_that_does_not_fit_its_body_is_3001_and_the_port_goes_on(
    port: tuple[MotionHandler, FakeCell], order: ByteOrder, data: st.DataObject
) -> None:
    handler, _ = port
    frames = data.draw(st.lists(ex_frames(order), min_size=1, max_size=5))
    served = serve(handler, b"".join(f for f, _ in frames), order)
    assert not served.closed_by_server
    assert len(served.replies) == len(frames)
    for reply, (_, readable) in zip(served.replies, frames, strict=True):
        body = motion_reply_of(reply)
        assert body.command == MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX
        unreadable = (body.result, body.subcode) == (Result.INVALID, InvalidSubcode.MSGSIZE)
        assert unreadable != readable


@given(
    st.builds(JointFeedbackEx, group_counts, st.lists(feedback_slots, max_size=4).map(tuple)),
    st.sampled_from(list(ByteOrder)),
)
def test_a_client_sending_2017_is_closed_without_a_reply(
    body: JointFeedbackEx, order: ByteOrder
) -> None:
    handler, cell = gateway(cell_of(2))
    feedback = SimpleMessageCodec(Role.CONTROLLER, order).send(
        state_message(MsgType.MOTO_JOINT_FEEDBACK_EX, body)
    )
    after = frame(MsgType.PING, b"", order)
    served = serve(handler, feedback + after, order)
    assert served.replies == []
    assert served.closed_by_server
    assert cell.sent == []


@given(
    st.binary(max_size=600).filter(lambda b: len(b) != 532),
    st.sampled_from(list(ByteOrder)),
)
def test_a_2017_of_the_wrong_size_is_3001_and_the_port_goes_on(
    body: bytes, order: ByteOrder
) -> None:
    handler, _ = gateway(cell_of(2))
    served = serve(handler, frame(MsgType.MOTO_JOINT_FEEDBACK_EX, body, order), order)
    [reply] = served.replies
    error = motion_reply_of(reply)
    assert (error.result, error.subcode, error.command) == (
        Result.INVALID,
        InvalidSubcode.MSGSIZE,
        MsgType.MOTO_JOINT_FEEDBACK_EX,
    )
    assert not served.closed_by_server
