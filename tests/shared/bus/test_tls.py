"""The TLS bus: a router that speaks only TLS, clients that prove who they are with a password
and (mutual TLS) a certificate from the cell's own CA."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.certificates import write_certificates
from motocell.shared.bus.credentials import CA_FILE, load, write_passwords
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import open_session
from motocell.testing.ports import listening
from motocell.testing.processes import wait_until

CELL = "c1"


@pytest.fixture
def tls_router(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    identities = cell_identities(1, face=False)
    write_passwords(tmp_path, CELL, identities)
    write_certificates(tmp_path, CELL, identities, ["127.0.0.1", "localhost"])

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint], cell=CELL, identities=identities, credentials=tmp_path, mutual_tls=True
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, router = listening(open_router, "tls")
    yield endpoint, tmp_path
    router.close()


def test_services_meet_over_mutual_tls(tls_router: tuple[str, Path]) -> None:
    endpoint, directory = tls_router
    sessions = [
        open_session("client", [endpoint], wait=False, credentials=load(directory, CELL, id_))
        for id_ in (Identity(Role.GATEWAY), Identity(Role.INTERPOLATOR))
    ]
    gateway, interpolator = sessions
    received: list[bytes] = []
    lock = threading.Lock()

    def keep(sample: zenoh.Sample) -> None:
        with lock:
            received.append(sample.payload.to_bytes())

    def arrived() -> bool:
        gateway.put("motocell/c1/group/0/point", b"p")
        with lock:
            return bool(received)

    try:
        subscriber = interpolator.declare_subscriber("motocell/c1/group/0/point", keep)
        wait_until(arrived, 5.0, "a point over mutual TLS")
        subscriber.undeclare()
    finally:
        for session in sessions:
            session.close()


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_a_client_without_a_certificate_is_refused(tls_router: tuple[str, Path]) -> None:
    endpoint, directory = tls_router
    credentials = load(directory, CELL, Identity(Role.OBSERVER))
    without_certificate = type(credentials)(
        credentials.user, credentials.password, ca=credentials.ca
    )
    with pytest.raises(ConnectionError):
        open_session("client", [endpoint], wait=False, credentials=without_certificate)


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_plain_tcp_is_not_served(tls_router: tuple[str, Path]) -> None:
    endpoint, directory = tls_router
    plain = endpoint.replace("tls/", "tcp/")
    credentials = load(directory, CELL, Identity(Role.OBSERVER))
    assert (directory / CA_FILE).is_file()
    with pytest.raises(ConnectionError):
        open_session("client", [plain], wait=False, credentials=credentials)
