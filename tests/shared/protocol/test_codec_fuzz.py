"""Hypothesis: any bytes in any chunking decode or raise PeerProtocolError, within a bounded
buffer; and every valid message round-trips in both byte orders and directions."""

from __future__ import annotations

import itertools
import struct

from hypothesis import given, settings
from hypothesis import strategies as st

from shared.protocol.codec import (
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
from shared.protocol.errors import PeerProtocolError
from shared.protocol.layouts import LAYOUTS, Direction, max_body_size
from shared.protocol.messages import (
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

FUZZ = settings(max_examples=150, deadline=None)

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


@FUZZ
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


@FUZZ
@given(st.binary(max_size=3000), roles, orders, st.lists(st.integers(0, 3000), max_size=20))
def test_any_bytes_in_any_chunking(
    data: bytes, role: Role, order: ByteOrder, cuts: list[int]
) -> None:
    for chunks in ([data], chunked(data, cuts), [data[i : i + 1] for i in range(len(data))]):
        run(SimpleMessageCodec(role, order), chunks)


@FUZZ
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


@FUZZ
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
