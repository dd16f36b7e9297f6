"""Framing, every error path, recovery after each, encoder rejections and the reply rules."""

from __future__ import annotations

import struct

import msgspec
import pytest

from motocell.shared.protocol import replies
from motocell.shared.protocol.codec import (
    CLOSED,
    NEED_DATA,
    ByteOrder,
    Event,
    Role,
    SimpleMessageCodec,
    decode_frames,
    encode,
)
from motocell.shared.protocol.constants import (
    Command,
    CommType,
    InvalidSubcode,
    IoResult,
    MsgType,
    NotReadySubcode,
    ReplyType,
    Result,
)
from motocell.shared.protocol.errors import LocalProtocolError, PeerProtocolError
from motocell.shared.protocol.layouts import LAYOUTS, Direction, max_body_size
from motocell.shared.protocol.messages import (
    DhLink,
    Empty,
    GetDhParametersReply,
    JointFeedback,
    JointFeedbackEx,
    JointTrajPtFull,
    JointTrajPtFullEx,
    Message,
    MotoMotionReply,
    ReadIOBit,
    RobotStatus,
    SelectTool,
    UnknownMessage,
    WriteIOBit,
)

JOINTS = (0.5, -1.25, 0.25, 1.0, -0.5, 2.0)
POINT = replies.traj_point(1, 7, 0.5, JOINTS, JOINTS)
CTRL = replies.motion_ctrl(Command.START_TRAJ_MODE, group_no=1, sequence=3)
EX_GROUPS = (replies.ex_group(0, 0.5, JOINTS, JOINTS), replies.ex_group(2, 0.5, JOINTS, JOINTS))
EX_POINT = replies.traj_point_ex(7, EX_GROUPS)
FEEDBACK = JointFeedback(1, 6, 0.0, JOINTS, JOINTS, ())
STREAM_TO_CONTROLLER: list[Message | UnknownMessage] = [
    POINT,
    CTRL,
    replies.ping(),
    EX_POINT,
    replies.select_tool(1, 5, 7),
    UnknownMessage(int(MsgType.GET_VERSION), 2, 0, b""),
    replies.read_mregister(12),
    replies.get_dh_parameters(),
]

# ------------------------------------------------------------------------------------- helpers


def le_frame(msg_type: int, body: bytes, length: int | None = None) -> bytes:
    """A little-endian frame built by hand; ``length`` overrides the prefix."""
    prefix = 12 + len(body) if length is None else length
    return struct.pack("<4i", prefix, msg_type, 2, 0) + body


def stream(messages: list[Message | UnknownMessage], role: Role = Role.CLIENT) -> bytes:
    return b"".join(encode(m, ByteOrder.LITTLE, role) for m in messages)


def drain(codec: SimpleMessageCodec) -> list[Event]:
    """Events up to and including NEED_DATA or CLOSED."""
    events = []
    while True:
        event = codec.next_event()
        events.append(event)
        if event is NEED_DATA or event is CLOSED:
            return events


def controller() -> SimpleMessageCodec:
    return SimpleMessageCodec(Role.CONTROLLER)


def expect_peer_error(codec: SimpleMessageCodec, subcode: InvalidSubcode, msg_type: int) -> None:
    with pytest.raises(PeerProtocolError) as caught:
        codec.next_event()
    assert (caught.value.result, caught.value.subcode, caught.value.msg_type) == (
        Result.INVALID,
        subcode,
        msg_type,
    )


# ------------------------------------------------------------------------------------- framing


def test_sizes_per_role() -> None:
    assert controller().max_frame_size == 4 + 12 + 536
    assert SimpleMessageCodec(Role.CLIENT).max_frame_size == 4 + 12 + 532


def test_several_frames_in_one_chunk_all_come_out() -> None:
    codec = controller()
    codec.receive_data(stream(STREAM_TO_CONTROLLER))
    assert drain(codec) == [*STREAM_TO_CONTROLLER, NEED_DATA]
    assert codec.buffered_bytes == 0


@pytest.mark.parametrize("order", list(ByteOrder))
def test_split_at_every_byte_boundary_reassembles(order: ByteOrder) -> None:
    data = b"".join(encode(m, order, Role.CLIENT) for m in STREAM_TO_CONTROLLER)
    for cut in range(1, len(data)):  # b"" would mean the peer closed
        codec = SimpleMessageCodec(Role.CONTROLLER, order)
        codec.receive_data(data[:cut])
        events = drain(codec)
        codec.receive_data(data[cut:])
        events += drain(codec)
        assert [e for e in events if e is not NEED_DATA] == STREAM_TO_CONTROLLER


def test_one_byte_at_a_time() -> None:
    data = stream(STREAM_TO_CONTROLLER)
    codec = controller()
    events: list[Event] = []
    for i in range(len(data)):
        codec.receive_data(data[i : i + 1])
        events += drain(codec)
    codec.receive_data(b"")
    events += drain(codec)
    assert [e for e in events if e is not NEED_DATA] == [*STREAM_TO_CONTROLLER, CLOSED]


def test_close_returns_whole_frames_then_closed_and_drops_a_partial_one() -> None:
    codec = controller()
    point = encode(POINT, ByteOrder.LITTLE, Role.CLIENT)
    codec.receive_data(point + point[:100])
    codec.receive_data(b"")
    assert drain(codec) == [POINT, CLOSED]
    assert codec.buffered_bytes == 0
    assert codec.next_event() is CLOSED
    codec.receive_data(b"")
    assert codec.next_event() is CLOSED


def test_data_after_close_is_our_bug() -> None:
    codec = controller()
    codec.receive_data(b"")
    with pytest.raises(LocalProtocolError):
        codec.receive_data(b"\x00")


def test_buffer_must_be_drained_before_more_data() -> None:
    codec = controller()
    frame = encode(POINT, ByteOrder.LITTLE, Role.CLIENT)
    codec.receive_data(frame * 4)  # 608 bytes pending >= 552
    with pytest.raises(LocalProtocolError):
        codec.receive_data(frame)
    assert drain(codec) == [POINT] * 4 + [NEED_DATA]
    codec.receive_data(frame)
    assert drain(codec) == [POINT, NEED_DATA]


# ------------------------------------------------------------------------- bad length prefixes


@pytest.mark.parametrize(
    ("length", "subcode"),
    [
        (-1, InvalidSubcode.MSGHEADER),
        (-(2**31), InvalidSubcode.MSGHEADER),
        (0, InvalidSubcode.MSGHEADER),
        (11, InvalidSubcode.MSGHEADER),
        (12 + 537, InvalidSubcode.MSGSIZE),
        (2**31 - 1, InvalidSubcode.MSGSIZE),
    ],
)
def test_bad_length_discards_everything_buffered_then_decoding_resumes(
    length: int, subcode: InvalidSubcode
) -> None:
    codec = controller()
    good = encode(CTRL, ByteOrder.LITTLE, Role.CLIENT)
    codec.receive_data(struct.pack("<i", length) + good)
    expect_peer_error(codec, subcode, 0)
    assert codec.buffered_bytes == 0
    assert codec.next_event() is NEED_DATA
    codec.receive_data(good)
    assert drain(codec) == [CTRL, NEED_DATA]


def test_bad_length_is_seen_as_soon_as_the_prefix_is_in() -> None:
    codec = controller()
    codec.receive_data(struct.pack("<i", 10_000))
    expect_peer_error(codec, InvalidSubcode.MSGSIZE, 0)


def test_largest_length_per_role() -> None:
    codec = SimpleMessageCodec(Role.CLIENT)
    codec.receive_data(struct.pack("<i", 544) + bytes(540))
    assert codec.next_event() is NEED_DATA
    codec = SimpleMessageCodec(Role.CLIENT)
    codec.receive_data(struct.pack("<i", 545))
    expect_peer_error(codec, InvalidSubcode.MSGSIZE, 0)


def test_peer_error_carries_its_reply() -> None:
    error = PeerProtocolError("bad", InvalidSubcode.MSGSIZE, 14)
    expected = Message(2002, 3, 1, MotoMotionReply(-1, -1, 14, 3, 3001, (0.0,) * 10))
    assert replies.invalid_reply(error) == expected
    assert str(error) == "bad"


# ---------------------------------------------------------------------------- wrong body sizes


def wrong_sizes() -> list[tuple[Role, int, int]]:
    """(receiver, type, body size) for every fixed-size layout, with sizes that still frame."""
    cases = []
    for (direction, msg_type), layout in LAYOUTS.items():
        if msg_type == MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX:
            continue  # variable size: test_bad_2016_is_3001
        role = Role.CONTROLLER if direction is Direction.TO_CONTROLLER else Role.CLIENT
        for size in (layout.max_size - 4, layout.max_size - 1, layout.max_size + 4):
            if 0 <= size <= max_body_size(direction):
                cases.append((role, msg_type, size))
    return cases


@pytest.mark.parametrize(("role", "msg_type", "size"), wrong_sizes())
def test_wrong_body_size_is_3001_and_the_frame_is_skipped(
    role: Role, msg_type: int, size: int
) -> None:
    codec = SimpleMessageCodec(role)
    ping = encode(replies.ping(), ByteOrder.LITTLE, Role.CLIENT)
    codec.receive_data(le_frame(msg_type, bytes(size)) + ping)
    expect_peer_error(codec, InvalidSubcode.MSGSIZE, msg_type)
    assert drain(codec) == [replies.ping(), NEED_DATA]


def ex_body(n: int, blocks: int, pad_to: int | None = None) -> bytes:
    body = struct.pack("<2i", n, 7) + bytes(132 * blocks)
    return body if pad_to is None else body.ljust(pad_to, b"\xee")


@pytest.mark.parametrize(
    "body",
    [
        ex_body(0, 0),  # MotoROS 1.9 answers from a stale buffer [quirk]; we answer 3001
        ex_body(0, 4),
        ex_body(-1, 1),
        ex_body(5, 4),  # can never fit
        ex_body(5, 4)[:-4],
        ex_body(2, 3),  # neither 8 + 132 x 2 nor the full 536
        ex_body(2, 1),
        ex_body(1, 1) + bytes(4),
        bytes(4),  # too short for the two header words
        b"",
    ],
    ids=["n0", "n0-full", "n-1", "n5", "n5-short", "n2-3blocks", "n2-1block", "extra", "4B", "0B"],
)
def test_bad_2016_is_3001(body: bytes) -> None:
    codec = controller()
    codec.receive_data(le_frame(2016, body) + encode(CTRL, ByteOrder.LITTLE, Role.CLIENT))
    expect_peer_error(codec, InvalidSubcode.MSGSIZE, 2016)
    assert drain(codec) == [CTRL, NEED_DATA]


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_2016_exact_and_full_size_both_decode(n: int) -> None:
    for body in (ex_body(n, n), ex_body(n, n, pad_to=536)):
        [event] = decode_frames(le_frame(2016, body), Role.CONTROLLER)
        assert isinstance(event, Message) and isinstance(event.body, JointTrajPtFullEx)
        assert (event.body.sequence, len(event.body.groups)) == (7, n)


# ------------------------------------------------------------------------------- unknown types


@pytest.mark.parametrize(
    ("role", "msg_type", "body"),
    [
        (Role.CONTROLLER, 2, b""),  # GET_VERSION
        (Role.CONTROLLER, 11, struct.pack("<3i", 0, -4, 0)),  # JOINT_TRAJ_PT stop at shutdown
        (Role.CONTROLLER, 2011, bytes(8)),
        (Role.CONTROLLER, 2004, bytes(8)),  # a reply type, unknown in this direction
        (Role.CONTROLLER, -7, bytes(3)),
        (Role.CLIENT, 14, bytes(136)),
        (Role.CLIENT, 2016, bytes(140)),
        (Role.CLIENT, 0x7FFFFFFF, bytes(532)),
    ],
)
def test_unknown_type_is_an_event_with_the_raw_body(role: Role, msg_type: int, body: bytes) -> None:
    codec = SimpleMessageCodec(role)
    codec.receive_data(le_frame(msg_type, body) + encode(replies.ping(), ByteOrder.LITTLE, role))
    assert drain(codec) == [UnknownMessage(msg_type, 2, 0, body), replies.ping(), NEED_DATA]


def test_unknown_message_round_trips() -> None:
    get_version = UnknownMessage(2, 2, 0, b"\x01\x02")
    assert decode_frames(
        encode(get_version, ByteOrder.BIG, Role.CLIENT), Role.CONTROLLER, ByteOrder.BIG
    ) == [get_version]


def test_decode_frames_rejects_a_truncated_tail() -> None:
    data = encode(POINT, ByteOrder.LITTLE, Role.CLIENT)
    with pytest.raises(PeerProtocolError) as caught:
        decode_frames(data + data[:10], Role.CONTROLLER)
    assert caught.value.subcode == InvalidSubcode.MSGSIZE


# ---------------------------------------------------------------------------- what send refuses


def too_long(values: tuple[float, ...]) -> tuple[float, ...]:
    return (*values, *(0.0,) * (11 - len(values)))


def traj(**changes: object) -> Message:
    body = JointTrajPtFull(0, 0, 7, 0.0, JOINTS, JOINTS, ())
    return Message(14, 2, 0, msgspec.structs.replace(body, **changes))


@pytest.mark.parametrize(
    ("role", "message"),
    [
        (Role.CLIENT, traj(positions=too_long(JOINTS))),
        (Role.CLIENT, traj(accelerations=too_long(()))),
        (Role.CLIENT, traj(group_no=2**31)),
        (Role.CLIENT, traj(time=1e39)),  # beyond float32
        (Role.CLIENT, traj(sequence="7")),
        (Role.CLIENT, Message(14, 2, 0, RobotStatus(0, 0, 0, 0, 0, 0, 0))),  # wrong body
        (Role.CLIENT, Message(2016, 2, 0, JointTrajPtFullEx(0, ()))),
        (Role.CLIENT, Message(2016, 2, 0, JointTrajPtFullEx(0, EX_GROUPS * 3))),
        (Role.CLIENT, Message(2016, 2, 0, RobotStatus(0, 0, 0, 0, 0, 0, 0))),
        (Role.CLIENT, Message(2016, 2, 0, JointTrajPtFullEx(2**31, EX_GROUPS))),
        (Role.CLIENT, Message(2003, 2, 0, ReadIOBit(-1))),  # uint32
        (Role.CLIENT, Message(2005, 2, 0, WriteIOBit(2**32, 0))),
        (Role.CLIENT, Message(2004, 3, 1, ReadIOBit(1))),  # a client never sends 2004
        (Role.CONTROLLER, Message(14, 2, 0, POINT.body)),  # a controller never sends 14
        (Role.CONTROLLER, Message(2017, 1, 0, JointFeedbackEx(5, (FEEDBACK,) * 5))),
        (Role.CONTROLLER, Message(2020, 3, 1, GetDhParametersReply(((),) * 5))),
        (Role.CONTROLLER, Message(2020, 3, 1, GetDhParametersReply(((DhLink(0, 0, 0, 0),) * 9,)))),
        (Role.CONTROLLER, Message(1, 2**32, 1, Empty())),  # header out of int32 range
        (Role.CLIENT, UnknownMessage(14, 2, 0, bytes(136))),  # known: must be a Message
        (Role.CLIENT, UnknownMessage(2, 2, 0, bytes(537))),  # longer than any receiver takes
    ],
)
def test_send_rejects_what_the_wire_cannot_carry(
    role: Role, message: Message | UnknownMessage
) -> None:
    with pytest.raises(LocalProtocolError):
        SimpleMessageCodec(role).send(message)


def test_encoder_pads_to_the_wire_shape() -> None:
    short = Message(14, 2, 0, JointTrajPtFull(0, 1, 7, 0.5, (0.5,), (), ()))
    [decoded] = decode_frames(SimpleMessageCodec(Role.CLIENT).send(short), Role.CONTROLLER)
    assert isinstance(decoded, Message) and isinstance(decoded.body, JointTrajPtFull)
    assert decoded.body.positions == (0.5, *(0.0,) * 9)
    assert decoded.body.velocities == decoded.body.accelerations == (0.0,) * 10

    feedback_ex = replies.state_message(2017, JointFeedbackEx(2, (FEEDBACK, FEEDBACK)))
    [decoded] = decode_frames(SimpleMessageCodec(Role.CONTROLLER).send(feedback_ex), Role.CLIENT)
    assert isinstance(decoded, Message) and isinstance(decoded.body, JointFeedbackEx)
    zero = JointFeedback(0, 0, 0.0, (0.0,) * 10, (0.0,) * 10, (0.0,) * 10)
    padded = JointFeedback(
        1, 6, 0.0, (*JOINTS, 0.0, 0.0, 0.0, 0.0), (*JOINTS, 0.0, 0.0, 0.0, 0.0), (0.0,) * 10
    )
    assert decoded.body == JointFeedbackEx(2, (padded, padded, zero, zero))

    link = DhLink(0.5, 1.0, -1.25, 0.25)
    dh = replies.service_reply(2020, GetDhParametersReply(((link,),)))
    [decoded] = decode_frames(SimpleMessageCodec(Role.CONTROLLER).send(dh), Role.CLIENT)
    assert isinstance(decoded, Message) and isinstance(decoded.body, GetDhParametersReply)
    zero_link = DhLink(0.0, 0.0, 0.0, 0.0)
    assert decoded.body.groups == (
        (link, *(zero_link,) * 7),
        *((zero_link,) * 8,) * 3,
    )


# --------------------------------------------------------------------------------- reply rules


def assert_motion_reply(reply: Message, group: int, sequence: int, command: int) -> None:
    # motoros1 §1.4: comm type 3 and reply type 1 whatever the result; data all zero.
    assert (reply.msg_type, reply.comm_type, reply.reply_type) == (2002, 3, 1)
    assert isinstance(reply.body, MotoMotionReply)
    assert (reply.body.group_no, reply.body.sequence, reply.body.command) == (
        group,
        sequence,
        command,
    )
    assert reply.body.data == (0.0,) * 10


def test_motion_reply_echoes_per_request_type() -> None:
    busy = Result.BUSY
    assert_motion_reply(replies.motion_reply(CTRL, 0, 0), 1, 3, Command.START_TRAJ_MODE)
    assert_motion_reply(replies.motion_reply(POINT, busy, 0), 1, 7, 14)
    assert_motion_reply(replies.motion_reply(EX_POINT, busy, 0), 2, 7, 2016)  # last group
    assert_motion_reply(replies.motion_reply(EX_POINT, busy, 0, group_no=0), 0, 7, 2016)
    tool = replies.select_tool(1, 64, 9)
    assert_motion_reply(replies.motion_reply(tool, 3, 3017), 1, 9, 2018)
    get_version = UnknownMessage(2, 2, 0, b"")
    assert_motion_reply(replies.motion_reply(get_version, 3, 3003), -1, -1, 2)
    assert_motion_reply(replies.motion_reply(replies.read_io_bit(1), 3, 3003), -1, -1, 2003)
    no_groups = Message(2016, 2, 0, JointTrajPtFullEx(4, ()))
    assert_motion_reply(replies.motion_reply(no_groups, 3, 3001), -1, 4, 2016)


def test_motion_reply_carries_result_and_subcode_as_plain_ints() -> None:
    reply = replies.motion_reply(POINT, Result.NOT_READY, NotReadySubcode.SERVO_OFF)
    assert isinstance(reply.body, MotoMotionReply)
    assert (reply.body.result, reply.body.subcode) == (5, 5006)
    assert all(type(v) is int for v in (reply.body.result, reply.body.subcode, reply.comm_type))


@pytest.mark.parametrize(
    ("error", "subcode", "command"),
    [
        (PeerProtocolError("short", InvalidSubcode.MSGSIZE, 14), 3001, 14),
        (PeerProtocolError("bad prefix", InvalidSubcode.MSGHEADER), 3002, 0),
        (UnknownMessage(11, 2, 0, b""), 3003, 11),
    ],
)
def test_invalid_reply(
    error: PeerProtocolError | UnknownMessage, subcode: int, command: int
) -> None:
    reply = replies.invalid_reply(error)
    assert_motion_reply(reply, -1, -1, command)
    assert isinstance(reply.body, MotoMotionReply)
    assert (reply.body.result, reply.body.subcode) == (3, subcode)


def test_io_error_reply_puts_result_and_subcode_first() -> None:
    reply = replies.io_error_reply(InvalidSubcode.MSGSIZE)
    assert (reply.msg_type, reply.comm_type, reply.reply_type) == (2002, 3, 2)
    assert reply.body == MotoMotionReply(3, 3001, 0, 0, 0, (0.0,) * 10)


@pytest.mark.parametrize(
    ("request_", "reply_type", "fields"),
    [
        (replies.read_io_bit(10010), 2004, {"value": 1, "result_code": 0}),
        (replies.write_io_bit(10010, 1), 2006, {"result_code": 0}),
        (replies.read_io_group(1001), 2008, {"value": 1, "result_code": 0}),
        (replies.write_io_group(1001, 255), 2010, {"result_code": 0}),
        (replies.read_mregister(1), 2012, {"value": 1, "result_code": 0}),
        (replies.write_mregister(1, 2), 2013, {"result_code": 0}),
    ],
)
def test_io_reply(request_: Message, reply_type: int, fields: dict[str, int]) -> None:
    ok = replies.io_reply(request_, IoResult.OK, value=1)
    assert (ok.msg_type, ok.comm_type, ok.reply_type) == (reply_type, 3, 1)
    assert msgspec.structs.asdict(ok.body) == fields
    failed = replies.io_reply(request_, IoResult.READ_ADDRESS_INVALID)
    result_code = msgspec.structs.asdict(failed.body)["result_code"]
    assert (failed.reply_type, result_code) == (2, 1001)
    assert type(result_code) is int
    assert encode(ok, ByteOrder.LITTLE, Role.CONTROLLER)


def test_io_reply_refuses_a_non_io_request() -> None:
    with pytest.raises(LocalProtocolError):
        replies.io_reply(POINT, 0)


def test_headers_of_built_messages() -> None:
    requests = [
        replies.ping(),
        CTRL,
        POINT,
        EX_POINT,
        replies.select_tool(0, 1),
        replies.get_dh_parameters(),
        replies.read_io_bit(1),
        replies.write_io_bit(1, 1),
        replies.read_io_group(1),
        replies.write_io_group(1, 1),
        replies.read_mregister(1),
        replies.write_mregister(1, 1),
    ]
    for request in requests:
        assert (request.comm_type, request.reply_type) == (CommType.SERVICE_REQUEST, 0)
        assert all(
            type(v) is int for v in (request.msg_type, request.comm_type, request.reply_type)
        )
        # Built messages are in wire shape: they equal what the controller decodes.
        assert decode_frames(
            encode(request, ByteOrder.BIG, Role.CLIENT), Role.CONTROLLER, ByteOrder.BIG
        ) == [request]
    status = replies.state_message(MsgType.ROBOT_STATUS, RobotStatus(1, 0, 0, 0, 0, 2, 1))
    assert (status.msg_type, status.comm_type, status.reply_type) == (
        13,
        CommType.TOPIC,
        ReplyType.INVALID,
    )
    assert type(status.msg_type) is int
    failed = replies.service_reply(MsgType.MOTO_GET_DH_PARAMETERS, Empty(), success=False)
    assert (failed.comm_type, failed.reply_type) == (3, 2)


def test_trajectory_builders_set_valid_fields_like_motoman_driver() -> None:
    assert isinstance(POINT.body, JointTrajPtFull)
    assert POINT.body.valid_fields == 0x07
    with_acc = replies.traj_point(0, 1, 0.1, JOINTS, JOINTS, accelerations=JOINTS)
    assert isinstance(with_acc.body, JointTrajPtFull)
    assert with_acc.body.valid_fields == 0x0F
    assert replies.ex_group(0, 0.1, JOINTS, JOINTS, accelerations=JOINTS).valid_fields == 0x0F
    with pytest.raises(LocalProtocolError):
        replies.traj_point(0, 1, 0.1, too_long(JOINTS), JOINTS)


def test_select_tool_body_order() -> None:
    assert replies.select_tool(1, 63, 7).body == SelectTool(group_no=1, tool=63, sequence=7)


def test_byte_order_prefixes() -> None:
    assert (ByteOrder.LITTLE.struct_prefix, ByteOrder.BIG.struct_prefix) == ("<", ">")
    assert ByteOrder("big") is ByteOrder.BIG
