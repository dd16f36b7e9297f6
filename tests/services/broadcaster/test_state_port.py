"""The state port over real loopback sockets, driven as the broadcaster's thread drives it:
motoros1 §6 client limits, every cycle whole, the newest cycle for a slow client, and a client
that takes nothing for STUCK_S closed. Times are passed in; nothing waits on a clock."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator

import pytest

from motocell.services.broadcaster.core.admission import MAX_STATE_CLIENTS
from motocell.services.broadcaster.core.backlog import STUCK_S
from motocell.services.broadcaster.state_port import Acceptor, StatePort
from motocell.shared.service import listen
from motocell.testing.processes import wait_until

CYCLE_BYTES = 64 * 1024
"""Big enough that a client which does not read fills the kernel's buffers in a few cycles."""


class Woken:
    """Counts the acceptor's wake-ups: one per connection it hands over."""

    def __init__(self) -> None:
        self.count = threading.Semaphore(0)

    def __call__(self) -> None:
        self.count.release()


class CountedPort(StatePort):
    """A state port whose acceptor's wake-ups are counted (``woken``)."""

    def __init__(self) -> None:
        self.woken = Woken()
        super().__init__(Acceptor(listen("127.0.0.1", 0), self.woken))
        self.acceptor.start()


@pytest.fixture
def port() -> Iterator[CountedPort]:
    state_port = CountedPort()
    yield state_port
    state_port.close()


class Client:
    def __init__(self, port: CountedPort) -> None:
        address = port.acceptor.server.getsockname()
        self.sock = socket.create_connection(address, timeout=5.0)

    def read(self, size: int) -> bytes:
        data = bytearray()
        while len(data) < size:
            chunk = self.sock.recv(size - len(data))
            if not chunk:
                break
            data += chunk
        return bytes(data)

    def closed_by_server(self) -> bool:
        """Reads what is left; True at the end of the stream, False if it stays open."""
        try:
            while self.sock.recv(1 << 20):
                pass
        except ConnectionResetError:
            return True
        except TimeoutError:
            return False
        return True

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def clients() -> Iterator[list[Client]]:
    made: list[Client] = []
    yield made
    for client in made:
        client.close()


def connect(port: CountedPort, clients: list[Client], count: int, queued: bool = False) -> None:
    for _ in range(count):
        clients.append(Client(port))
        assert port.woken.count.acquire(timeout=5.0), "the acceptor handed the connection over"
    port.admit(queued)


def test_every_client_gets_each_cycle(port: CountedPort, clients: list[Client]) -> None:
    connect(port, clients, MAX_STATE_CLIENTS)
    port.send((b"cycle one;",), 0.0)
    port.send((b"cycle two;",), 0.0)
    for client in clients:
        assert client.read(20) == b"cycle one;cycle two;"


def test_a_fifth_client_replaces_the_first_while_nothing_is_queued(
    port: CountedPort, clients: list[Client]
) -> None:
    connect(port, clients, MAX_STATE_CLIENTS)
    connect(port, clients, 1, queued=False)
    assert clients[0].closed_by_server()
    assert len(port.clients) == MAX_STATE_CLIENTS
    port.send((b"still here",), 0.0)
    for client in clients[1:]:
        assert client.read(10) == b"still here"


def test_a_fifth_client_is_refused_while_motion_is_queued(
    port: CountedPort, clients: list[Client]
) -> None:
    connect(port, clients, MAX_STATE_CLIENTS)
    connect(port, clients, 1, queued=True)
    assert clients[-1].closed_by_server()
    port.send((b"still here",), 0.0)
    for client in clients[:-1]:
        assert client.read(10) == b"still here"


def fill(port: CountedPort, size: int, now: float, reader: Client | None = None) -> int:
    """Send numbered cycles of ``size`` bytes until the first client's backlog waits (its
    socket is full); the last number sent. ``reader`` reads every cycle meanwhile."""
    number = 0
    while not port.clients[0].backlog.pending:
        number += 1
        port.send((bytes([number]) * size,), now)
        if reader is not None:
            assert reader.read(size) == bytes([number]) * size
    return number


def test_a_slow_client_gets_whole_cycles_and_then_the_newest(
    port: CountedPort, clients: list[Client]
) -> None:
    connect(port, clients, 1)
    begun = fill(port, CYCLE_BYTES, 0.0)
    newest = begun + 10  # far more than the client's buffers hold while it does not read
    for newer in range(begun + 1, newest + 1):
        port.send((bytes([newer]) * CYCLE_BYTES,), 0.0)
    received = bytearray()
    while len(received) % CYCLE_BYTES or not received or received[-1] != newest:
        received += clients[0].sock.recv(1 << 20)
        port.flush(0.1)
    cycles = [received[i : i + CYCLE_BYTES] for i in range(0, len(received), CYCLE_BYTES)]
    numbers = [cycle[0] for cycle in cycles]
    assert cycles == [bytes([n]) * CYCLE_BYTES for n in numbers]  # whole, never interleaved
    assert numbers[:begun] == list(range(1, begun + 1))
    assert numbers == sorted(set(numbers))
    assert numbers[-1] == newest
    assert port.replaced_total() == newest - len(numbers) > 0


def test_a_client_that_takes_nothing_for_the_bound_is_closed(
    port: CountedPort, clients: list[Client]
) -> None:
    connect(port, clients, 2)
    fill(port, 4096, 10.0, reader=clients[1])
    port.flush(10.0 + STUCK_S - 0.01)
    assert len(port.clients) == 2
    port.flush(10.0 + STUCK_S)
    assert len(port.clients) == 1
    assert port.closed_stuck == 1
    assert clients[0].closed_by_server()
    port.send((b"on",), 10.0 + STUCK_S)
    assert clients[1].read(2) == b"on"


def test_a_client_that_hung_up_is_dropped(port: CountedPort, clients: list[Client]) -> None:
    connect(port, clients, 2)
    clients[0].close()

    def dropped() -> bool:
        port.send((b"x",), 0.0)  # the first send after a hang-up can still succeed
        return len(port.clients) == 1

    wait_until(dropped, 5.0, "the drop")
    assert clients[1].read(1) == b"x"  # and the other client goes on


def test_closing_the_port_closes_every_client(port: CountedPort, clients: list[Client]) -> None:
    connect(port, clients, 3)
    port.close()
    assert all(client.closed_by_server() for client in clients)
    assert port.clients == []
