"""The motion and I/O ports' TCP servers: thin blocking-socket shells around the pure codec and
the handlers.

A thread per connection keeps the reply path short: recv, decode, decide, send, with no event
loop hop in between; the motion port's runs a step above the rest of the cell
(``reply_priority``).
Connection limits and take-over follow MotoROS 1.9.4+ (motoros1 §2.1, motoros1 §8).

Replies are written as each request is answered, by the connection's own thread, and nothing
else is read meanwhile: a client that does not read its replies fills the kernel's buffers and
then holds only its own thread, blocked in ``sendall``, with nothing piling up in the gateway.
The other port is served as usual, and a newcomer that replaces the client (or ``close``)
shuts its socket down, which ends the blocked write.

The shells take their sockets as ``Stream`` and ``Listener`` (``socket.socket`` is a
``Stream``; ``SocketListener`` is the real listener), so unit tests script both.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
import time
from collections.abc import Callable
from typing import Protocol

from motocell.services.gateway.core.response import Response
from motocell.services.gateway.reply_priority import ReplyPriority
from motocell.shared.protocol.codec import CLOSED, NEED_DATA, ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import Message, UnknownMessage

log = logging.getLogger("gateway")

RECV_BYTES = 65536
HANGUP_GRACE_S = 0.3
"""How long a newcomer waits for a previous client that is already closing."""
CLOSE_DELAY_S = 0.05
"""MotoROS sleeps 50 ms before it closes a motion connection (motoros1 §2.1)."""
ACCEPT_RETRY_S = 0.1
"""After a failed accept that was not a close (a client reset before it was taken, no file
descriptor left): try again this much later rather than in a tight loop."""
JOIN_S = 5.0
"""How long closing waits for a connection's thread: a request being handled ends within its
own timeouts (START_TRAJ_MODE's is the longest, 6 s, and is rare)."""

Respond = Callable[[Message | UnknownMessage], Response]
Observe = Callable[[int, Message | None, int], None]
ErrorReply = Callable[[PeerProtocolError], Message]


class Stream(Protocol):
    """What a connection needs of its socket."""

    def recv(self, size: int, flags: int = 0, /) -> bytes: ...

    def sendall(self, data: bytes, /) -> None: ...

    def shutdown(self, how: int, /) -> None:
        """Ends a ``recv`` or ``sendall`` blocked in another thread."""
        ...

    def close(self) -> None: ...


class Listener(Protocol):
    def accept(self) -> tuple[Stream, tuple[str, int]]:
        """The next client; OSError once closed (and on a client lost before it was taken)."""
        ...

    def close(self) -> None:
        """Stop listening; an ``accept`` blocked in another thread raises OSError."""
        ...


class SocketListener:
    """The real ``Listener``: a listening socket, each client configured for small replies."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock

    def accept(self) -> tuple[Stream, tuple[str, int]]:
        client, peer = self.sock.accept()
        try:
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            client.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        except OSError:
            client.close()
            raise
        return client, peer

    def close(self) -> None:
        # Closing alone does not wake a thread blocked in accept() on Linux; shutting the
        # socket down does.
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()


def serve_requests(
    client: Stream,
    byte_order: ByteOrder,
    respond: Respond,
    error_reply: ErrorReply,
    observe: Observe = lambda msg_type, reply, elapsed_ns: None,
    *,
    priority: ReplyPriority | None = None,
) -> None:
    """Answer every request exactly once, in order, until the peer closes or a handler says
    to close. Garbage gets its INVALID reply and the connection is kept. ``observe`` learns
    each request's type, reply and time from decoded request to written reply; ``priority``
    whether the thread waits for its client between reads."""
    codec = SimpleMessageCodec(Role.CONTROLLER, byte_order)
    while True:
        try:
            data = _read(client, priority)
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
            response = respond(event)
            try:
                if response.reply is not None:
                    client.sendall(codec.send(response.reply))
                observe(event.msg_type, response.reply, time.monotonic_ns() - started)
            finally:
                # Even when the client is gone: a point the gateway counted as pending must
                # reach its interpolator, or the slot would never free.
                if response.then is not None:
                    response.then()
            if response.close:
                return


def _read(client: Stream, priority: ReplyPriority | None) -> bytes:
    """What the client sent; while the thread holds the reply priority, first without waiting,
    to tell ``priority`` whether a request was there already."""
    if priority is None or not priority.raised:
        return client.recv(RECV_BYTES)
    try:
        data = client.recv(RECV_BYTES, socket.MSG_DONTWAIT)
    except BlockingIOError:
        priority.waiting()
        return client.recv(RECV_BYTES)
    priority.busy()
    return data


class Connection:
    def __init__(self, sock: Stream, thread: threading.Thread) -> None:
        self.sock = sock
        self.thread = thread

    def close(self) -> None:
        """Shut the socket down (which ends a blocked read or write) and join the thread."""
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.thread.join(timeout=JOIN_S)


class RequestServer:
    """The motion port or the I/O port: one client at a time (motoros1 §2.1, motoros1 §8).

    A newcomer replaces an idle client; while the robot moves it is refused. The old client's
    clean-up (``on_disconnect``) finishes before the newcomer is served, so a new motion client
    never inherits increments queued by the old one.

    ``start`` starts the accept thread, which starts one thread per client; ``close`` stops
    and joins them all.
    """

    def __init__(
        self,
        *,
        name: str,
        listener: Listener,
        byte_order: ByteOrder,
        respond: Respond,
        error_reply: ErrorReply,
        moving: Callable[[], bool],
        on_disconnect: Callable[[], object] = lambda: None,
        on_change: Callable[[], object] = lambda: None,
        observe: Observe = lambda msg_type, reply, elapsed_ns: None,
        reply_priority: bool = False,
    ) -> None:
        """``reply_priority``: its connection threads answer at the reply priority (the motion
        port's, whose points set off the work a next request would otherwise wait behind)."""
        self.name = name
        self.listener = listener
        self.byte_order = byte_order
        self.respond = respond
        self.error_reply = error_reply
        self.moving = moving
        self.on_disconnect = on_disconnect
        self.on_change = on_change
        self.observe = observe
        self.reply_priority = reply_priority
        self.current: Connection | None = None
        self._stopping = threading.Event()
        self._accepting: threading.Thread | None = None

    def start(self) -> None:
        self._accepting = threading.Thread(
            target=self._accept_loop, name=f"gateway-{self.name}-accept", daemon=True
        )
        self._accepting.start()

    def _accept_loop(self) -> None:
        while not self._stopping.is_set():
            try:
                client, peer = self.listener.accept()
            except OSError as exc:
                if not self._stopping.is_set():
                    log.warning("%s: accept failed: %s", self.name, exc)
                    self._stopping.wait(ACCEPT_RETRY_S)
                continue
            self._take(client, peer)

    def _take(self, client: Stream, peer: tuple[str, int]) -> None:
        """Serve ``client``, replacing the current one, or refuse it."""
        if self.current is not None:
            # A client that has just hung up is not a rival: let its clean-up finish.
            self.current.thread.join(timeout=HANGUP_GRACE_S)
        if self.current is not None and self.current.thread.is_alive():
            if self.moving():
                log.warning("%s: refused %s:%d, the robot is moving", self.name, *peer)
                client.close()
                return
            log.info("%s: %s:%d replaces the idle client", self.name, *peer)
            self.current.close()
            if self.current.thread.is_alive():
                # Its request is still being handled (e.g. a START_TRAJ_MODE waiting on a
                # controller): two clients must never be served at once.
                log.warning("%s: refused %s:%d, the old client is busy", self.name, *peer)
                client.close()
                return
        log.info("%s: client %s:%d connected", self.name, *peer)
        thread = threading.Thread(
            target=self._serve,
            args=(client, peer),
            name=f"gateway-{self.name}-client",
            daemon=True,
        )
        self.current = Connection(client, thread)
        thread.start()
        self.on_change()

    def _serve(self, client: Stream, peer: tuple[str, int]) -> None:
        priority = ReplyPriority()
        if self.reply_priority:
            # Above the rest of the cell: a request then preempts the interpolating and routing
            # the previous point set off, instead of queueing behind it (docs/reply-path.md).
            priority.enter()
        try:
            serve_requests(
                client,
                self.byte_order,
                self.respond,
                self.error_reply,
                self.observe,
                priority=priority,
            )
        except OSError as exc:
            log.info("%s: %s:%d: %s", self.name, *peer, exc)
        finally:
            # MotoROS's pause before it closes; a server that is closing does not make it.
            self._stopping.wait(CLOSE_DELAY_S)
            client.close()
            self.on_disconnect()
            log.info("%s: client %s:%d gone", self.name, *peer)
            self.on_change()

    def connected(self) -> bool:
        current = self.current
        return current is not None and current.thread.is_alive()

    def close(self) -> None:
        """Stop accepting, join the accept thread, then close the client and join its thread."""
        self._stopping.set()
        self.listener.close()
        if self._accepting is not None:
            self._accepting.join(timeout=JOIN_S)
        if self.current is not None:
            self.current.close()
