"""The ROS 2 face's way into the gateway (``FacePort``) on a scripted bus: each query's one
Simple Message frame is answered as the motion port answers it, by a handler of the face's own;
M-registers by the I/O port's handler; bad queries get the motion port's error reply; and when
the face's process goes, its motion stops."""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import pytest

from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.core.robot_io import RobotIoHandler
from motocell.services.gateway.core.sources import Source
from motocell.services.gateway.face_port import FacePort
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, MotionRequest, MotionResponse, encode
from motocell.shared.protocol.codec import ByteOrder, Role, decode_frames
from motocell.shared.protocol.codec import encode as encode_frame
from motocell.shared.protocol.constants import Command, InvalidSubcode, Result
from motocell.shared.protocol.messages import Message, MotoMotionReply, ReadMRegisterReply
from motocell.shared.protocol.replies import motion_ctrl, read_mregister
from motocell.testing.processes import wait_until
from tests.services.gateway.core.fake_cell import SYNC_SEED, FakeCell, one_group
from tests.services.gateway.fake_bus import FakeBus

KEYS = CellKeys("cell1")
MOTION_KEY = KEYS.gateway_cmd("motion")
FACE_TOKEN = KEYS.alive("ros2", "0")
WAIT_S = 10.0
"""For the face's thread to answer: a bound for a hang, not a speed."""
_response = Decoder(MotionResponse)


@pytest.fixture
def port() -> Iterator[tuple[FacePort, FakeBus, FakeCell]]:
    bus, cell = FakeBus(), FakeCell(1).ready()
    io = RobotIoHandler(cell)
    motion = MotionHandler(one_group(), cell, io, itertools.count(SYNC_SEED), Source.ROS2)
    face_port = FacePort(bus, KEYS, ByteOrder.LITTLE, motion, io)
    face_port.start()
    yield face_port, bus, cell
    face_port.close()


def ask(bus: FakeBus, payload: bytes) -> bytes:
    answers = bus.ask(MOTION_KEY, payload)
    wait_until(lambda: bool(answers), WAIT_S, "the face's thread to answer")
    return _response.decode(answers[0]).frame


def ask_frame(bus: FakeBus, request: Message) -> Message:
    frame = ask(bus, encode(MotionRequest(encode_frame(request, ByteOrder.LITTLE, Role.CLIENT))))
    (reply,) = decode_frames(frame, Role.CLIENT, ByteOrder.LITTLE)
    assert isinstance(reply, Message)
    return reply


def test_a_command_is_answered_as_the_motion_port_answers_it(
    port: tuple[FacePort, FakeBus, FakeCell],
) -> None:
    _, bus, cell = port
    reply = ask_frame(bus, motion_ctrl(Command.START_TRAJ_MODE)).body
    assert isinstance(reply, MotoMotionReply) and reply.result == Result.SUCCESS
    assert cell.verbs("controller") == ["start_traj_mode"]
    assert cell.state.sources.holder is Source.ROS2


def test_m_registers_are_the_io_ports_to_answer(port: tuple[FacePort, FakeBus, FakeCell]) -> None:
    _, bus, _ = port
    assert isinstance(ask_frame(bus, read_mregister(5)).body, ReadMRegisterReply)


@pytest.mark.parametrize("payload", [b"garbage", encode(MotionRequest(b"\x00\x01"))])
def test_a_query_that_is_not_one_frame_gets_the_motion_ports_error_reply(
    port: tuple[FacePort, FakeBus, FakeCell], payload: bytes
) -> None:
    _, bus, _ = port
    (reply,) = decode_frames(ask(bus, payload), Role.CLIENT, ByteOrder.LITTLE)
    body = reply.body
    assert isinstance(body, MotoMotionReply) and body.result == Result.INVALID
    assert body.subcode == InvalidSubcode.MSGSIZE
    # The thread goes on answering.
    assert isinstance(ask_frame(bus, motion_ctrl(Command.CHECK_MOTION_READY)).body, MotoMotionReply)


def test_when_the_face_goes_its_motion_stops(port: tuple[FacePort, FakeBus, FakeCell]) -> None:
    _, bus, cell = port
    ask_frame(bus, motion_ctrl(Command.START_TRAJ_MODE))
    (tokens,) = [made for made in bus.tokens_made if made.key == FACE_TOKEN]
    tokens.appear(FACE_TOKEN)
    tokens.vanish(FACE_TOKEN)
    wait_until(lambda: cell.state.sources.holder is None, WAIT_S, "the face to give it up")
    assert cell.verbs("executor") == ["stop"]
