"""A refused session says why, in one line, against a real router: nothing listening, the
router's certificate not trusted (another CA, another name, expired), ours refused (none,
another CA, expired), a wrong password, the wrong protocol. Zenoh's own error is the same
for all of them."""

from __future__ import annotations

import contextlib
import dataclasses
import io
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import Credentials, load
from motocell.shared.bus.refusal import tls_problem
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import NoRouterError, open_session
from motocell.shared.ports import free_port
from motocell.testing.ports import listening
from motocell.tools.cli import build_parser
from tests.certificates import expire_in

CELL = "lab"


def credentials_directory(directory: Path, *options: str) -> Path:
    """What `motocell credentials DIR --cell lab OPTIONS` writes."""
    args = build_parser().parse_args(["credentials", str(directory), "--cell", CELL, *options])
    with contextlib.redirect_stdout(io.StringIO()):
        assert args.run(args) == 0
    return directory


@contextlib.contextmanager
def router(credentials: Path, scheme: str = "tls") -> Iterator[str]:
    """A router with the cell's access rules on a free port (``scheme`` tls: mutual TLS): its
    endpoint."""

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint],
            cell=CELL,
            identities=cell_identities(1),
            credentials=credentials,
            mutual_tls=scheme == "tls",
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, session = listening(open_router, scheme)
    try:
        yield endpoint
    finally:
        session.close()


@pytest.fixture
def site(tmp_path: Path) -> Path:
    return credentials_directory(tmp_path / "site", "--tls", "--host", "127.0.0.1")


@pytest.fixture
def elsewhere(tmp_path: Path) -> Path:
    """Another directory's credentials, of the same cell name: another CA."""
    return credentials_directory(tmp_path / "elsewhere", "--tls", "--host", "127.0.0.1")


def observer(directory: Path) -> Credentials:
    return load(directory, CELL, Identity(Role.OBSERVER))


def refusal(endpoint: str, credentials: Credentials | None) -> str:
    with pytest.raises(ConnectionError) as refused:
        open_session("client", [endpoint], wait=False, credentials=credentials).close()
    return str(refused.value)


def test_nothing_listening(site: Path) -> None:
    with pytest.raises(NoRouterError, match="no Zenoh router answers at"):
        open_session(
            "client", [f"tls/127.0.0.1:{free_port()}"], credentials=observer(site), wait=False
        )


def test_the_right_credentials_join(site: Path) -> None:
    with router(site) as endpoint:
        open_session("client", [endpoint], wait=False, credentials=observer(site)).close()


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_a_router_certificate_of_another_ca(site: Path, elsewhere: Path) -> None:
    with router(site) as endpoint:
        theirs = dataclasses.replace(observer(site), ca=observer(elsewhere).ca)
        assert f"the router's TLS certificate at {endpoint} is not from the CA in" in refusal(
            endpoint, theirs
        )


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_a_router_certificate_for_another_name(site: Path) -> None:
    with router(site) as endpoint:
        port = endpoint.rsplit(":", 1)[1]
        message = refusal(f"tls/localhost:{port}", observer(site))
    assert "is not valid for the name localhost" in message
    assert "motocell credentials DIR --host localhost" in message


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_an_expired_router_certificate(site: Path) -> None:
    expire_in(site, "router.pem", -0.5)
    with router(site) as endpoint:
        assert "has expired: renew it" in refusal(endpoint, observer(site))


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_no_client_certificate(site: Path) -> None:
    with router(site) as endpoint:
        without = dataclasses.replace(observer(site), certificate=None, key=None)
        assert f"refused {CELL}.observer: it requires a client certificate" in refusal(
            endpoint, without
        )


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_a_client_certificate_of_another_ca(site: Path, elsewhere: Path) -> None:
    theirs = observer(elsewhere)
    mixed = dataclasses.replace(observer(site), certificate=theirs.certificate, key=theirs.key)
    with router(site) as endpoint:
        assert f"refused {CELL}.observer's certificate" in refusal(endpoint, mixed)


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_an_expired_client_certificate(site: Path) -> None:
    expire_in(site, f"{CELL}.observer.pem", -0.5)
    with router(site) as endpoint:
        assert "certificate: it has expired" in refusal(endpoint, observer(site))


@pytest.mark.cell  # waits PROBE_S for an alert that never comes: tests/lanes.py
def test_a_wrong_password_over_tls(site: Path) -> None:
    with router(site) as endpoint:
        wrong = dataclasses.replace(observer(site), password="not-it")
        assert f"refused {CELL}.observer: wrong password" in refusal(endpoint, wrong)


def test_a_wrong_password_over_tcp(tmp_path: Path) -> None:
    passwords = credentials_directory(tmp_path / "c")
    with router(passwords, "tcp") as endpoint:
        wrong = dataclasses.replace(observer(passwords), password="not-it")
        assert f"refused {CELL}.observer: wrong password" in refusal(endpoint, wrong)


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_tcp_to_a_tls_router(site: Path) -> None:
    with router(site) as endpoint:
        port = endpoint.rsplit(":", 1)[1]
        message = refusal(f"tcp/127.0.0.1:{port}", observer(site))
    assert f"speaks TLS: connect to tls/127.0.0.1:{port}" in message


@pytest.mark.cell  # waits PROBE_S for a handshake that never comes: tests/lanes.py
def test_tls_to_a_tcp_router(tmp_path: Path, site: Path) -> None:
    """The probe alone: Zenoh itself gives up on that handshake only after 10 s."""
    passwords = credentials_directory(tmp_path / "c")
    with router(passwords, "tcp") as endpoint:
        port = endpoint.rsplit(":", 1)[1]
        message = tls_problem(f"tls/127.0.0.1:{port}", observer(site))
    assert message == (
        f"the router at tls/127.0.0.1:{port} does not answer a TLS handshake: if it speaks "
        f"plain TCP, connect to tcp/127.0.0.1:{port}"
    )
