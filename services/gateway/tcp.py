"""The motion and I/O ports' TCP servers: thin blocking-socket shells around the pure codec and
the handlers.

A thread per connection keeps the reply path short: recv, decode, decide, send, with no event
loop hop in between. Connection limits and take-over follow MotoROS 1.9.4+ (motoros1 §2.1,
motoros1 §8).
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
import time
from collections.abc import Callable

from motocell.services.gateway.core.answer import Answer
from motocell.shared.protocol.codec import CLOSED, NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import Message, UnknownMessage

log = logging.getLogger("gateway")

RECV_BYTES = 65536
HANGUP_GRACE_S = 0.3
"""How long a newcomer waits for a previous client that is already closing."""
CLOSE_DELAY_S = 0.05
"""MotoROS sleeps 50 ms before it closes a motion connection (motoros1 §2.1)."""

Respond = Callable[[Message | UnknownMessage], Answer]
Observe = Callable[[int, Message | None, int], None]
ErrorReply = Callable[[PeerProtocolError], Message]


def configure(client: socket.socket) -> None:
    client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    client.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)


def serve_requests(
    client: socket.socket,
    byte_order: ByteOrder,
    respond: Respond,
    error_reply: ErrorReply,
    observe: Observe = lambda msg_type, reply, elapsed_ns: None,
) -> None:
    """Answer every request exactly once, in order, until the peer closes or a handler says
    to close. Garbage gets its INVALID reply and the connection is kept. ``observe`` learns
    each request's type, reply and time from decoded request to written reply."""
    codec = SimpleMessageCodec(Role.CONTROLLER, byte_order)
    while True:
        try:
            data = client.recv(RECV_BYTES)
        except OSError:
            return
        codec.receive_data(data)
        while True:
            try:
                event = codec.next_event()
            except PeerProtocolError as error:
                started = time.monotonic_ns()
                reply = error_reply(error)
                client.sendall(codec.send(reply))
                observe(error.msg_type, reply, time.monotonic_ns() - started)
                continue
            if event is NEED_DATA:
                break
            if event is CLOSED:
                return
            assert isinstance(event, Message | UnknownMessage)
            started = time.monotonic_ns()
            answer = respond(event)
            try:
                if answer.reply is not None:
                    client.sendall(codec.send(answer.reply))
                observe(event.msg_type, answer.reply, time.monotonic_ns() - started)
            finally:
                # Even when the client is gone: a point the gateway counted as pending must
                # reach its interpolator, or the slot would never free.
                if answer.then is not None:
                    answer.then()
            if answer.close:
                return


class Connection:
    def __init__(self, sock: socket.socket, thread: threading.Thread) -> None:
        self.sock = sock
        self.thread = thread

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.thread.join(timeout=5.0)


class RequestServer:
    """The motion port or the I/O port: one client at a time (motoros1 §2.1, motoros1 §8).

    A newcomer replaces an idle client; while the robot moves it is refused. The old client's
    clean-up (``on_disconnect``) finishes before the newcomer is served, so a new motion client
    never inherits increments queued by the old one.
    """

    def __init__(
        self,
        *,
        name: str,
        server: socket.socket,
        byte_order: ByteOrder,
        respond: Respond,
        error_reply: ErrorReply,
        moving: Callable[[], bool],
        on_disconnect: Callable[[], object] = lambda: None,
        on_change: Callable[[], object] = lambda: None,
        observe: Observe = lambda msg_type, reply, elapsed_ns: None,
    ) -> None:
        self.name = name
        self.server = server
        self.byte_order = byte_order
        self.respond = respond
        self.error_reply = error_reply
        self.moving = moving
        self.on_disconnect = on_disconnect
        self.on_change = on_change
        self.observe = observe
        self.current: Connection | None = None
        self.thread = threading.Thread(target=self._accept_loop, name=f"{name}-accept", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def _accept_loop(self) -> None:
        while True:
            try:
                client, peer = self.server.accept()
            except OSError:
                return
            configure(client)
            if self.current is not None:
                # A client that has just hung up is not a rival: let its clean-up finish.
                self.current.thread.join(timeout=HANGUP_GRACE_S)
            if self.current is not None and self.current.thread.is_alive():
                if self.moving():
                    log.warning("%s: refused %s:%d, the robot is moving", self.name, *peer)
                    client.close()
                    continue
                log.info("%s: %s:%d replaces the idle client", self.name, *peer)
                self.current.close()
                if self.current.thread.is_alive():
                    # Its request is still being handled (e.g. a START_TRAJ_MODE waiting on a
                    # controller): two clients must never be served at once.
                    log.warning("%s: refused %s:%d, the old client is busy", self.name, *peer)
                    client.close()
                    continue
            log.info("%s: client %s:%d connected", self.name, *peer)
            thread = threading.Thread(
                target=self._serve, args=(client, peer), name=f"{self.name}-client", daemon=True
            )
            self.current = Connection(client, thread)
            thread.start()
            self.on_change()

    def _serve(self, client: socket.socket, peer: tuple[str, int]) -> None:
        try:
            serve_requests(client, self.byte_order, self.respond, self.error_reply, self.observe)
        except OSError as exc:
            log.info("%s: %s:%d: %s", self.name, *peer, exc)
        finally:
            threading.Event().wait(CLOSE_DELAY_S)
            client.close()
            self.on_disconnect()
            log.info("%s: client %s:%d gone", self.name, *peer)
            self.on_change()

    def connected(self) -> bool:
        return self.current is not None and self.current.thread.is_alive()

    def close(self) -> None:
        self.server.close()
        if self.current is not None:
            self.current.close()
