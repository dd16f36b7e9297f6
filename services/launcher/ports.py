"""The ports a cell will listen on, tried before anything starts: a port out of range or
taken, or a host that is not this machine's, then costs one line and exit status 2, instead of
a service that fails and is restarted in a loop. Afterwards, whether the services listen.
"""

from __future__ import annotations

import errno
import socket
from collections.abc import Sequence

from motocell.services.launcher.core.tcp_ports import TcpPort
from motocell.shared.config import MAX_PORT


class PortError(Exception):
    """A port the cell needs cannot be had; the message says which, why and what to do."""


def check_tcp_ports(host: str, ports: Sequence[TcpPort]) -> None:
    """PortError unless every one of ``ports`` can be listened on at ``host``."""
    for wanted in ports:
        problem = bind_problem(host, wanted.port)
        if problem is not None:
            raise PortError(
                f"cannot listen on the {wanted.use} port {host}:{wanted.port}: {problem}"
                f"{_TCP_ADVICE.get(problem, '')}"
            )


TAKEN = "it is taken by another process"
NOT_HERE = "the address is not one of this machine's"
_TCP_ADVICE = {
    TAKEN: " (stop that process, or choose --port-base N: it needs N, N+1 and N+2 free)",
    NOT_HERE: " (--host takes 127.0.0.1, 0.0.0.0 or an address of this host)",
}


def check_router_endpoints(endpoints: Sequence[str]) -> None:
    """PortError unless every ``tcp/HOST:PORT`` (or ``tls/``) endpoint of ``endpoints`` can be
    listened on; endpoints of another form are left to Zenoh, whose refusal the router
    translates."""
    for endpoint in endpoints:
        protocol, _, address = endpoint.partition("/")
        host, _, port = address.rpartition(":")
        if protocol not in ("tcp", "tls") or not port.isdigit():
            continue
        problem = bind_problem(host.strip("[]"), int(port))
        if problem is not None:
            raise PortError(
                f"the cell's Zenoh router cannot listen on {endpoint}: {problem} "
                "(--zenoh-listen tcp/HOST:PORT chooses another)"
            )


def listening(host: str, ports: Sequence[TcpPort]) -> bool:
    """Every one of ``ports`` is taken at ``host``: after ``check_tcp_ports``, by the cell."""
    return all(bind_problem(host, wanted.port) is not None for wanted in ports)


def bind_problem(host: str, port: int) -> str | None:
    """Why a server socket cannot listen on ``host:port`` now, as the services bind (with
    SO_REUSEADDR); None when it can."""
    if not 1 <= port <= MAX_PORT:
        return f"a port is a number from 1 to {MAX_PORT}"
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except socket.gaierror as exc:
            return f"the host name does not resolve ({exc.strerror})"
        except OSError as exc:
            return _BIND_ERRORS.get(exc.errno or 0, exc.strerror or str(exc))
    return None


_BIND_ERRORS = {
    errno.EADDRINUSE: TAKEN,
    errno.EADDRNOTAVAIL: NOT_HERE,
    errno.EACCES: "ports below 1024 need privileges",
}
