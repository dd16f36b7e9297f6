"""Fixtures for tests of the bus adapters: a real Zenoh router on a free loopback port (picked
again when taken before the router could bind it), and
client sessions of it, in the test's own process (no process started)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.access import cell_identities
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import open_session
from motocell.testing.ports import listening


@pytest.fixture
def endpoint() -> Iterator[str]:
    """A running router's endpoint, closed after the test."""
    listen, router = listening(
        lambda endpoint: zenoh.open(zenoh_config(router_settings([endpoint])))
    )
    yield listen
    router.close()


@pytest.fixture
def sessions(endpoint: str) -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    """Two client sessions of the router."""
    opened = [open_session("client", [endpoint], wait=False) for _ in range(2)]
    yield opened[0], opened[1]
    for session in opened:
        session.close()


def mutual_tls_router(directory: Path, cell: str) -> tuple[str, zenoh.Session]:
    """A router of ``cell`` (one group) with mutual TLS from the credentials in ``directory``,
    on a free loopback port: its endpoint, and the router, for the caller to close."""

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint],
            cell=cell,
            identities=cell_identities(1),
            credentials=directory,
            mutual_tls=True,
        )
        return zenoh.open(zenoh_config(settings))

    return listening(open_router, "tls")
