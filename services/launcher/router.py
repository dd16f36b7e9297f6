"""Zenoh routers: a cell's own on loopback, and a standalone one (``motocell router``).

Every service of a local cell connects to its launcher's router as a client; multicast
scouting, gossip and the admin space stay off (shared.bus.router), so cells meet only through
these explicit endpoints.
"""

from __future__ import annotations

import logging
import resource
from collections.abc import Collection, Sequence
from pathlib import Path

import zenoh

from motocell.services.launcher.core.endpoints import (
    WELL_KNOWN_ENDPOINT,
    WELL_KNOWN_PORT,
    router_endpoints,
)
from motocell.shared.bus.access import cell_identities
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.runtime import zenoh_runtime
from motocell.shared.bus.session import zenoh_problem
from motocell.shared.config import Cell
from motocell.shared.ports import free_port_besides, port_free
from motocell.shared.service import StopFlag

log = logging.getLogger("motocell")


def cell_router_endpoints(
    listen: Sequence[str], *, secured: bool, tcp_ports: Collection[int]
) -> tuple[list[str], list[str]]:
    """(listen, connect) for a cell's own router, from what is free on this machine and none
    of ``tcp_ports``, the cell's own, picked already but bound only once its services start."""
    well_known_free = WELL_KNOWN_PORT not in tcp_ports and port_free(WELL_KNOWN_PORT)
    return router_endpoints(
        listen, well_known_free, lambda: free_port_besides(tcp_ports), link=not secured
    )


def open_cell_router(
    cell: Cell, listen: Sequence[str], connect: Sequence[str], credentials: Path | None
) -> zenoh.Session:
    """The cell's router: secured with ``credentials`` (passwords, ACL), else open."""
    settings = router_settings(
        listen,
        connect,
        cell=cell.name if credentials else None,
        identities=cell_identities(len(cell.groups), face=cell.ros2 is not None),
        credentials=credentials,
    )
    try:
        with zenoh_runtime():
            return zenoh.open(zenoh_config(settings))
    except zenoh.ZError as exc:
        raise ConnectionError(
            f"the cell's Zenoh router cannot listen on {', '.join(listen)}: "
            f"{zenoh_problem(exc)} (--zenoh-listen tcp/HOST:PORT says where)"
        ) from None


def serve_router(
    listen: Sequence[str], connect: Sequence[str], stop: StopFlag, config_file: str | None = None
) -> None:
    """A router in this process until ``stop``: a stand-in for zenohd. Open, on ``listen``;
    or exactly as ``config_file`` says (``zenohd -c``)."""
    listen = list(listen) or [WELL_KNOWN_ENDPOINT]
    settings = router_settings(listen, connect)
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (open_files_limit(soft, hard), hard))
    where = config_file or ", ".join(listen)
    try:
        config = zenoh.Config.from_file(config_file) if config_file else zenoh_config(settings)
        with zenoh_runtime():
            session = zenoh.open(config)
    except zenoh.ZError as exc:
        raise ConnectionError(
            f"cannot run a Zenoh router from {where}: {zenoh_problem(exc)}"
        ) from None
    log.info("Zenoh router running (%s)", where)
    stop.wait()
    session.close()


OPEN_FILES_CAP = 1 << 20
"""Descriptors ``motocell router`` asks for when its hard limit is unlimited."""


def open_files_limit(soft: int, hard: int) -> int:
    """The soft open-files limit a standalone router takes: its hard limit, or
    ``OPEN_FILES_CAP`` where that is unlimited. Each session it serves holds a socket, and the
    soft limit many systems start a process with (1024) is 165 single-arm cells on a site's
    router."""
    if hard != resource.RLIM_INFINITY:
        return hard
    return soft if soft == resource.RLIM_INFINITY else max(soft, OPEN_FILES_CAP)
