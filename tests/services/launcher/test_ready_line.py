"""``motocell up``'s ready line over a scripted bus: said once, the first time the controller's
status names no service missing and every TCP port of this host's services listens (real
sockets on loopback); then the subscription ends."""

from __future__ import annotations

import logging
import socket
from collections.abc import Iterator

import pytest

from motocell.services.launcher.core.tcp_ports import TcpPort
from motocell.services.launcher.ready_line import ReadyNotice
from motocell.shared.bus.keys import CellKeys
from motocell.testing.statuses import ready_status
from tests.services.launcher.fake_session import Session

HOST = "127.0.0.1"
LINE = "cell cell1 ready: motion 127.0.0.1:50240"


@pytest.fixture
def bound() -> Iterator[socket.socket]:
    """A socket bound to a port the kernel chose, not listening yet: the port is the test's
    from the start, and free to a service's bind (both with SO_REUSEADDR) until it listens."""
    with socket.socket() as server:
        server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        server.bind((HOST, 0))
        yield server


@pytest.fixture
def listening_port() -> Iterator[int]:
    with socket.socket() as server:
        server.bind((HOST, 0))
        server.listen()
        yield server.getsockname()[1]


def notice(session: Session, *ports: int) -> ReadyNotice:
    tcp = [TcpPort("motion", port) for port in ports]
    return ReadyNotice(session.zenoh(), CellKeys("cell1"), HOST, tcp, LINE)


def said(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno == logging.INFO]


def test_a_whole_cell_whose_ports_listen_is_said_ready_once(
    listening_port: int, caplog: pytest.LogCaptureFixture
) -> None:
    session = Session()
    ready = notice(session, listening_port)
    with caplog.at_level(logging.INFO, logger="motocell"):
        assert not ready.check()
        session.put(ready_status())
        assert ready.check()
        assert ready.check()
    assert said(caplog) == [LINE]
    assert session.subscriber is not None
    assert session.subscriber.undeclared == 1
    ready.close()
    assert session.subscriber.undeclared == 1


def test_nothing_is_said_while_a_service_is_missing(
    listening_port: int, caplog: pytest.LogCaptureFixture
) -> None:
    session = Session()
    ready = notice(session, listening_port)
    with caplog.at_level(logging.INFO, logger="motocell"):
        session.put(ready_status(missing_services=["gateway/0"], motion_ready=False))
        assert not ready.check()
        session.put(ready_status())
        assert ready.check()
    assert said(caplog) == [LINE]


def test_a_cell_that_lost_a_service_again_before_its_ports_listen_is_not_ready(
    bound: socket.socket, caplog: pytest.LogCaptureFixture
) -> None:
    session = Session()
    port = bound.getsockname()[1]
    ready = notice(session, port)
    with caplog.at_level(logging.INFO, logger="motocell"):
        session.put(ready_status())
        assert not ready.check()
        session.put(ready_status(missing_services=["gateway/0"], motion_ready=False))
        bound.listen()
        assert not ready.check()
    assert said(caplog) == []
    ready.close()
    assert session.subscriber is not None
    assert session.subscriber.undeclared == 1


def test_the_ports_are_looked_at_again_without_a_new_status(
    bound: socket.socket, caplog: pytest.LogCaptureFixture
) -> None:
    """The controller says the cell is whole once; the ports may listen only later."""
    session = Session()
    port = bound.getsockname()[1]
    ready = notice(session, port)
    with caplog.at_level(logging.INFO, logger="motocell"):
        session.put(ready_status())
        assert not ready.check()
        bound.listen()
        assert ready.check()
    assert said(caplog) == [LINE]
