"""Hypothesis: any bytes in any chunking decode or raise PeerProtocolError, within a bounded
buffer; every valid message round-trips in both byte orders and directions; and every group,
sequence and count field of 2016 and 2017 decodes as written or is refused (3001 on receipt,
LocalProtocolError on sending), whatever it says."""

from __future__ import annotations

import itertools
import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from motocell.shared.protocol.codec import (
    NEED_DATA,
    ByteOrder,
    Closed,
    Event,
    NeedData,
    Role,
    SimpleMessageCodec,
    decode_frames,
    encode,
)
from motocell.shared.protocol.constants import MAX_GROUPS, InvalidSubcode, MsgType
from motocell.shared.protocol.errors import LocalProtocolError, PeerProtocolError
from motocell.shared.protocol.layouts import (
    JOINT_BLOCK,
    JOINT_BLOCK_SIZE,
    LAYOUTS,
    Direction,
    max_body_size,
)
from motocell.shared.protocol.messages import (
    Body,
    DhLink,
    Empty,
    GetDhParametersReply,
    JointFeedback,
    JointFeedbackEx,
    JointTrajPtExGroup,
    JointTrajPtFull,
    JointTrajPtFullEx,
    Message,
    MotoMotionCtrl,
    MotoMotionReply,
    ReadIOBit,
    ReadIOBitReply,
    ReadIOGroup,
    ReadIOGroupReply,
    ReadMRegister,
    ReadMRegisterReply,
    RobotStatus,
    SelectTool,
    UnknownMessage,
    WriteIOBit,
    WriteIOBitReply,
    WriteIOGroup,
    WriteIOGroupReply,
    WriteMRegister,
    WriteMRegisterReply,
)

roles = st.sampled_from(list(Role))
orders = st.sampled_from(list(ByteOrder))

# ------------------------------------------------------------------------------ valid messages

i32 = st.integers(-(2**31), 2**31 - 1)
u32 = st.integers(0, 2**32 - 1)
f32 = st.floats(width=32, allow_nan=False)
joints = st.tuples(*[f32] * 10)
feedback = st.builds(JointFeedback, i32, i32, f32, joints, joints, joints)
ex_group = st.builds(JointTrajPtExGroup, i32, i32, f32, joints, joints, joints)
dh_group = st.tuples(*[st.builds(DhLink, f32, f32, f32, f32)] * 8)

BODIES: dict[type, st.SearchStrategy[Body]] = {
    Empty: st.just(Empty()),
    RobotStatus: st.builds(RobotStatus, i32, i32, i32, i32, i32, i32, i32),
    JointTrajPtFull: st.builds(JointTrajPtFull, i32, i32, i32, f32, joints, joints, joints),
    JointFeedback: feedback,
    MotoMotionCtrl: st.builds(MotoMotionCtrl, i32, i32, i32, joints),
    MotoMotionReply: st.builds(MotoMotionReply, i32, i32, i32, i32, i32, joints),
    ReadIOBit: st.builds(ReadIOBit, u32),
    ReadIOBitReply: st.builds(ReadIOBitReply, u32, i32),
    WriteIOBit: st.builds(WriteIOBit, u32, u32),
    WriteIOBitReply: st.builds(WriteIOBitReply, i32),
    ReadIOGroup: st.builds(ReadIOGroup, u32),
    ReadIOGroupReply: st.builds(ReadIOGroupReply, u32, i32),
    WriteIOGroup: st.builds(WriteIOGroup, u32, u32),
    WriteIOGroupReply: st.builds(WriteIOGroupReply, i32),
    ReadMRegister: st.builds(ReadMRegister, u32),
    ReadMRegisterReply: st.builds(ReadMRegisterReply, u32, i32),
    WriteMRegister: st.builds(WriteMRegister, u32, u32),
    WriteMRegisterReply: st.builds(WriteMRegisterReply, i32),
    JointTrajPtFullEx: st.builds(
        JointTrajPtFullEx, i32, st.lists(ex_group, min_size=1, max_size=4).map(tuple)
    ),
    JointFeedbackEx: st.builds(JointFeedbackEx, i32, st.tuples(*[feedback] * 4)),
    SelectTool: st.builds(SelectTool, i32, i32, i32),
    GetDhParametersReply: st.builds(GetDhParametersReply, st.tuples(*[dh_group] * 4)),
}

SENDER = {Direction.TO_CONTROLLER: Role.CLIENT, Direction.TO_CLIENT: Role.CONTROLLER}
RECEIVER = {Direction.TO_CONTROLLER: Role.CONTROLLER, Direction.TO_CLIENT: Role.CLIENT}


@st.composite
def sent_messages(
    draw: st.DrawFn, towards: Direction | None = None
) -> tuple[Direction, Message | UnknownMessage]:
    """A message that one side may send, in the shape the other side decodes."""
    layouts = [(k, v) for k, v in LAYOUTS.items() if towards in (None, k[0])]
    (direction, msg_type), layout = draw(st.sampled_from(layouts))
    if draw(st.integers(0, 9)) == 0:
        unknown = draw(i32.filter(lambda t: (direction, t) not in LAYOUTS))
        body = draw(st.binary(max_size=max_body_size(direction)))
        return direction, UnknownMessage(unknown, draw(i32), draw(i32), body)
    return direction, Message(msg_type, draw(i32), draw(i32), draw(BODIES[layout.body_type]))


@given(sent_messages(), orders)
def test_valid_messages_round_trip(
    sent: tuple[Direction, Message | UnknownMessage], order: ByteOrder
) -> None:
    direction, message = sent
    data = encode(message, order, SENDER[direction])
    assert decode_frames(data, RECEIVER[direction], order) == [message]


# ------------------------------------------------------------------------------ hostile input


def frame_bytes(msg_type: int, body: bytes, order: ByteOrder, length: int | None = None) -> bytes:
    prefix = 12 + len(body) if length is None else length
    return struct.pack(order.struct_prefix + "4i", prefix, msg_type, 2, 0) + body


@st.composite
def hostile_streams(draw: st.DrawFn, order: ByteOrder) -> bytes:
    """Valid frames, known types with random bodies, bad prefixes and raw noise, mixed."""
    parts = []
    for _ in range(draw(st.integers(0, 6))):
        kind = draw(st.integers(0, 3))
        if kind == 0:
            direction, message = draw(sent_messages())
            parts.append(encode(message, order, SENDER[direction]))
        elif kind == 1:
            msg_type = draw(st.sampled_from(sorted({t for _, t in LAYOUTS})) | i32)
            parts.append(frame_bytes(msg_type, draw(st.binary(max_size=600)), order))
        elif kind == 2:
            length = draw(st.integers(-(2**31), 2**31 - 1))
            parts.append(frame_bytes(draw(i32), draw(st.binary(max_size=64)), order, length))
        else:
            parts.append(draw(st.binary(max_size=64)))
    return b"".join(parts)


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    edges = [0, *sorted(set(cuts)), len(data)]
    return [data[a:b] for a, b in itertools.pairwise(edges) if b > a]


def run(codec: SimpleMessageCodec, chunks: list[bytes]) -> list[Event | PeerProtocolError]:
    """Feeds each chunk and drains, checking event types and the buffer bound throughout."""
    out: list[Event | PeerProtocolError] = []
    bound = codec.max_frame_size - 1
    for chunk in [*chunks, b""]:
        codec.receive_data(chunk)
        # The stated bound: less than one frame left over plus the latest read. _buf is checked
        # directly because it is the memory held, consumed bytes included.
        if chunk:
            bound = codec.max_frame_size - 1 + len(chunk)
        while True:
            assert len(codec._buf) <= bound
            assert codec.buffered_bytes <= bound
            pending = codec.buffered_bytes
            try:
                event = codec.next_event()
            except PeerProtocolError as error:
                assert codec.buffered_bytes < pending  # every error consumes bytes: no livelock
                out.append(error)
                continue
            assert isinstance(event, Message | UnknownMessage | NeedData | Closed)
            if isinstance(event, NeedData | Closed):
                break
            out.append(event)
    assert codec.next_event() is not NEED_DATA
    return out


@given(st.binary(max_size=3000), roles, orders, st.lists(st.integers(0, 3000), max_size=20))
def test_any_bytes_in_any_chunking(
    data: bytes, role: Role, order: ByteOrder, cuts: list[int]
) -> None:
    for chunks in ([data], chunked(data, cuts), [data[i : i + 1] for i in range(len(data))]):
        run(SimpleMessageCodec(role, order), chunks)


@given(st.data(), roles, orders)
def test_hostile_streams_in_any_chunking(data: st.DataObject, role: Role, order: ByteOrder) -> None:
    stream = data.draw(hostile_streams(order))
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=20))
    for chunks in (
        [stream],
        chunked(stream, cuts),
        [stream[i : i + 1] for i in range(len(stream))],
    ):
        run(SimpleMessageCodec(role, order), chunks)


@given(st.data(), orders)
def test_valid_streams_decode_the_same_in_any_chunking(
    data: st.DataObject, order: ByteOrder
) -> None:
    direction = data.draw(st.sampled_from(list(Direction)))
    sent = data.draw(st.lists(sent_messages(direction), max_size=8))
    stream = b"".join(encode(m, order, SENDER[direction]) for _, m in sent)
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=20))
    expected = [m for _, m in sent]
    for chunks in (
        [stream],
        chunked(stream, cuts),
        [stream[i : i + 1] for i in range(len(stream))],
    ):
        assert run(SimpleMessageCodec(RECEIVER[direction], order), chunks) == expected


# ---------------------------------------------------------------------- 2016 and 2017 fields

group_numbers = st.integers(-2, MAX_GROUPS + 1) | st.sampled_from([-(2**31), 2**31 - 1]) | i32
group_counts = st.integers(-2, MAX_GROUPS + 2) | st.sampled_from([-(2**31), 2**31 - 1]) | i32
FULL_EX = 8 + MAX_GROUPS * JOINT_BLOCK_SIZE
"""2016's body padded to 4 groups."""


def joint_block(order: ByteOrder, group: int, valid: int, time: float) -> bytes:
    return struct.pack(order.struct_prefix + JOINT_BLOCK, group, valid, time, *[0.0] * 30)


@given(
    group_counts,
    i32,
    st.lists(st.tuples(group_numbers, i32, f32), max_size=MAX_GROUPS),
    st.booleans(),
    orders,
)
def test_2016_decodes_its_count_sequence_and_groups_or_is_3001(
    count: int, sequence: int, blocks: list[tuple[int, int, float]], padded: bool, order: ByteOrder
) -> None:
    body = struct.pack(order.struct_prefix + "2i", count, sequence)
    body += b"".join(joint_block(order, *b) for b in blocks)
    if padded:
        body = body.ljust(FULL_EX, b"\0")
    data = frame_bytes(MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX, body, order)
    if not 1 <= count <= MAX_GROUPS or len(body) not in (8 + count * JOINT_BLOCK_SIZE, FULL_EX):
        with pytest.raises(PeerProtocolError) as refused:
            decode_frames(data, Role.CONTROLLER, order)
        assert refused.value.subcode == InvalidSubcode.MSGSIZE
        assert refused.value.msg_type == MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX
        return
    [message] = decode_frames(data, Role.CONTROLLER, order)
    assert isinstance(message, Message)
    decoded = message.body
    assert isinstance(decoded, JointTrajPtFullEx)
    assert decoded.sequence == sequence
    padding = [(0, 0, 0.0)] * MAX_GROUPS
    expected = [*blocks, *padding][:count]
    assert [(g.group_no, g.valid_fields) for g in decoded.groups] == [b[:2] for b in expected]


@given(group_counts, st.lists(st.tuples(group_numbers, i32, f32), max_size=6), orders, roles)
def test_2017_decodes_its_count_and_4_slots_whatever_they_say(
    count: int, slots: list[tuple[int, int, float]], order: ByteOrder, role: Role
) -> None:
    body = struct.pack(order.struct_prefix + "i", count)
    body += b"".join(joint_block(order, *s) for s in slots)
    data = frame_bytes(MsgType.MOTO_JOINT_FEEDBACK_EX, body, order)
    if len(slots) != MAX_GROUPS:
        with pytest.raises(PeerProtocolError) as refused:
            decode_frames(data, role, order)
        assert refused.value.subcode == InvalidSubcode.MSGSIZE
        return
    [message] = decode_frames(data, role, order)
    assert isinstance(message, Message)
    decoded = message.body
    assert isinstance(decoded, JointFeedbackEx)
    assert decoded.number_of_valid_groups == count
    assert [(s.group_no, s.valid_fields) for s in decoded.groups] == [s[:2] for s in slots]


@given(
    st.integers(-(2**40), 2**40),
    st.lists(
        st.builds(
            JointTrajPtExGroup, st.integers(-(2**40), 2**40), i32, f32, joints, joints, joints
        ),
        max_size=6,
    ),
    orders,
)
def test_2016_encodes_1_to_4_groups_of_int32_fields_or_refuses(
    sequence: int, groups: list[JointTrajPtExGroup], order: ByteOrder
) -> None:
    message = Message(
        MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX, 2, 0, JointTrajPtFullEx(sequence, tuple(groups))
    )
    fits = all(-(2**31) <= n < 2**31 for n in (sequence, *(g.group_no for g in groups)))
    if not 1 <= len(groups) <= MAX_GROUPS or not fits:
        with pytest.raises(LocalProtocolError):
            encode(message, order, Role.CLIENT)
        return
    assert decode_frames(encode(message, order, Role.CLIENT), Role.CONTROLLER, order) == [message]


@given(st.integers(-(2**40), 2**40), st.lists(feedback, max_size=6), orders)
def test_2017_encodes_up_to_4_slots_and_an_int32_count_or_refuses(
    count: int, slots: list[JointFeedback], order: ByteOrder
) -> None:
    message = Message(MsgType.MOTO_JOINT_FEEDBACK_EX, 1, 0, JointFeedbackEx(count, tuple(slots)))
    if len(slots) > MAX_GROUPS or not -(2**31) <= count < 2**31:
        with pytest.raises(LocalProtocolError):
            encode(message, order, Role.CONTROLLER)
        return
    [decoded] = decode_frames(encode(message, order, Role.CONTROLLER), Role.CLIENT, order)
    assert isinstance(decoded, Message) and isinstance(decoded.body, JointFeedbackEx)
    assert decoded.body.number_of_valid_groups == count
    assert decoded.body.groups[: len(slots)] == tuple(slots)
