"""Port 50241 (port_base + 1): the state clients, served by the broadcaster's one thread.

An ``Acceptor`` thread blocks in ``accept`` and hands each connection over, waking the
broadcaster's thread, which may otherwise sleep for as long as nothing is due. Everything else
is non-blocking and is called from the thread that reads the ticks: whether a newcomer is taken
(motoros1 §6 limits), each cycle's frames written to every client with ``send``, and what a
client cannot take waiting in its ``Backlog`` for the next cycle. The server never reads from
these sockets (motoros1 §6); a client goes when a send fails or it takes nothing for
``STUCK_S``.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
from collections import deque
from collections.abc import Callable

from motocell.services.broadcaster.core.admission import Admission, admission
from motocell.services.broadcaster.core.backlog import STUCK_S, Backlog, Cycle

log = logging.getLogger("broadcaster")

SEND_BUFFER_BYTES = 16 * 1024
"""The kernel's share of a client's backlog (Linux doubles it): a few dozen cycles, so a
client on a slow link is not fed seconds of old states from our side of the connection."""


class StateClient:
    def __init__(self, sock: socket.socket, peer: tuple[str, int]) -> None:
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
        self.sock = sock
        self.peer = peer
        self.backlog = Backlog()

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()


WAITING_CONNECTIONS = 16
"""Connections accepted but not yet taken by the broadcaster's thread: far more than the four
clients it serves; beyond that the oldest waiting is closed."""


class Acceptor:
    """Accepts connections in a thread of its own and hands them over (``take``), calling
    ``wake`` for each so the broadcaster's thread takes it at once."""

    def __init__(self, server: socket.socket, wake: Callable[[], None]) -> None:
        server.setblocking(True)
        self.server = server
        self._wake = wake
        self._waiting: deque[tuple[socket.socket, tuple[str, int]]] = deque()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="state-accept")

    def start(self) -> None:
        self._thread.start()

    def _run(self) -> None:
        while True:
            try:
                sock, peer = self.server.accept()
            except ConnectionError:
                continue  # gone before it was taken
            except OSError:
                return  # the listening socket was shut down: stopping
            with self._lock:
                self._waiting.append((sock, peer))
                if len(self._waiting) > WAITING_CONNECTIONS:
                    self._waiting.popleft()[0].close()
            self._wake()

    def take(self) -> list[tuple[socket.socket, tuple[str, int]]]:
        with self._lock:
            taken = list(self._waiting)
            self._waiting.clear()
        return taken

    def close(self) -> None:
        """Stop accepting: the blocked ``accept`` returns, the thread ends."""
        with contextlib.suppress(OSError):
            self.server.shutdown(socket.SHUT_RDWR)
        self._thread.join()
        self.server.close()
        for sock, _peer in self.take():
            sock.close()


class StatePort:
    def __init__(self, acceptor: Acceptor) -> None:
        self.acceptor = acceptor
        self.clients: list[StateClient] = []
        self.replaced = 0
        """Cycles that clients which went missed because a newer one replaced them."""
        self.closed_stuck = 0

    def admit(self, motion_queued: bool) -> None:
        """Take every connection the acceptor has (motoros1 §6 limits)."""
        for sock, peer in self.acceptor.take():
            decision = admission(len(self.clients), motion_queued)
            if decision is Admission.REFUSE:
                log.warning("state: refused %s:%d, 4 clients and motion queued", *peer)
                sock.close()
                continue
            if decision is Admission.REPLACE_FIRST:
                self._drop(self.clients[0], "replaced by a 5th client")
            self.clients.append(StateClient(sock, peer))
            log.info("state: client %s:%d connected", *peer)

    def send(self, cycle: Cycle, now: float) -> None:
        """One cycle's frames to every client, as far as each takes them now."""
        for client in list(self.clients):
            client.backlog.offer(cycle)
            self._write(client, now)

    def flush(self, now: float) -> None:
        """The backlogs, as far as the clients take them now."""
        for client in list(self.clients):
            if client.backlog.pending:
                self._write(client, now)

    def _write(self, client: StateClient, now: float) -> None:
        try:
            taking = client.backlog.write(client.sock.send, now)
        except OSError as exc:
            self._drop(client, exc.strerror or type(exc).__name__)
            return
        if not taking:
            self.closed_stuck += 1
            self._drop(client, f"took nothing for {STUCK_S:g} s")

    def _drop(self, client: StateClient, why: str) -> None:
        self.clients.remove(client)
        self.replaced += client.backlog.replaced
        client.close()
        log.info("state: client %s:%d gone: %s", *client.peer, why)

    def replaced_total(self) -> int:
        return self.replaced + sum(client.backlog.replaced for client in self.clients)

    def close(self) -> None:
        self.acceptor.close()
        for client in list(self.clients):
            self._drop(client, "the broadcaster stops")
