"""The motion and I/O ports' shells on scripted sockets (as httpcore tests its connections on a
mock network): frames split across reads or packed into one, a peer that closes mid-frame or
resets, garbage, a client that does not read its replies, take-over, and the threads each
server starts and joins. One test runs the real listener on loopback."""

from __future__ import annotations

import queue
import socket
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import pytest

from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.core.response import Response
from motocell.services.gateway.tcp import (
    RECV_BYTES,
    RequestServer,
    SocketListener,
    Stream,
    serve_requests,
)
from motocell.shared.protocol.codec import NEED_DATA, ByteOrder, Role, SimpleMessageCodec, encode
from motocell.shared.protocol.constants import Command, InvalidSubcode, Result
from motocell.shared.protocol.messages import Message, MotoMotionReply, UnknownMessage
from motocell.shared.protocol.replies import motion_ctrl, motion_reply
from motocell.shared.service import listen

ORDER = ByteOrder.LITTLE
WAIT_S = 5.0
"""Deadline for what another thread is expected to do soon (generous for a loaded host)."""


def request(sequence: int) -> bytes:
    """One MOTO_MOTION_CTRL frame as a client sends it, numbered by its sequence."""
    return encode(motion_ctrl(Command.CHECK_QUEUE_CNT, 0, sequence), ORDER, Role.CLIENT)


REQUEST_BYTES = len(request(0))


@dataclass
class Responder:
    """Answers every request SUCCESS with its sequence echoed; counts what it was asked."""

    seen: list[int] = field(default_factory=list)
    then: list[int] = field(default_factory=list)
    """Sequences whose after-reply action ran (a point's publication)."""
    close_on: int | None = None

    def __call__(self, message: Message | UnknownMessage) -> Response:
        assert isinstance(message, Message)
        sequence = message.body.sequence  # type: ignore[union-attr]
        self.seen.append(sequence)
        return Response(
            motion_reply(message, Result.SUCCESS, 0),
            close=sequence == self.close_on,
            then=lambda: self.then.append(sequence),
        )


def replies(data: bytes) -> list[MotoMotionReply]:
    codec = SimpleMessageCodec(Role.CLIENT, ORDER)
    codec.receive_data(data)
    found = []
    while (event := codec.next_event()) is not NEED_DATA:
        assert isinstance(event, Message)
        assert isinstance(event.body, MotoMotionReply)
        found.append(event.body)
    return found


class ScriptedStream:
    """A socket whose peer is a script: each item is what one ``recv`` returns (an exception
    is raised instead); once the script is out, the peer has closed. Writes are kept."""

    def __init__(self, *reads: bytes | OSError, send_error: OSError | None = None) -> None:
        self.reads = list(reads)
        self.sent = bytearray()
        self.send_error = send_error
        self.closed = False

    def recv(self, size: int, flags: int = 0, /) -> bytes:
        if not self.reads:
            return b""
        item = self.reads.pop(0)
        if isinstance(item, OSError):
            raise item
        assert len(item) <= size
        return item

    def sendall(self, data: bytes, /) -> None:
        if self.send_error is not None:
            raise self.send_error
        self.sent += data

    def shutdown(self, how: int, /) -> None:
        pass

    def close(self) -> None:
        self.closed = True


def serve(stream: ScriptedStream, responder: Responder) -> list[MotoMotionReply]:
    serve_requests(stream, ORDER, responder, MotionHandler.error_reply)
    return replies(bytes(stream.sent))


# -- framing -----------------------------------------------------------------------------
def test_a_frame_read_byte_by_byte_is_answered_once() -> None:
    frame = request(7)
    responder = Responder()
    answered = serve(ScriptedStream(*(frame[k : k + 1] for k in range(len(frame)))), responder)
    assert [reply.sequence for reply in answered] == [7]
    assert responder.seen == [7]


@pytest.mark.parametrize("cut", range(1, REQUEST_BYTES))
def test_a_frame_split_anywhere_is_answered_once(cut: int) -> None:
    frame = request(3)
    answered = serve(ScriptedStream(frame[:cut], frame[cut:]), Responder())
    assert [reply.sequence for reply in answered] == [3]


def test_several_frames_in_one_read_are_answered_in_order() -> None:
    together = b"".join(request(k) for k in range(1, 51))
    answered = serve(ScriptedStream(together), Responder())
    assert [reply.sequence for reply in answered] == list(range(1, 51))


def test_frames_straddling_reads_are_answered_in_order() -> None:
    stream = b"".join(request(k) for k in range(1, 11))
    reads = [stream[k : k + 7] for k in range(0, len(stream), 7)]
    answered = serve(ScriptedStream(*reads), Responder())
    assert [reply.sequence for reply in answered] == list(range(1, 11))


def test_a_peer_that_closes_mid_frame_gets_no_reply_for_the_partial_frame() -> None:
    responder = Responder()
    answered = serve(ScriptedStream(request(1) + request(2)[:10]), responder)
    assert [reply.sequence for reply in answered] == [1]
    assert responder.seen == [1]


def test_a_peer_that_resets_ends_the_connection_quietly() -> None:
    responder = Responder()
    answered = serve(ScriptedStream(request(1), ConnectionResetError()), responder)
    assert [reply.sequence for reply in answered] == [1]


def test_a_peer_gone_while_replied_to_still_gets_its_point_published() -> None:
    """The slot counts a point as pending from the moment it is accepted: it must reach its
    interpolator even if its reply cannot be written."""
    responder = Responder()
    stream = ScriptedStream(request(1), send_error=BrokenPipeError())
    with pytest.raises(BrokenPipeError):
        serve_requests(stream, ORDER, responder, MotionHandler.error_reply)
    assert responder.then == [1]


def test_garbage_is_answered_invalid_and_the_connection_kept() -> None:
    too_long = (1 << 20).to_bytes(4, "little") + b"\xff" * 40
    responder = Responder()
    answered = serve(ScriptedStream(too_long, request(2)), responder)
    assert [(reply.result, reply.subcode) for reply in answered] == [
        (int(Result.INVALID), int(InvalidSubcode.MSGSIZE)),
        (int(Result.SUCCESS), 0),
    ]
    assert responder.seen == [2]


def test_a_handler_that_closes_ends_the_connection_and_reads_no_more() -> None:
    responder = Responder(close_on=2)
    stream = ScriptedStream(request(1) + request(2) + request(3), request(4))
    answered = serve(stream, responder)
    assert [reply.sequence for reply in answered] == [1, 2]
    assert stream.reads == [request(4)]


# -- servers and their threads -----------------------------------------------------------
class PipeStream:
    """A connection's server end, the peer driven by the test: ``write`` what the peer sends,
    ``take`` what it has received. Only ``window`` bytes of replies fit in the peer's buffers
    until it reads them; beyond that ``sendall`` blocks, as TCP's does. ``shutdown`` ends a
    blocked ``recv`` (end of stream) or ``sendall`` (broken pipe)."""

    def __init__(self, window: int = 1 << 20) -> None:
        self.window = window
        self._changed = threading.Condition()
        self._inbound = bytearray()
        self._outbound = bytearray()
        self._peer_closed = False
        self._shut = False
        self.blocked = False
        self.closed = False

    # the server's side
    def recv(self, size: int, flags: int = 0, /) -> bytes:
        with self._changed:
            self._changed.wait_for(lambda: self._inbound or self._peer_closed or self._shut)
            data = bytes(self._inbound[:size])
            del self._inbound[:size]
            return data

    def sendall(self, data: bytes, /) -> None:
        def room() -> bool:
            return len(self._outbound) + len(data) <= self.window

        with self._changed:
            self.blocked = not room()
            self._changed.notify_all()
            self._changed.wait_for(lambda: room() or self._shut)
            self.blocked = False
            if self._shut:
                raise BrokenPipeError("shut down")
            self._outbound += data
            self._changed.notify_all()

    def shutdown(self, how: int, /) -> None:
        with self._changed:
            self._shut = True
            self._changed.notify_all()

    def close(self) -> None:
        with self._changed:
            self.closed = True
            self._changed.notify_all()

    # the peer's side
    def write(self, data: bytes) -> None:
        with self._changed:
            self._inbound += data
            self._changed.notify_all()

    def hang_up(self) -> None:
        with self._changed:
            self._peer_closed = True
            self._changed.notify_all()

    def take(self) -> bytes:
        with self._changed:
            data = bytes(self._outbound)
            self._outbound.clear()
            self._changed.notify_all()
            return data

    def wait(self, what: str, condition: Callable[[], bool]) -> None:
        with self._changed:
            if not self._changed.wait_for(condition, WAIT_S):
                raise TimeoutError(f"{what} not within {WAIT_S} s")

    def wait_replies(self, count: int) -> list[MotoMotionReply]:
        self.wait(f"{count} replies", lambda: len(self._outbound) >= count * len(reply_frame()))
        return replies(self.take())

    def wait_blocked(self) -> None:
        self.wait("a blocked write", lambda: self.blocked)

    @property
    def pending_requests(self) -> int:
        """Whole requests written by the peer and not read by the server yet."""
        with self._changed:
            return len(self._inbound) // REQUEST_BYTES


def reply_frame() -> bytes:
    return encode(motion_reply(motion_ctrl(0), Result.SUCCESS, 0), ORDER, Role.CONTROLLER)


class FakeListener:
    """Clients arrive when the test connects them; ``fail`` makes the next accept fail."""

    def __init__(self) -> None:
        self._arrivals: queue.Queue[tuple[Stream, tuple[str, int]] | OSError | None] = queue.Queue()
        self.closed = False

    def connect(self, stream: Stream, port: int = 40000) -> None:
        self._arrivals.put((stream, ("127.0.0.1", port)))

    def fail(self, error: OSError) -> None:
        self._arrivals.put(error)

    def accept(self) -> tuple[Stream, tuple[str, int]]:
        arrival = self._arrivals.get()
        if arrival is None:
            raise OSError("listener closed")
        if isinstance(arrival, OSError):
            raise arrival
        return arrival

    def close(self) -> None:
        self.closed = True
        self._arrivals.put(None)


@dataclass
class Port:
    listener: FakeListener
    server: RequestServer
    responder: Responder
    disconnects: list[int]


@pytest.fixture
def ports() -> Iterator[Callable[..., Port]]:
    made: list[RequestServer] = []

    def make(name: str = "motion", moving: Callable[[], bool] = lambda: False) -> Port:
        listener, responder, disconnects = FakeListener(), Responder(), []
        server = RequestServer(
            name=name,
            listener=listener,
            byte_order=ORDER,
            respond=responder,
            error_reply=MotionHandler.error_reply,
            moving=moving,
            on_disconnect=lambda: disconnects.append(1),
        )
        made.append(server)
        server.start()
        return Port(listener, server, responder, disconnects)

    yield make
    for server in made:
        server.close()


def gateway_threads() -> list[str]:
    return sorted(t.name for t in threading.enumerate() if t.name.startswith("gateway-"))


def test_a_server_starts_no_thread_until_started_and_joins_all_when_closed() -> None:
    listener = FakeListener()
    server = RequestServer(
        name="motion",
        listener=listener,
        byte_order=ORDER,
        respond=Responder(),
        error_reply=MotionHandler.error_reply,
        moving=lambda: False,
    )
    assert gateway_threads() == []
    server.start()
    client = PipeStream()
    listener.connect(client)
    client.write(request(1))
    client.wait_replies(1)
    assert gateway_threads() == ["gateway-motion-accept", "gateway-motion-client"]
    server.close()
    assert gateway_threads() == []
    assert listener.closed and client.closed


def test_a_client_that_does_not_read_holds_only_its_own_thread(
    ports: Callable[..., Port],
) -> None:
    """Replies do not pile up in the gateway: once the peer's buffers are full the
    connection's thread waits in its write and reads nothing more. The other port is
    served meanwhile, and a newcomer takes the port over."""
    motion, io = ports("motion"), ports("io")
    stuck = PipeStream(window=3 * len(reply_frame()))
    motion.listener.connect(stuck)
    sent = 3 * RECV_BYTES // REQUEST_BYTES
    stuck.write(b"".join(request(k) for k in range(1, sent + 1)))
    stuck.wait_blocked()
    assert len(motion.responder.seen) == 4  # three replies fit, the fourth waits
    # Read ahead: at most what one read takes.
    assert stuck.pending_requests >= sent - RECV_BYTES // REQUEST_BYTES - 1

    other = PipeStream()
    io.listener.connect(other)
    other.write(request(9))
    assert [reply.sequence for reply in other.wait_replies(1)] == [9]

    newcomer = PipeStream()
    motion.listener.connect(newcomer, port=40001)
    newcomer.write(request(5))
    assert [reply.sequence for reply in newcomer.wait_replies(1)] == [5]
    assert motion.disconnects == [1]
    assert stuck.closed


def test_a_newcomer_is_refused_while_the_robot_moves(ports: Callable[..., Port]) -> None:
    motion = ports(moving=lambda: True)
    first, second = PipeStream(), PipeStream()
    motion.listener.connect(first)
    first.write(request(1))
    first.wait_replies(1)
    motion.listener.connect(second, port=40001)
    first.write(request(2))
    assert [reply.sequence for reply in first.wait_replies(1)] == [2]
    second.wait("the refusal", lambda: second.closed)
    assert motion.server.connected()


def test_a_client_that_hangs_up_is_cleaned_up_and_the_next_served(
    ports: Callable[..., Port],
) -> None:
    motion = ports(moving=lambda: True)
    first, second = PipeStream(), PipeStream()
    motion.listener.connect(first)
    first.hang_up()
    motion.listener.connect(second, port=40001)
    second.write(request(1))
    assert [reply.sequence for reply in second.wait_replies(1)] == [1]
    assert motion.disconnects == [1]


def test_a_failed_accept_does_not_close_the_port(
    ports: Callable[..., Port], caplog: pytest.LogCaptureFixture
) -> None:
    motion = ports()
    motion.listener.fail(ConnectionAbortedError("reset before it was taken"))
    client = PipeStream()
    motion.listener.connect(client)
    client.write(request(1))
    assert [reply.sequence for reply in client.wait_replies(1)] == [1]
    assert "accept failed" in caplog.text


def test_closing_ends_a_connection_blocked_in_its_write(ports: Callable[..., Port]) -> None:
    motion = ports()
    stuck = PipeStream(window=0)
    motion.listener.connect(stuck)
    stuck.write(request(1))
    stuck.wait_blocked()
    motion.server.close()
    assert not motion.server.connected()
    assert motion.disconnects == [1]
    assert gateway_threads() == []


# -- the real listener -------------------------------------------------------------------
def test_the_socket_listener_serves_loopback_clients_and_its_close_ends_accept() -> None:
    sock = listen("127.0.0.1", 0)
    responder = Responder()
    server = RequestServer(
        name="motion",
        listener=SocketListener(sock),
        byte_order=ORDER,
        respond=responder,
        error_reply=MotionHandler.error_reply,
        moving=lambda: False,
    )
    server.start()
    try:
        with socket.create_connection(sock.getsockname(), timeout=WAIT_S) as client:
            client.sendall(request(1) + request(2))
            received = b""
            while len(received) < 2 * len(reply_frame()):
                received += client.recv(RECV_BYTES)
            assert [reply.sequence for reply in replies(received)] == [1, 2]
            assert server.current is not None
            accepted = server.current.sock
            assert isinstance(accepted, socket.socket)
            assert accepted.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
    finally:
        server.close()
    assert gateway_threads() == []
