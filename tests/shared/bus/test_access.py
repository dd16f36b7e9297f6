"""Access control derived from the key map: default deny, each identity its own keys only.

The pure tests read the generated rules; the router test opens a real Zenoh router with the
rules and password authentication and checks what actually gets through.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from motocell.shared.bus.access import (
    Identity,
    access_control,
    cell_identities,
    cell_parties,
    is_router_name,
    router_links,
    site_observer,
)
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import load, write_passwords
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.testing.ports import listening
from motocell.testing.processes import wait_until

CELL = "c1"


def allowed(config: dict[str, Any], identity: Identity | str, flow: str, message: str) -> set[str]:
    """The key expressions ``identity`` (or the party of that name) may use ``message`` on
    in ``flow``."""
    name = identity if isinstance(identity, str) else identity.username(CELL)
    policy = next(p for p in config["policies"] if p["id"] == name)
    rules = {rule["id"]: rule for rule in config["rules"]}
    return {
        key
        for rule_id in policy["rules"]
        if flow in rules[rule_id]["flows"] and message in rules[rule_id]["messages"]
        for key in rules[rule_id]["key_exprs"]
    }


CONFIG = access_control(cell_parties(CELL, cell_identities(2, face=False)), certificates=False)


def test_default_deny_and_one_subject_per_identity() -> None:
    assert CONFIG["default_permission"] == "deny"
    names = [subject["usernames"] for subject in CONFIG["subjects"]]
    assert ["c1.interpolator-1"] in names and ["c1.observer"] in names
    assert len(names) == len(cell_identities(2, face=False))
    assert not any("cert_common_names" in subject for subject in CONFIG["subjects"])


def test_with_certificates_a_subject_is_its_username_and_its_certificate_together() -> None:
    config = access_control(cell_parties(CELL, cell_identities(1, face=False)), certificates=True)
    for subject in config["subjects"]:
        assert subject["usernames"] == subject["cert_common_names"] == [subject["id"]]


def test_a_site_observer_watches_every_cell_and_acts_on_nothing() -> None:
    config = access_control([site_observer("site.observer")], certificates=True)
    name = "site.observer"
    assert allowed(config, name, "ingress", "declare_subscriber") >= {"motocell/*/**"}
    assert allowed(config, name, "ingress", "query") == {"motocell/*/service/*/*"}
    assert "@motocell/*/**" in allowed(config, name, "ingress", "liveliness_query")
    for message in ("put", "delete", "liveliness_token", "declare_queryable"):
        assert allowed(config, name, "ingress", message) == set(), message


def test_a_router_of_the_mesh_passes_everything_on_every_cell() -> None:
    config = access_control(router_links("site.router", "lab.router"), certificates=True)
    for name in ("site.router", "lab.router"):
        for flow in ("ingress", "egress"):
            for message in ("put", "query", "reply", "liveliness_token", "declare_subscriber"):
                assert allowed(config, name, flow, message) == {"motocell/**", "@motocell/**"}
    subjects = {subject["id"]: subject for subject in config["subjects"]}
    assert subjects["site.router"]["usernames"] == ["site.router"]
    # A router this one connected to shows its server certificate and logs in as no one.
    assert subjects["lab.router"] == {"id": "lab.router", "cert_common_names": ["lab.router"]}


def test_a_router_that_dials_no_other_has_no_subject_of_a_certificate_alone() -> None:
    config = access_control(router_links("site.router", None), certificates=True)
    (subject,) = config["subjects"]
    assert subject == {
        "id": "site.router",
        "usernames": ["site.router"],
        "cert_common_names": ["site.router"],
    }


@pytest.mark.parametrize(
    ("user", "router"),
    [
        ("lab.router", True),
        ("site.router", True),
        ("lab.observer", False),
        ("router", False),
        ("lab.routers", False),
    ],
)
def test_names_ending_in_router_are_routers(user: str, router: bool) -> None:
    assert is_router_name(user) is router


def test_an_interpolator_sends_only_on_its_own_group() -> None:
    puts = allowed(CONFIG, Identity(Role.INTERPOLATOR, "1"), "ingress", "put")
    assert "motocell/c1/group/1/increments" in puts
    assert not any("/group/0/" in key or "/group/*/" in key for key in puts)


def test_only_the_gateway_sends_points() -> None:
    for identity in cell_identities(2, face=False):
        puts = allowed(CONFIG, identity, "ingress", "put")
        sends_points = any(key.endswith("/point") for key in puts)
        assert sends_points == (identity.role is Role.GATEWAY), identity


def test_watchers_put_nothing_and_query_only_faults_or_service_info() -> None:
    for role in (Role.OBSERVER, Role.OPERATOR):
        identity = Identity(role)
        assert allowed(CONFIG, identity, "ingress", "put") == set()
        assert allowed(CONFIG, identity, "ingress", "liveliness_token") == set()
        queries = allowed(CONFIG, identity, "ingress", "query")
        expected = {"motocell/c1/service/*/*"}
        if role is Role.OPERATOR:
            expected.add("motocell/c1/controller/fault/*")
        assert queries == expected


def test_a_service_declares_only_its_own_token_and_info() -> None:
    identity = Identity(Role.EXECUTOR)
    assert allowed(CONFIG, identity, "ingress", "liveliness_token") == {
        "@motocell/c1/alive/executor/0",
        "@motocell/c1/claim/executor/0/*",
    }
    assert "motocell/c1/service/executor/0" in allowed(
        CONFIG, identity, "ingress", "declare_queryable"
    )


@pytest.fixture
def router(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    """A secured router for a one-group cell, as the launcher runs it."""
    write_passwords(tmp_path, CELL, cell_identities(1, face=False))

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint], cell=CELL, identities=cell_identities(1, face=False), credentials=tmp_path
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, session = listening(open_router)
    yield endpoint, tmp_path
    session.close()


def client(router: tuple[str, Path], role: Role, password: str | None = None) -> zenoh.Session:
    endpoint, directory = router
    credentials = load(directory, CELL, Identity(role))
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    config.insert_json5("transport/auth/usrpwd/user", json.dumps(credentials.user))
    config.insert_json5(
        "transport/auth/usrpwd/password", json.dumps(password or credentials.password)
    )
    return zenoh.open(config)


def test_the_router_lets_through_exactly_what_the_rules_say(router: tuple[str, Path]) -> None:
    interpolator = client(router, Role.INTERPOLATOR)
    gateway = client(router, Role.GATEWAY)
    observer = client(router, Role.OBSERVER)
    received: list[bytes] = []
    lock = threading.Lock()

    def keep(sample: zenoh.Sample) -> None:
        with lock:
            received.append(sample.payload.to_bytes())

    try:
        subscriber = interpolator.declare_subscriber("motocell/c1/group/0/point", keep)
        observer.put("motocell/c1/group/0/point", b"observer")
        wait_until(lambda: _put_arrives(gateway, received, lock), 5.0, "the gateway's point")
        assert b"observer" not in received
        subscriber.undeclare()
    finally:
        for session in (interpolator, gateway, observer):
            session.close()


def _put_arrives(gateway: zenoh.Session, received: list[bytes], lock: threading.Lock) -> bool:
    gateway.put("motocell/c1/group/0/point", b"gateway")
    with lock:
        return b"gateway" in received


def test_a_wrong_password_is_refused(router: tuple[str, Path]) -> None:
    with pytest.raises(zenoh.ZError):
        client(router, Role.GATEWAY, password="wrong")


def test_an_observer_subscribes_to_the_whole_cell_and_asks_every_service(
    router: tuple[str, Path],
) -> None:
    gateway = client(router, Role.GATEWAY)
    observer = client(router, Role.OBSERVER)
    received: list[str] = []
    lock = threading.Lock()

    def keep(sample: zenoh.Sample) -> None:
        with lock:
            received.append(str(sample.key_expr))

    def arrived() -> bool:
        gateway.put("motocell/c1/group/0/point", b"p")
        with lock:
            return "motocell/c1/group/0/point" in received

    def describe(query: zenoh.Query) -> None:
        query.reply("motocell/c1/service/gateway/0", b"info")
        query.drop()

    try:
        subscriber = observer.declare_subscriber("motocell/c1/**", keep)
        queryable = gateway.declare_queryable("motocell/c1/service/gateway/0", describe)
        wait_until(arrived, 5.0, "the point at a whole-cell subscriber")
        replies = list(observer.get("motocell/c1/service/*/*", timeout=2.0))
        assert [reply.ok.payload.to_bytes() for reply in replies if reply.ok] == [b"info"]
        queryable.undeclare()
        subscriber.undeclare()
    finally:
        for session in (gateway, observer):
            session.close()


def test_a_sender_on_every_group_sends_on_each_groups_key_and_never_on_a_wildcard() -> None:
    for role, message, suffix in (
        (Role.GATEWAY, "put", "point"),
        (Role.GATEWAY, "query", "slot"),
        (Role.EXECUTOR, "put", "queue"),
    ):
        keys = allowed(CONFIG, Identity(role), "ingress", message)
        groups = {key for key in keys if key.startswith("motocell/c1/group/")}
        assert groups == {f"motocell/c1/group/{g}/{suffix}" for g in range(2)}, role


def test_a_wildcard_in_a_group_chunk_is_refused_by_the_router(router: tuple[str, Path]) -> None:
    """The router of a one-group cell: a put on ``group/*/point`` or ``group/1/point`` from
    the gateway's identity never reaches a subscriber of every group's points, while one on
    ``group/0/point`` sent after them does."""
    executor = client(router, Role.EXECUTOR)
    gateway = client(router, Role.GATEWAY)
    received: list[str] = []
    lock = threading.Lock()

    def keep(sample: zenoh.Sample) -> None:
        with lock:
            received.append(str(sample.key_expr))

    def arrived() -> bool:
        gateway.put("motocell/c1/group/0/point", b"p")
        with lock:
            return "motocell/c1/group/0/point" in received

    try:
        subscriber = executor.declare_subscriber("motocell/c1/group/*/point", keep)
        wait_until(arrived, 5.0, "the gateway's point on group 0")
        with lock:
            received.clear()
        for key in ("motocell/c1/group/*/point", "motocell/c1/group/1/point"):
            gateway.put(key, b"forged")
        # The same session's puts arrive in order: the forged ones, had they passed, first.
        wait_until(arrived, 5.0, "a point on group 0 after the refused ones")
        with lock:
            assert set(received) == {"motocell/c1/group/0/point"}
        subscriber.undeclare()
    finally:
        for session in (executor, gateway):
            session.close()
