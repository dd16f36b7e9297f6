"""The key map: every key a service builds is on exactly one route of the one table."""

from __future__ import annotations

import pytest

from motocell.shared.bus import catalog
from motocell.shared.bus.catalog import Op, Role
from motocell.shared.bus.keys import CellKeys, group_of
from motocell.shared.bus.schemas import Point, encode

KEYS = CellKeys("cell1")

BUILT = [
    (KEYS.controller_status, Op.PUT),
    (KEYS.controller_cmd("start_traj_mode"), Op.QUERY),
    (KEYS.controller_cmd("incmove_error"), Op.PUT),
    (KEYS.controller_cmd("connections"), Op.PUT),
    (KEYS.controller_fault("estop"), Op.QUERY),
    (KEYS.executor_tick, Op.PUT),
    (KEYS.executor_cmd("stop"), Op.QUERY),
    (KEYS.state, Op.PUT),
    (KEYS.group_point(2), Op.PUT),
    (KEYS.group_slot(2), Op.PUT),
    (KEYS.group_increments(2), Op.PUT),
    (KEYS.group_queue(2), Op.PUT),
    (KEYS.group_metrics(2), Op.PUT),
    (KEYS.metrics("executor"), Op.PUT),
    (KEYS.metrics("gateway"), Op.PUT),
    (KEYS.metrics("broadcaster"), Op.PUT),
    (KEYS.service_info("interpolator", "2"), Op.QUERY),
    (KEYS.alive("interpolator", "2"), Op.TOKEN),
    (KEYS.claim("interpolator", "2", "a1b2"), Op.TOKEN),
]


@pytest.mark.parametrize(("key", "op"), BUILT)
def test_every_built_key_is_on_a_route(key: str, op: Op) -> None:
    route = catalog.route_of(key)
    assert route is not None, key
    assert route.op is op


def test_an_exact_key_wins_over_a_wildcard() -> None:
    route = catalog.route_of(KEYS.controller_cmd("connections"))
    assert route is not None
    assert route.suffix == "controller/cmd/connections"
    assert route.senders == {Role.GATEWAY, Role.BROADCASTER}


def test_unknown_keys_have_no_route() -> None:
    assert catalog.route_of("motocell/cell1/group/0/nonsense") is None
    assert catalog.route_of("motocell/cell1/alive/gateway/0") is None  # tokens start with '@'
    assert catalog.decode("motocell/cell1/nonsense", b"\x90") is None


def test_observers_only_ever_ask_services_who_they_are() -> None:
    for route in catalog.ROUTES:
        if Role.OBSERVER in route.senders:
            assert route.suffix == "service/*/*" and route.op is Op.QUERY


def test_operators_act_only_on_faults_and_service_info() -> None:
    acting = {route.suffix for route in catalog.ROUTES if Role.OPERATOR in route.senders}
    assert acting == {"controller/fault/*", "service/*/*"}


def test_every_put_route_has_a_decoder_and_queries_have_replies() -> None:
    for route in catalog.ROUTES:
        if route.op is Op.PUT:
            assert catalog.PAYLOADS[route.suffix] is route.payload
        if route.op is Op.QUERY:
            assert route.reply is not None


def test_decode_uses_the_routes_payload() -> None:
    point = Point(7, 1, 0.5, [0.1] * 6, [0.0] * 6)
    assert catalog.decode(KEYS.group_point(1), encode(point)) == point


@pytest.mark.parametrize(
    ("key", "group"),
    [
        ("motocell/c1/group/0/point", 0),
        ("motocell/c1/group/1/increments", 1),
        ("motocell/c1/group/*/point", None),
        ("motocell/c1/group/2/point", None),
        ("motocell/c1/group/99999999999999999999/point", None),
        ("motocell/c1/group/01/point", None),
        ("motocell/c1/group/-1/point", None),
        ("motocell/c1/group/+1/point", None),
        ("motocell/c1/group/ 1/point", None),
        ("motocell/c1/group/\u0661/point", None),  # an Arabic-Indic one: int() takes it
        ("motocell/c1/group/$*/point", None),
        ("motocell/c1/group//point", None),
        ("motocell/c1/group/1", None),
        ("motocell/c1/executor/tick", None),
        ("motocell", None),
    ],
)
def test_a_group_is_read_from_a_key_only_when_the_cell_has_it(key: str, group: int | None) -> None:
    assert group_of(key, 2) == group
