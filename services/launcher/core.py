"""The launcher's decisions, no processes: which services a cell runs and with which command
lines, where its router listens, and when a child that died comes back."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum

from shared.config import EXIT_CONFIG, Cell

WELL_KNOWN_PORT = 7447
"""The first cell on a machine takes it, so observers find that cell with no arguments."""
WELL_KNOWN_ENDPOINT = f"tcp/127.0.0.1:{WELL_KNOWN_PORT}"
RESTART_DELAY_S = 1.0


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
    skip: tuple[str, ...] = ()
    """Services another host runs, by name (``interpolator/1``)."""


@dataclass(frozen=True)
class ChildSpec:
    name: str
    """The service and, for interpolators, its group: ``controller``, ``interpolator/1``."""
    argv: tuple[str, ...]


class UnknownServiceError(ValueError):
    """``--skip`` named a service the cell does not have."""


def child_specs(
    cell: Cell, options: UpOptions, endpoint: str, python: Sequence[str]
) -> list[ChildSpec]:
    """The services this host runs for ``cell``, each connecting to Zenoh at ``endpoint``:
    controller, executor, broadcaster, one interpolator per group, gateway; less the skipped.
    ``python`` runs a module (``[sys.executable, "-m"]``)."""
    common = ["--zenoh-connect", endpoint]
    if options.config:
        common += ["--config", options.config]
    if options.name:
        common += ["--name", options.name]
    if options.credentials:
        common += ["--credentials", options.credentials]

    def spec(name: str, module: str, *extra: str) -> ChildSpec:
        return ChildSpec(name, (*python, f"services.{module}", *common, *extra))

    ports = _port_options(options)
    specs = [spec(service, service) for service in ("controller", "executor")]
    specs.append(spec("broadcaster", "broadcaster", *ports))
    specs += [
        spec(f"interpolator/{g.index}", "interpolator", "--group", str(g.index))
        for g in cell.groups
    ]
    specs.append(spec("gateway", "gateway", *ports))
    unknown = set(options.skip) - {s.name for s in specs}
    if unknown:
        raise UnknownServiceError(
            f"--skip {', '.join(sorted(unknown))}: no such service in this cell "
            f"(services: {', '.join(s.name for s in specs)})"
        )
    return [s for s in specs if s.name not in options.skip]


def _port_options(options: UpOptions) -> list[str]:
    """Where the TCP ports are and their byte order: the gateway's motion and I/O ports, the
    broadcaster's state port."""
    extra = []
    if options.host:
        extra += ["--host", options.host]
    if options.port_base:
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
