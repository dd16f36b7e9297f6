"""The launcher's decisions, no processes: which services a cell runs and with which command
lines, where its router listens, and when a child that died comes back."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum

from motocell.shared.config import EXIT_CONFIG, MAX_PORT, MAX_PORT_BASE, PORT_COUNT, Cell
from motocell.shared.service_names import (
    PER_GROUP,
    ServiceName,
    UnknownServiceError,
    cell_services,
    parse_service,
)

WELL_KNOWN_PORT = 7447
"""The first cell on a machine takes it, so observers find that cell with no arguments."""
WELL_KNOWN_ENDPOINT = f"tcp/127.0.0.1:{WELL_KNOWN_PORT}"
RESTART_DELAY_S = 1.0
PORT_BASE_AUTO = "auto"
"""``--port-base auto``: three free ports, chosen at start; the ready line and the registry
(``motocell ps``) name them."""
TCP_SERVICES = ("broadcaster", "gateway")
"""They serve the Simple Message ports: the state port, and the motion and I/O ports."""


@dataclass(frozen=True)
class UpOptions:
    """What ``up`` was told that shapes its children's command lines (None: not given)."""

    config: str | None = None
    name: str | None = None
    """Overrides the cell file's name."""
    credentials: str | None = None
    """The cell's credentials directory; None on an open bus."""
    host: str | None = None
    port_base: int | None = None
    byte_order: str | None = None


@dataclass(frozen=True)
class ChildSpec:
    service: ServiceName
    argv: tuple[str, ...]

    @property
    def name(self) -> str:
        """As logs, ``motocell watch`` and ``--skip`` write it: ``gateway/0``."""
        return str(self.service)


CONTROLLER = str(ServiceName("controller", "0"))
EXECUTOR = str(ServiceName("executor", "0"))


def services_here(cell: Cell, skip: Sequence[str]) -> list[ServiceName]:
    """The services of ``cell`` this host runs, in start order: all but those ``skip`` names
    (``interpolator/1``, ``gateway``); UnknownServiceError for a name the cell lacks."""
    try:
        skipped = {parse_service(text, cell) for text in skip}
    except UnknownServiceError as exc:
        raise UnknownServiceError(f"--skip: {exc}") from None
    return [name for name in cell_services(cell) if name not in skipped]


def child_specs(
    services: Sequence[ServiceName],
    options: UpOptions,
    endpoints: Sequence[str],
    python: Sequence[str],
) -> list[ChildSpec]:
    """The command lines of ``services``, each connecting to Zenoh at ``endpoints`` (several:
    the routers of a site's mesh, any one of which serves). ``python`` runs a module
    (``[sys.executable, "-m"]``)."""
    common = [option for endpoint in endpoints for option in ("--zenoh-connect", endpoint)]
    if options.config:
        common += ["--config", options.config]
    if options.name:
        common += ["--name", options.name]
    if options.credentials:
        common += ["--credentials", options.credentials]
    specs = []
    for name in services:
        if name.service == PER_GROUP:
            extra = ["--group", name.instance]
        elif name.service in TCP_SERVICES:
            extra = _port_options(options)
        else:
            extra = []
        specs.append(
            ChildSpec(name, (*python, f"motocell.services.{name.service}", *common, *extra))
        )
    return specs


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


def _port_options(options: UpOptions) -> list[str]:
    """Where the TCP ports are and their byte order: the gateway's motion and I/O ports, the
    broadcaster's state port."""
    extra = []
    if options.host:
        extra += ["--host", options.host]
    if options.port_base is not None:
        extra += ["--port-base", str(options.port_base)]
    if options.byte_order:
        extra += ["--byte-order", options.byte_order]
    return extra


def router_endpoints(
    listen: Sequence[str], well_known_free: bool, spare_port: Callable[[], int], *, link: bool
) -> tuple[list[str], list[str]]:
    """(listen, connect) endpoints of a cell's own router. Unless told where to listen, the
    first cell on a machine takes the well-known port and a later one a spare port. On an
    open bus (``link``) a later cell's router also links to the first, so one observer on the
    well-known port sees every cell; a secured cell's router links to nothing: its access
    control knows only its own cell, and observers find each cell through the registry."""
    if listen:
        return list(listen), []
    if well_known_free:
        return [WELL_KNOWN_ENDPOINT], []
    return [f"tcp/127.0.0.1:{spare_port()}"], [WELL_KNOWN_ENDPOINT] if link else []


class Restart(Enum):
    GIVE_UP = "give up"
    """It exited because it cannot start as configured (EXIT_CONFIG): stop the cell."""
    NOTICED = "noticed"
    """Just found dead: report it; it comes back after the delay."""
    WAIT = "wait"
    NOW = "now"


class RestartPolicy:
    """A dead child is restarted ``delay_s`` after it was found dead, for as long as the
    launcher runs. Meanwhile the controller sees its liveliness token gone and the cell
    answers NOT_READY; the delay keeps a child that dies at once from spinning."""

    def __init__(self, delay_s: float = RESTART_DELAY_S) -> None:
        self.delay_s = delay_s
        self._restart_at: dict[str, float] = {}

    def dead(self, name: str, now: float, returncode: int | None = None) -> Restart:
        """What to do about child ``name``, found dead at ``now`` (seconds, any clock) with
        ``returncode``."""
        if returncode == EXIT_CONFIG:
            return Restart.GIVE_UP
        restart_at = self._restart_at.get(name)
        if restart_at is None:
            self._restart_at[name] = now + self.delay_s
            return Restart.NOTICED
        if now < restart_at:
            return Restart.WAIT
        del self._restart_at[name]
        return Restart.NOW

    def next_restart(self) -> float | None:
        """When the earliest restart waiting is due (None: none waits)."""
        return min(self._restart_at.values(), default=None)
