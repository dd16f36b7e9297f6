"""The test kit's Simple Message client against a controller of the other byte order: it stops
at the first frame and names the byte order the controller speaks, on either port; and how it
connects to a port that may not listen yet."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest

from motocell.shared.protocol.codec import ByteOrder, Role, encode
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import RobotStatus
from motocell.shared.protocol.replies import motion_ctrl, motion_reply, state_message
from motocell.testing import client
from motocell.testing.client import (
    FrameReader,
    MotionClient,
    StateListener,
    WrongByteOrderError,
    connect_once_listening,
)

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


def test_a_client_once_listening_makes_one_connection(listener: socket.socket) -> None:
    port = listener.getsockname()[1]
    with MotionClient.once_listening("127.0.0.1", port, ByteOrder.LITTLE, timeout=60.0) as motion:
        controller, peer = listener.accept()
        with controller:
            assert peer == motion.sock.getsockname()
            listener.setblocking(False)
            with pytest.raises(BlockingIOError):  # no probe before it
                listener.accept()


def test_a_refused_connection_is_tried_again(
    listener: socket.socket, monkeypatch: pytest.MonkeyPatch
) -> None:
    port = listener.getsockname()[1]
    tries: list[int] = []
    real = client.connect

    def refused_first(host: str, port: int, timeout: float = 5.0) -> socket.socket:
        tries.append(port)
        if len(tries) == 1:
            raise ConnectionRefusedError
        return real(host, port, timeout)

    monkeypatch.setattr(client, "connect", refused_first)
    monkeypatch.setattr(client, "LISTEN_POLL_S", 0.0)
    with connect_once_listening("127.0.0.1", port, timeout=60.0) as sock:
        assert sock.getpeername() == ("127.0.0.1", port)
    assert tries == [port, port]


def test_nothing_listening_is_a_timeout() -> None:
    with socket.socket() as bound:  # bound, not listening: a connection is refused
        bound.bind(("127.0.0.1", 0))
        with pytest.raises(TimeoutError, match="nothing listened"):
            connect_once_listening("127.0.0.1", bound.getsockname()[1], timeout=0.0)
