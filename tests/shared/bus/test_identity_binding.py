"""A certificate proves the identity (docs/security.md, Identities): on a mutual-TLS bus a
session is the gateway only with the gateway's password AND the gateway's certificate.

A real secured router (TLS only, mutual TLS, passwords, the cell's access control) and a party
acting as the controller: it publishes its status, answers its info query, holds its liveliness
token and takes the connection counts the gateway puts. Each combination of password and
certificate tries all four; a session with the right pair does the same alongside, and only
once everything reached it is the other one's share counted, so a loaded machine cannot make
an absence look like a refusal.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.certificates import write_certificates
from motocell.shared.bus.credentials import Credentials, load, write_passwords
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import open_session
from motocell.testing.ports import listening
from motocell.testing.processes import wait_until

CELL = "c1"
KEYS = CellKeys(CELL)
DEADLINE_S = 30.0
"""For what an idle machine does in milliseconds: a bound for a hang, not a speed."""
EXTRA_ROUNDS = 5
"""Statuses and puts the right session must see after its first: the wrong one had as long."""


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[Bus]:
    """The router, and the controller's side of every operation."""
    identities = cell_identities(1)
    write_passwords(tmp_path, CELL, identities)
    write_certificates(tmp_path, CELL, identities, ["127.0.0.1"])

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint], cell=CELL, identities=identities, credentials=tmp_path, mutual_tls=True
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, router = listening(open_router, "tls")
    controller = join(endpoint, load(tmp_path, CELL, Identity(Role.CONTROLLER)))
    connections = Received()
    subscriber = controller.declare_subscriber(KEYS.controller_cmd("connections"), connections.keep)
    queryable = controller.declare_queryable(
        KEYS.service_info("controller", "0"), lambda query: query.reply(query.key_expr, b"i")
    )
    token = controller.liveliness().declare_token(KEYS.alive("controller", "0"))
    try:
        yield Bus(endpoint, tmp_path, controller, connections)
    finally:
        token.undeclare()
        queryable.undeclare()
        subscriber.undeclare()
        controller.close()
        router.close()


def join(endpoint: str, credentials: Credentials) -> zenoh.Session:
    return open_session("client", [endpoint], wait=False, credentials=credentials)


@dataclass
class Received:
    payloads: list[bytes] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def keep(self, sample: zenoh.Sample) -> None:
        with self.lock:
            self.payloads.append(sample.payload.to_bytes())

    def count(self, payload: bytes | None = None) -> int:
        with self.lock:
            return sum(payload is None or p == payload for p in self.payloads)


@dataclass
class Bus:
    endpoint: str
    directory: Path
    controller: zenoh.Session
    """Acts as the controller: publishes its status, answers its info, holds its token."""
    connections: Received
    """What reached the controller's connection counts."""


class Party:
    """A session trying all four operations on the controller's keys."""

    def __init__(self, session: zenoh.Session, name: bytes) -> None:
        self.session = session
        self.name = name
        self.statuses = Received()
        self.tokens = Received()
        self.answers = 0
        self._declared = [
            session.declare_subscriber(KEYS.controller_status, self.statuses.keep),
            session.liveliness().declare_subscriber(KEYS.alive_all, self._token, history=True),
        ]

    def _token(self, sample: zenoh.Sample) -> None:
        self.tokens.keep(sample)

    def act(self) -> None:
        """Put a connection count and ask the controller's info once."""
        self.session.put(KEYS.controller_cmd("connections"), self.name)
        replies = self.session.get(KEYS.service_info("controller", "0"), timeout=DEADLINE_S)
        self.answers += sum(reply.ok is not None for reply in replies)

    def close(self) -> None:
        for entity in self._declared:
            entity.undeclare()
        self.session.close()


def credentials(bus: Bus, user_of: Role, certificate_of: Role | None) -> Credentials:
    """``user_of``'s username and password with ``certificate_of``'s certificate (None: no
    client certificate)."""
    user = load(bus.directory, CELL, Identity(user_of))
    holder = load(bus.directory, CELL, Identity(certificate_of or user_of))
    if certificate_of is None:
        return Credentials(user.user, user.password, user.ca)
    return Credentials(user.user, user.password, user.ca, holder.certificate, holder.key)


def exercise(bus: Bus, *parties: Party) -> None:
    """Every party acts, the controller publishes, until the last party (the right one) has
    its put delivered, its query answered, the token seen and EXTRA_ROUNDS statuses."""
    right = parties[-1]

    def everything_reached_the_right_one() -> bool:
        for party in parties:
            party.act()
        bus.controller.put(KEYS.controller_status, b"status")
        return (
            bus.connections.count(right.name) > EXTRA_ROUNDS
            and right.statuses.count() > EXTRA_ROUNDS
            and right.answers > EXTRA_ROUNDS
            and right.tokens.count() > 0
        )

    wait_until(everything_reached_the_right_one, DEADLINE_S, "the right session's operations")


def test_the_right_password_and_certificate_do_everything_the_identity_may(bus: Bus) -> None:
    gateway = Party(join(bus.endpoint, credentials(bus, Role.GATEWAY, Role.GATEWAY)), b"gateway")
    try:
        exercise(bus, gateway)
    finally:
        gateway.close()


@pytest.mark.parametrize(
    ("user_of", "certificate_of"),
    [(Role.OBSERVER, Role.GATEWAY), (Role.GATEWAY, Role.OBSERVER)],
    ids=["another-password-this-certificate", "this-password-another-certificate"],
)
def test_a_password_and_a_certificate_of_two_identities_get_nothing(
    bus: Bus, user_of: Role, certificate_of: Role
) -> None:
    """The router admits the session (both credentials are the cell's), but it is no one."""
    mixed = Party(join(bus.endpoint, credentials(bus, user_of, certificate_of)), b"mixed")
    right = Party(join(bus.endpoint, credentials(bus, Role.GATEWAY, Role.GATEWAY)), b"right")
    try:
        exercise(bus, mixed, right)
        assert bus.connections.count(b"mixed") == 0, "its put was delivered"
        assert mixed.statuses.count() == 0, "its subscription was served"
        assert mixed.answers == 0, "its query was answered"
        assert mixed.tokens.count() == 0, "it saw a liveliness token"
    finally:
        mixed.close()
        right.close()


@pytest.mark.cell  # a refused TLS session waits (PROBE_S alone): tests/lanes.py
@pytest.mark.parametrize("alone", ["certificate", "password"])
def test_a_certificate_or_a_password_alone_is_refused(bus: Bus, alone: str) -> None:
    gateway = credentials(bus, Role.GATEWAY, Role.GATEWAY)
    if alone == "certificate":
        only = Credentials("", "", gateway.ca, gateway.certificate, gateway.key)
    else:
        only = Credentials(gateway.user, gateway.password, gateway.ca)
    # What the refusal says is the session's (shared/bus/session.py); that it is refused is ours.
    with pytest.raises(ConnectionError):
        join(bus.endpoint, only)
