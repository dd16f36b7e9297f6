"""Zenoh routers: a cell's own on loopback, and a standalone one (``motocell router``).

Every service of a local cell connects to its launcher's router; multicast scouting stays
off (shared.bus.session), so cells meet only through these explicit endpoints.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import zenoh

from services.launcher.core import WELL_KNOWN_ENDPOINT, WELL_KNOWN_PORT, router_endpoints
from shared.bus.session import open_session
from shared.ports import free_port, port_free
from shared.service import StopFlag

log = logging.getLogger("motocell")


def open_cell_router(listen: Sequence[str]) -> tuple[zenoh.Session, str]:
    """The cell's router, and the endpoint its services should connect to."""
    listen, connect = router_endpoints(listen, port_free(WELL_KNOWN_PORT), free_port)
    # Not waiting: a router retries an absent link in the background.
    session = open_session("router", connect, listen, wait=False)
    return session, listen[0]


def serve_router(listen: Sequence[str], connect: Sequence[str], stop: StopFlag) -> None:
    """A router in this process until ``stop``: a stand-in for zenohd."""
    listen = list(listen) or [WELL_KNOWN_ENDPOINT]
    session = open_session("router", connect, listen)
    log.info("Zenoh router listening on %s", ", ".join(listen))
    stop.wait()
    session.close()
