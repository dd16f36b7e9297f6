"""The test kit's Simple Message client against a controller of the other byte order: it stops
at the first frame and names the byte order the controller speaks, on either port."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest

from motocell.shared.protocol.codec import ByteOrder, Role, encode
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import RobotStatus
from motocell.shared.protocol.replies import motion_ctrl, motion_reply, state_message
from motocell.testing.client import FrameReader, MotionClient, StateListener, WrongByteOrderError

STATUS = state_message(13, RobotStatus(1, 0, 0, 0, 0, 2, 1))


@pytest.fixture
def listener() -> Iterator[socket.socket]:
    with socket.create_server(("127.0.0.1", 0)) as server:
        yield server


def test_a_big_endian_state_port_is_named_at_once(listener: socket.socket) -> None:
    port = listener.getsockname()[1]
    with StateListener("127.0.0.1", port, ByteOrder.LITTLE).start() as state:
        controller, _ = listener.accept()
        with controller:
            controller.sendall(encode(STATUS, ByteOrder.BIG, Role.CONTROLLER) * 3)
            with pytest.raises(WrongByteOrderError) as refused:
                state.wait_for(lambda f: True, timeout=60.0)
    assert refused.value.byte_order is ByteOrder.BIG
    assert "looks big-endian" in str(refused.value)


def test_a_little_endian_motion_port_is_named_to_a_big_endian_client(
    listener: socket.socket,
) -> None:
    port = listener.getsockname()[1]
    with MotionClient("127.0.0.1", port, ByteOrder.BIG) as motion:
        controller, _ = listener.accept()
        with controller:
            request = motion_ctrl(Command.CHECK_MOTION_READY)
            reply = motion_reply(request, Result.SUCCESS, 0)
            controller.sendall(encode(reply, ByteOrder.LITTLE, Role.CONTROLLER))
            with pytest.raises(WrongByteOrderError) as refused:
                motion.command(Command.CHECK_MOTION_READY)
    assert refused.value.byte_order is ByteOrder.LITTLE


def test_garbage_after_good_frames_is_not_blamed_on_the_byte_order() -> None:
    ours, theirs = socket.socketpair()
    with ours, theirs:
        reader = FrameReader(ours, ByteOrder.LITTLE)
        theirs.sendall(
            encode(STATUS, ByteOrder.LITTLE, Role.CONTROLLER)
            + encode(STATUS, ByteOrder.BIG, Role.CONTROLLER)
        )
        assert reader.next() == STATUS
        with pytest.raises(PeerProtocolError) as refused:
            reader.next()
    assert not isinstance(refused.value, WrongByteOrderError)
