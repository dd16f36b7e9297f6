"""Listening on a port picked free (``testing/ports.py``): a port another program took between
the pick and the bind leads to a new pick, for a socket, a Zenoh router and a cell alike;
any other failure is the caller's at once."""

from __future__ import annotations

import errno
import socket
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
import zenoh

from motocell.services.launcher.ports import TAKEN
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import open_session
from motocell.shared.ports import free_port_block
from motocell.testing import ports
from motocell.testing.ports import PortTakenError, listening, on_free_port, taken
from motocell.testing.processes import connectable
from motocell.testing.running_cell import router_on_free_port, running_cell

HOST = "127.0.0.1"


@contextmanager
def held_first(monkeypatch: pytest.MonkeyPatch, count: int = 1) -> Iterator[list[int]]:
    """The first pick is a block another program listens on (as if it took it right after the
    pick); later picks are free ones. Yields every pick made."""
    with socket.socket() as holder:
        holder.bind((HOST, 0))
        holder.listen()
        port: int = holder.getsockname()[1]
        picks: list[int] = []

        def pick(wanted: int, host: str = HOST) -> int:
            assert wanted == count
            picks.append(port if not picks else free_port_block(wanted, host))
            return picks[-1]

        monkeypatch.setattr(ports, "free_port_block", pick)
        yield picks


def test_a_bind_that_finds_the_port_taken_gets_a_new_pick(monkeypatch: pytest.MonkeyPatch) -> None:
    def bind(port: int) -> socket.socket:
        server = socket.socket()
        try:
            server.bind((HOST, port))
        except OSError:
            server.close()
            raise
        return server

    with held_first(monkeypatch) as picks, on_free_port(bind) as server:
        assert len(picks) == 2
        assert server.getsockname()[1] == picks[1]


def test_a_zenoh_router_on_a_taken_port_is_opened_on_another(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def open_router(endpoint: str) -> zenoh.Session:
        return zenoh.open(zenoh_config(router_settings([endpoint])))

    with held_first(monkeypatch) as picks:
        endpoint, router = listening(open_router)
    try:
        assert endpoint == f"tcp/{HOST}:{picks[1]}"
        open_session("client", [endpoint], wait=False).close()
    finally:
        router.close()


def test_a_session_listening_on_a_taken_port_is_opened_on_another(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with held_first(monkeypatch) as picks:
        endpoint, session = listening(lambda at: open_session("peer", [], listen=[at], wait=False))
    session.close()
    assert endpoint == f"tcp/{HOST}:{picks[1]}"


def test_a_failure_that_is_not_a_taken_port_is_the_callers_at_once() -> None:
    tries: list[int] = []

    def bind(port: int) -> None:
        tries.append(port)
        raise PermissionError(errno.EACCES, "not allowed")

    with pytest.raises(PermissionError):
        on_free_port(bind)
    assert len(tries) == 1


def test_ports_taken_again_and_again_end_after_the_last_try() -> None:
    tries: list[int] = []

    def bind(port: int) -> None:
        tries.append(port)
        raise OSError(errno.EADDRINUSE, "Address already in use")

    with pytest.raises(OSError, match="Address already in use"):
        on_free_port(bind, tries=3)
    assert len(tries) == 3


@pytest.mark.parametrize(
    "error",
    [
        OSError(errno.EADDRINUSE, "Address already in use"),
        PortTakenError("ports [20001] were taken meanwhile"),
        ConnectionError("the port is taken by another process"),
        AssertionError(f"exited (2):\nmotocell up: cannot listen on the motion port: {TAKEN}"),
    ],
    ids=["kernel", "harness", "open_session", "launcher"],
)
def test_each_way_a_taken_port_is_told_is_understood(error: BaseException) -> None:
    assert taken(error)


@pytest.mark.parametrize(
    "error",
    [OSError(errno.ECONNREFUSED, "Connection refused"), TimeoutError("no router answers")],
)
def test_other_failures_are_not_taken_ports(error: BaseException) -> None:
    assert not taken(error)


@pytest.mark.cell  # starts a router process
def test_a_router_process_on_a_taken_port_is_started_on_another(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with held_first(monkeypatch) as picks, router_on_free_port() as endpoint:
        assert endpoint == f"tcp/{HOST}:{picks[1]}"
        assert connectable(HOST, picks[1])


@pytest.mark.cell  # starts a cell
def test_a_cell_whose_port_was_taken_before_it_started_starts_on_new_ports(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with held_first(monkeypatch, count=3) as picks, running_cell() as cell:
        assert len(picks) == 2
        assert cell.port_base == picks[1]
        with cell.motion() as motion:
            assert motion.sock.getpeername() == (HOST, picks[1])
