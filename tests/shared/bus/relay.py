"""A TCP relay between a client and its router that a test can freeze or cut, in one thread.

Frozen, it stops passing bytes (they wait in the kernel's buffers): the router does not answer
within a query's timeout, but no connection closes. Cut, it closes every connection and closes
new ones at once: the client loses its router, as across a network partition, and finds it
again when the relay is restored."""

from __future__ import annotations

import select
import socket
import threading
from enum import Enum

from motocell.testing.processes import wait_until

CHUNK = 65_536
HOST = "127.0.0.1"
CLOSE_TIMEOUT_S = 5.0


class Mode(Enum):
    OPEN = "open"
    FROZEN = "frozen"
    CUT = "cut"


class Relay:
    """Listens on ``endpoint`` (``tcp/127.0.0.1:PORT``) and relays to ``target``'s port."""

    def __init__(self, target: str) -> None:
        self._target = (HOST, int(target.rsplit(":", 1)[1]))
        self._listener = socket.create_server((HOST, 0))
        self.endpoint = f"tcp/{HOST}:{self._listener.getsockname()[1]}"
        self._peers: dict[socket.socket, socket.socket] = {}
        self._mode = Mode.OPEN
        self._closing = False
        self._wake_read, self._wake_write = socket.socketpair()
        self._thread = threading.Thread(target=self._run, name="relay")
        self._thread.start()

    def set_mode(self, mode: Mode) -> None:
        self._mode = mode
        self._wake_write.send(b"\0")

    def connections(self) -> int:
        return len(self._peers) // 2

    def close(self) -> None:
        self._closing = True
        self._wake_write.send(b"\0")
        self._thread.join(CLOSE_TIMEOUT_S)
        for sock in (self._listener, self._wake_read, self._wake_write):
            sock.close()

    def _run(self) -> None:
        while not self._closing:
            relaying = list(self._peers) if self._mode is Mode.OPEN else []
            readable, _, _ = select.select([self._listener, self._wake_read, *relaying], [], [])
            for sock in readable:
                if sock is self._listener:
                    self._accept()
                elif sock is self._wake_read:
                    self._wake_read.recv(CHUNK)
                    if self._mode is Mode.CUT:
                        self._drop_all()
                elif sock in self._peers:
                    self._pass(sock)
        self._drop_all()

    def _accept(self) -> None:
        client, _ = self._listener.accept()
        if self._mode is Mode.CUT:
            client.close()
            return
        try:
            upstream = socket.create_connection(self._target)
        except OSError:
            client.close()
            raise
        self._peers[client], self._peers[upstream] = upstream, client

    def _pass(self, sock: socket.socket) -> None:
        try:
            data = sock.recv(CHUNK)
            if data:
                self._peers[sock].sendall(data)
                return
        except OSError:
            pass
        self._drop(sock)

    def _drop(self, sock: socket.socket) -> None:
        other = self._peers.pop(sock)
        self._peers.pop(other, None)
        sock.close()
        other.close()

    def _drop_all(self) -> None:
        while self._peers:
            self._drop(next(iter(self._peers)))


def wait_for_connections(relay: Relay, count: int, timeout: float) -> None:
    wait_until(lambda: relay.connections() == count, timeout, f"{count} relayed connection(s)")
