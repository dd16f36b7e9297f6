"""Port 50241 (port_base + 1): the state clients, served by the broadcaster's one thread.

Everything here is non-blocking and is called from the thread that reads the ticks: new
connections are taken from a non-blocking listening socket once per cycle (no accept thread,
no lock), each cycle's frames are written to every client with ``send``, and what a client
cannot take waits in its ``Backlog`` for the next cycle. The server never reads from these
sockets (motoros1 §6); a client goes when a send fails or it takes nothing for ``STUCK_S``.
"""

from __future__ import annotations

import contextlib
import logging
import socket

from motocell.services.broadcaster.backlog import STUCK_S, Backlog, Cycle
from motocell.services.broadcaster.core import Admission, admission

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


class StatePort:
    def __init__(self, server: socket.socket) -> None:
        server.setblocking(False)  # polled once a cycle by the broadcaster's one thread
        self.server = server
        self.clients: list[StateClient] = []
        self.replaced = 0
        """Cycles that clients which went missed because a newer one replaced them."""
        self.closed_stuck = 0

    def admit(self, motion_queued: bool) -> None:
        """Take every connection waiting at the listening socket (motoros1 §6 limits)."""
        while True:
            try:
                sock, peer = self.server.accept()
            except BlockingIOError:
                return
            except ConnectionError:
                continue  # gone before it was taken
            except OSError as exc:
                log.warning("state: cannot take a client now: %s", exc)
                return
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
        self.server.close()
        for client in list(self.clients):
            self._drop(client, "the broadcaster stops")
