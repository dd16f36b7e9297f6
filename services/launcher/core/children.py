"""Which services a cell runs on this host, in start order, and the command line of each."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from motocell.shared.config import Cell
from motocell.shared.service_names import (
    PER_GROUP,
    ServiceName,
    UnknownServiceError,
    cell_services,
    parse_service,
    service_module,
)

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
    new_bus: bool = False
    """The services join the secured router this launcher has just opened: nobody else can be
    claiming their names, so each one's first start holds its claim at once (``--new-bus``)."""


@dataclass(frozen=True)
class ChildSpec:
    service: ServiceName
    argv: tuple[str, ...]
    first_start: tuple[str, ...] = ()
    """Arguments for the first start only: a restart joins a bus others may have joined since,
    so its claim settles."""

    def argv_for(self, *, restart: bool) -> tuple[str, ...]:
        return self.argv if restart else self.argv + self.first_start

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
        argv = (*python, service_module(name.service), *common, *extra)
        specs.append(ChildSpec(name, argv, ("--new-bus",) if options.new_bus else ()))
    return specs


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
