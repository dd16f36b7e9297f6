"""The state port's frames (motoros1 §6), read back by a client's codec: JOINT_FEEDBACK per group,
JOINT_FEEDBACK_EX with 2+ groups, then ROBOT_STATUS; all as topics (comm type 1)."""

from __future__ import annotations

import pytest

from motocell.services.broadcaster.core.frames import FEEDBACK_FIELDS, state_frames
from motocell.shared.bus.schemas import GroupState, RobotStatusFields, State
from motocell.shared.protocol.codec import NEED_DATA, ByteOrder, Role, SimpleMessageCodec, encode
from motocell.shared.protocol.constants import CommType, MsgType, ReplyType
from motocell.shared.protocol.messages import JointFeedback, JointFeedbackEx, Message, RobotStatus
from motocell.shared.protocol.replies import state_message

STATUS = RobotStatusFields(
    drives_powered=1,
    e_stopped=0,
    error_code=4321,
    in_error=1,
    in_motion=1,
    mode=2,
    motion_possible=0,
)
ZEROS = (0.0,) * 10


def group(index: int, axes: int = 6) -> GroupState:
    # Exact in float32, as the wire carries them.
    positions = [index + axis / 8 for axis in range(axes)]
    velocities = [-(index + axis / 64) for axis in range(axes)]
    return GroupState(index, positions, velocities, command_positions=positions)


def state(*groups: GroupState) -> State:
    return State(seq=1, tick=2, tick_ns=3, groups=list(groups), status=STATUS)


def read_back(data: bytes, byte_order: ByteOrder = ByteOrder.LITTLE) -> list[Message]:
    codec = SimpleMessageCodec(Role.CLIENT, byte_order)
    codec.receive_data(data)
    messages = []
    while (event := codec.next_event()) is not NEED_DATA:
        assert isinstance(event, Message)
        messages.append(event)
    return messages


def feedback(g: GroupState) -> JointFeedback:
    pad = (0.0,) * (10 - len(g.positions))
    return JointFeedback(
        g.group_no,
        FEEDBACK_FIELDS,
        0.0,
        (*g.positions, *pad),
        (*g.velocities, *pad),
        ZEROS,
    )


ROBOT_STATUS = RobotStatus(1, 0, 4321, 1, 1, 2, 0)


def test_one_group_sends_its_feedback_and_the_robot_status() -> None:
    arm = group(0)
    messages = read_back(b"".join(state_frames(state(arm), ByteOrder.LITTLE)))
    assert [m.msg_type for m in messages] == [MsgType.JOINT_FEEDBACK, MsgType.ROBOT_STATUS]
    assert messages[0].body == feedback(arm)
    assert messages[1].body == ROBOT_STATUS


def test_feedback_carries_positions_and_velocities() -> None:
    messages = read_back(b"".join(state_frames(state(group(0)), ByteOrder.LITTLE)))
    body = messages[0].body
    assert isinstance(body, JointFeedback)
    assert body.valid_fields == 6
    assert body.time == 0.0


def test_every_message_is_a_topic() -> None:
    messages = read_back(b"".join(state_frames(state(group(0), group(1)), ByteOrder.LITTLE)))
    assert {(m.comm_type, m.reply_type) for m in messages} == {(CommType.TOPIC, ReplyType.INVALID)}


@pytest.mark.parametrize("count", [2, 3, 4])
def test_several_groups_add_the_combined_feedback(count: int) -> None:
    groups = [group(index, axes=6 if index % 2 == 0 else 1) for index in range(count)]
    messages = read_back(b"".join(state_frames(state(*groups), ByteOrder.LITTLE)))
    assert [m.msg_type for m in messages] == [
        *[MsgType.JOINT_FEEDBACK] * count,
        MsgType.MOTO_JOINT_FEEDBACK_EX,
        MsgType.ROBOT_STATUS,
    ]
    assert [m.body for m in messages[:count]] == [feedback(g) for g in groups]
    combined = messages[count].body
    assert isinstance(combined, JointFeedbackEx)
    assert combined.number_of_valid_groups == count
    assert list(combined.groups[:count]) == [feedback(g) for g in groups]
    assert messages[-1].body == ROBOT_STATUS


def test_big_endian_frames_read_back_the_same() -> None:
    two = state(group(0), group(1))
    little = read_back(b"".join(state_frames(two, ByteOrder.LITTLE)))
    big_bytes = state_frames(two, ByteOrder.BIG)
    assert big_bytes != state_frames(two, ByteOrder.LITTLE)
    assert read_back(b"".join(big_bytes), ByteOrder.BIG) == little


def test_every_frame_is_one_whole_message() -> None:
    """Each is written on its own, so each must decode alone (one message per ``recv``)."""
    frames = state_frames(state(group(0), group(1)), ByteOrder.LITTLE)
    assert [len(read_back(frame)) for frame in frames] == [1, 1, 1, 1]


@pytest.mark.parametrize("byte_order", list(ByteOrder))
@pytest.mark.parametrize("groups", [1, 2, 3, 4])
def test_the_frames_are_the_codecs_own_encoding(byte_order: ByteOrder, groups: int) -> None:
    """The broadcaster packs its frames with precompiled structs; byte for byte they are what
    the protocol's codec encodes for the same messages."""
    given = state(*(group(index, axes=(6, 7, 2, 1)[index]) for index in range(groups)))
    blocks = [feedback(g) for g in given.groups]
    messages = [state_message(MsgType.JOINT_FEEDBACK, block) for block in blocks]
    if groups >= 2:
        messages.append(
            state_message(MsgType.MOTO_JOINT_FEEDBACK_EX, JointFeedbackEx(groups, tuple(blocks)))
        )
    messages.append(state_message(MsgType.ROBOT_STATUS, ROBOT_STATUS))
    assert state_frames(given, byte_order) == tuple(
        encode(message, byte_order, Role.CONTROLLER) for message in messages
    )
