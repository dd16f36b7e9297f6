"""A real FS100 (big-endian) session between motoman_driver and MotoROS decodes frame by frame.

Data: data/fs100-session.jsonl beside this file, one TCP segment per line, captured from a real
controller and kept verbatim (data/README.md says where it comes from and what it holds).
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import NamedTuple

import pytest

from motocell.shared.protocol.codec import NEED_DATA, ByteOrder, Role, SimpleMessageCodec, encode
from motocell.shared.protocol.constants import Command, CommType, MsgType, Result
from motocell.shared.protocol.messages import (
    JointFeedback,
    JointTrajPtFull,
    Message,
    MotoMotionCtrl,
    MotoMotionReply,
    RobotStatus,
    UnknownMessage,
)

SESSION_FILE = Path(__file__).parent / "data" / "fs100-session.jsonl"

MOTION_PORT, STATE_PORT = 50240, 50241


class Segment(NamedTuple):
    port: int
    to_controller: bool
    payload: bytes

    @property
    def receiver(self) -> Role:
        return Role.CONTROLLER if self.to_controller else Role.CLIENT

    @property
    def sender(self) -> Role:
        return Role.CLIENT if self.to_controller else Role.CONTROLLER


class Frame(NamedTuple):
    segment: Segment
    raw: bytes
    event: Message | UnknownMessage


@pytest.fixture(scope="module")
def segments() -> list[Segment]:
    with SESSION_FILE.open() as lines:
        records = [json.loads(line) for line in lines if line.strip()]
    return [
        Segment(r["port"], r["dir"] == "to_controller", bytes.fromhex(r["hex"])) for r in records
    ]


def split_by_prefix(payload: bytes) -> list[bytes]:
    """Frames cut by their big-endian length prefix, independently of the codec."""
    frames, at = [], 0
    while at < len(payload):
        (length,) = struct.unpack_from(">i", payload, at)
        frames.append(payload[at : at + 4 + length])
        at += 4 + length
    assert at == len(payload)
    return frames


@pytest.fixture(scope="module")
def frames(segments: list[Segment]) -> list[Frame]:
    """Each (port, direction) stream decoded by one codec, fed one segment at a time."""
    codecs: dict[tuple[int, bool], SimpleMessageCodec] = {}
    decoded: list[Frame] = []
    for segment in segments:
        key = (segment.port, segment.to_controller)
        codec = codecs.setdefault(key, SimpleMessageCodec(segment.receiver, ByteOrder.BIG))
        codec.receive_data(segment.payload)
        raws = split_by_prefix(segment.payload)
        events = []
        while (event := codec.next_event()) is not NEED_DATA:
            assert isinstance(event, Message | UnknownMessage)
            events.append(event)
        assert len(events) == len(raws)
        decoded += [Frame(segment, raw, event) for raw, event in zip(raws, events, strict=True)]
    assert all(codec.buffered_bytes == 0 for codec in codecs.values())
    return decoded


def messages(frames: list[Frame], port: int) -> list[Message]:
    found = [f.event for f in frames if f.segment.port == port]
    assert all(isinstance(m, Message) for m in found)
    return [m for m in found if isinstance(m, Message)]


def test_every_frame_decodes_to_a_known_message(
    segments: list[Segment], frames: list[Frame]
) -> None:
    assert len(frames) == sum(len(split_by_prefix(s.payload)) for s in segments) == 164
    assert not [f for f in frames if isinstance(f.event, UnknownMessage)]


def test_every_frame_reencodes_byte_for_byte(frames: list[Frame]) -> None:
    for frame in frames:
        assert encode(frame.event, ByteOrder.BIG, frame.segment.sender) == frame.raw


def test_state_port_sends_feedback_and_status(frames: list[Frame]) -> None:
    state = messages(frames, STATE_PORT)
    assert {m.msg_type for m in state} == {MsgType.JOINT_FEEDBACK, MsgType.ROBOT_STATUS}
    for m in state:
        assert (m.comm_type, m.reply_type) == (CommType.TOPIC, 0)
        if isinstance(m.body, RobotStatus):
            # MotoROS sends 2 in PLAY, not the 2012 spec's 0 (docs/behaviour.md): this capture.
            assert m.body.mode == 2
            assert (m.body.drives_powered, m.body.e_stopped, m.body.in_error) == (1, 0, 0)
        else:
            assert isinstance(m.body, JointFeedback)
            # This MotoROS predates velocity feedback: position only, time never filled
            # (motoros1 §6).
            assert (m.body.group_no, m.body.valid_fields, m.body.time) == (0, 2, 0.0)
            assert m.body.positions[7:] == (0.0,) * 3  # a 7-axis arm: slots 7..9 unused
            assert m.body.velocities == (0.0,) * 10


def test_start_point_is_the_fed_back_position(frames: list[Frame]) -> None:
    """motoman_driver requires point 0 to match joint_states, which comes from JOINT_FEEDBACK."""
    start = next(f for f in frames if isinstance(f.event.body, JointTrajPtFull))
    before = frames[: frames.index(start)]
    feedback = [f.event.body for f in before if isinstance(f.event.body, JointFeedback)]
    assert isinstance(start.event.body, JointTrajPtFull)
    assert start.event.body.sequence == 0
    assert start.event.body.positions == feedback[-1].positions


def test_every_motion_request_is_answered_in_order(frames: list[Frame]) -> None:
    motion = messages(frames, MOTION_PORT)
    requests, replies = motion[0::2], motion[1::2]
    assert len(requests) == len(replies) == 60
    for request, reply in zip(requests, replies, strict=True):
        assert (request.comm_type, request.reply_type) == (CommType.SERVICE_REQUEST, 0)
        assert (reply.msg_type, reply.comm_type, reply.reply_type) == (2002, 3, 1)
        assert isinstance(reply.body, MotoMotionReply)
        if isinstance(request.body, JointTrajPtFull):
            assert request.body.valid_fields == 0x0F  # MoveIt supplied accelerations
            assert (reply.body.sequence, reply.body.command) == (request.body.sequence, 14)
        else:
            assert isinstance(request.body, MotoMotionCtrl)
            assert (reply.body.sequence, reply.body.command) == (0, request.body.command)
    first_ctrl = replies[0].body
    assert isinstance(first_ctrl, MotoMotionReply)
    assert first_ctrl.command == Command.CHECK_MOTION_READY
    assert (first_ctrl.result, first_ctrl.subcode) == (Result.FALSE, 0)


def test_busy_points_are_resent_with_the_same_sequence(frames: list[Frame]) -> None:
    motion = messages(frames, MOTION_PORT)
    busy = 0
    for reply, next_request in zip(motion[1::2], motion[2::2], strict=False):
        assert isinstance(reply.body, MotoMotionReply)
        if reply.body.result == Result.BUSY:
            busy += 1
            assert isinstance(next_request.body, JointTrajPtFull)
            assert next_request.body.sequence == reply.body.sequence
    assert busy > 0
