"""The Simple Message ports a cell's services listen on here, and which ``--port-base`` can be
a cell's."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from motocell.shared.config import MAX_PORT, MAX_PORT_BASE, PORT_COUNT, Cell
from motocell.shared.service_names import ServiceName

PORT_BASE_AUTO = "auto"
"""``--port-base auto``: three free ports, chosen at start; the ready line and the registry
(``motocell ps``) name them."""


@dataclass(frozen=True)
class TcpPort:
    use: str
    """``motion``, ``state`` or ``I/O``."""
    port: int


def tcp_ports(cell: Cell, services: Sequence[ServiceName]) -> list[TcpPort]:
    """The Simple Message ports ``services`` will listen on (a skipped service's ports are
    another host's business), in port order."""
    kinds = {name.service for name in services}
    ports = []
    if "gateway" in kinds:
        ports += [TcpPort("motion", cell.motion_port), TcpPort("I/O", cell.io_port)]
    if "broadcaster" in kinds:
        ports.append(TcpPort("state", cell.state_port))
    return sorted(ports, key=lambda p: p.port)


def port_base_problem(given: str) -> str | None:
    """Why ``--port-base given`` cannot be a cell's, or None: ``auto``, or a number whose
    state and I/O ports (N+1, N+2) exist too. 0 is refused, not taken for the default."""
    if given == PORT_BASE_AUTO:
        return None
    how = f"`--port-base {PORT_BASE_AUTO}` picks three free ports and the ready line prints them"
    try:
        port_base = int(given)
    except ValueError:
        return f"--port-base {given} is not a number: give the motion port N, or {how}"
    if 1 <= port_base <= MAX_PORT_BASE:
        return None
    return (
        f"--port-base {port_base} is out of range: the motion, state and I/O ports "
        f"({port_base}-{port_base + PORT_COUNT - 1}) must lie within 1-{MAX_PORT}; {how}"
    )
