"""What ``motocell up`` tries before it starts anything: its TCP ports and its router's
endpoints, free to listen on here; real sockets on loopback."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest

from motocell.services.launcher.core.tcp_ports import TcpPort
from motocell.services.launcher.ports import (
    PortError,
    check_router_endpoints,
    check_tcp_ports,
    listening,
)
from motocell.shared.ports import free_port

HOST = "127.0.0.1"


@pytest.fixture
def taken_port() -> Iterator[int]:
    with socket.socket() as taken:
        taken.bind((HOST, 0))
        taken.listen()
        yield taken.getsockname()[1]


def test_free_ports_pass_and_are_not_listening() -> None:
    ports = [TcpPort("motion", free_port()), TcpPort("state", free_port())]
    check_tcp_ports(HOST, ports)
    assert not listening(HOST, ports)


def test_a_taken_port_is_named_with_its_use_and_what_to_do(taken_port: int) -> None:
    with pytest.raises(PortError) as refused:
        check_tcp_ports(HOST, [TcpPort("motion", free_port()), TcpPort("state", taken_port)])
    assert str(refused.value) == (
        f"cannot listen on the state port {HOST}:{taken_port}: it is taken by another process "
        "(stop that process, or choose --port-base N: it needs N, N+1 and N+2 free)"
    )


def test_ports_that_are_listened_on_count_as_listening(taken_port: int) -> None:
    assert listening(HOST, [TcpPort("I/O", taken_port)])


def test_an_address_of_another_machine_is_refused() -> None:
    with pytest.raises(PortError, match=r"192\.0\.2\.1:.*not one of this machine's.*--host"):
        check_tcp_ports("192.0.2.1", [TcpPort("motion", 50240)])


def test_a_host_name_that_does_not_resolve_is_refused() -> None:
    with pytest.raises(PortError, match="does not resolve"):
        check_tcp_ports("nosuchhost.invalid", [TcpPort("motion", 50240)])


def test_a_taken_router_port_is_refused_naming_the_option(taken_port: int) -> None:
    with pytest.raises(PortError, match=r"router cannot listen on tcp/.*taken.*--zenoh-listen"):
        check_router_endpoints([f"tcp/{HOST}:{free_port()}", f"tcp/{HOST}:{taken_port}"])


@pytest.mark.parametrize("endpoint", ["tcp/127.0.0.1:70000", "tls/127.0.0.1:0"])
def test_a_router_port_out_of_range_is_refused(endpoint: str) -> None:
    with pytest.raises(PortError, match="a port is a number from 1 to 65535"):
        check_router_endpoints([endpoint])


@pytest.mark.parametrize("endpoint", ["127.0.0.1:7447", "udp/127.0.0.1:7447", "tcp/[::1]:x"])
def test_endpoints_of_other_forms_are_left_to_zenoh(endpoint: str) -> None:
    check_router_endpoints([endpoint])
