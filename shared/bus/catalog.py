"""The cell's key map: every key, what travels on it, who may send it and who receives it.

This table is the one place that knows the bus. Observers decode any sample through it, the
tests check every key a service builds against it, and access control is derived from it: a
role may do on a key exactly what its route lists, nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import msgspec

from motocell.shared.bus.schemas import (
    BroadcasterMetrics,
    CommandReply,
    CommandRequest,
    ControllerStatus,
    ExecutorMetrics,
    GatewayMetrics,
    IncrementBatch,
    InterpolatorMetrics,
    LateTicks,
    MotionRequest,
    MotionResponse,
    Point,
    QueueState,
    ServiceInfo,
    Slot,
    State,
    Tick,
)


class Op(StrEnum):
    """How a key is used."""

    PUT = "put"
    """Senders publish, receivers subscribe."""
    QUERY = "query"
    """Senders query, receivers declare the queryable and reply."""
    TOKEN = "token"
    """Senders declare a liveliness token, receivers watch liveliness."""


class Role(StrEnum):
    """Who acts on a cell's bus: its services, and the two kinds of outside tool."""

    CONTROLLER = "controller"
    EXECUTOR = "executor"
    BROADCASTER = "broadcaster"
    GATEWAY = "gateway"
    INTERPOLATOR = "interpolator"
    ROS2 = "ros2"
    """The ROS 2 face (``services/ros2``): MotoROS2's topics from the cell's state."""
    OPERATOR = "operator"
    """Injects faults (``motocell fault``, tests); acts only on the fault keys."""
    OBSERVER = "observer"
    """Watches (``ps``, ``watch``, ``record``): receives, never sends anything that acts."""


SERVICES = frozenset(
    {Role.CONTROLLER, Role.EXECUTOR, Role.BROADCASTER, Role.GATEWAY, Role.INTERPOLATOR, Role.ROS2}
)
WATCHERS = frozenset({Role.OBSERVER, Role.OPERATOR})


@dataclass(frozen=True)
class Route:
    suffix: str
    """The key after ``motocell/<cell>/`` (``@motocell/<cell>/`` for tokens); ``*`` is one
    level: a group number, a verb, a service name or an instance."""
    op: Op
    payload: type[msgspec.Struct] | None
    """What a put carries, or a query's request; None for tokens."""
    senders: frozenset[Role]
    receivers: frozenset[Role]
    reply: type[msgspec.Struct] | None = None
    """A query's reply."""


def _roles(*roles: Role) -> frozenset[Role]:
    return frozenset(roles)


CONTROLLER, EXECUTOR, BROADCASTER = Role.CONTROLLER, Role.EXECUTOR, Role.BROADCASTER
GATEWAY, INTERPOLATOR, ROS2 = Role.GATEWAY, Role.INTERPOLATOR, Role.ROS2

ROUTES: tuple[Route, ...] = (
    Route(
        "controller/status",
        Op.PUT,
        ControllerStatus,
        _roles(CONTROLLER),
        _roles(EXECUTOR, BROADCASTER, GATEWAY, INTERPOLATOR, ROS2) | WATCHERS,
    ),
    Route(
        "controller/cmd/*",
        Op.QUERY,
        CommandRequest,
        _roles(GATEWAY, EXECUTOR),
        _roles(CONTROLLER),
        CommandReply,
    ),
    Route(
        "controller/cmd/incmove_error",
        Op.PUT,
        CommandReply,
        _roles(EXECUTOR),
        _roles(CONTROLLER) | WATCHERS,
    ),
    Route(
        "controller/cmd/connections",
        Op.PUT,
        CommandRequest,
        _roles(GATEWAY, BROADCASTER),
        _roles(CONTROLLER) | WATCHERS,
    ),
    Route(
        "controller/fault/*",
        Op.QUERY,
        CommandRequest,
        _roles(Role.OPERATOR),
        _roles(CONTROLLER),
        CommandReply,
    ),
    Route(
        "group/*/point",
        Op.PUT,
        Point,
        _roles(GATEWAY),
        # The executor only counts them: what it has been promised (IncrementBatch.through).
        _roles(INTERPOLATOR, EXECUTOR) | WATCHERS,
    ),
    Route("group/*/slot", Op.PUT, Slot, _roles(INTERPOLATOR), _roles(GATEWAY) | WATCHERS),
    # The slot as it is now, for a gateway that starts or lost track of it: the interpolator
    # publishes it only when it changes.
    Route("group/*/slot", Op.QUERY, None, _roles(GATEWAY), _roles(INTERPOLATOR), Slot),
    Route(
        "group/*/increments",
        Op.PUT,
        IncrementBatch,
        _roles(INTERPOLATOR),
        _roles(EXECUTOR) | WATCHERS,
    ),
    Route(
        "group/*/queue",
        Op.PUT,
        QueueState,
        _roles(EXECUTOR),
        _roles(GATEWAY, INTERPOLATOR) | WATCHERS,
    ),
    Route("group/*/metrics", Op.PUT, InterpolatorMetrics, _roles(INTERPOLATOR), WATCHERS),
    Route(
        "executor/tick", Op.PUT, Tick, _roles(EXECUTOR), _roles(CONTROLLER, BROADCASTER) | WATCHERS
    ),
    Route(
        "executor/cmd/stop",
        Op.QUERY,
        CommandRequest,
        _roles(GATEWAY),
        _roles(EXECUTOR),
        CommandReply,
    ),
    Route("executor/metrics", Op.PUT, ExecutorMetrics, _roles(EXECUTOR), WATCHERS),
    Route("executor/late", Op.PUT, LateTicks, _roles(EXECUTOR), WATCHERS),
    # Where the robot was at the newest tick the broadcaster had: a restarted executor resumes
    # there (the broadcaster follows every tick anyway; nobody else needs them all).
    Route(
        "broadcaster/cmd/positions",
        Op.QUERY,
        CommandRequest,
        _roles(EXECUTOR),
        _roles(BROADCASTER),
        CommandReply,
    ),
    # The ROS 2 face's requests to the cell's one motion API (the gateway's handlers).
    Route(
        "gateway/cmd/motion",
        Op.QUERY,
        MotionRequest,
        _roles(ROS2),
        _roles(GATEWAY),
        MotionResponse,
    ),
    Route("gateway/metrics", Op.PUT, GatewayMetrics, _roles(GATEWAY), WATCHERS),
    Route("broadcaster/metrics", Op.PUT, BroadcasterMetrics, _roles(BROADCASTER), WATCHERS),
    Route("state", Op.PUT, State, _roles(BROADCASTER), _roles(ROS2) | WATCHERS),
    Route("service/*/*", Op.QUERY, None, WATCHERS | SERVICES, SERVICES, ServiceInfo),
    Route(
        "alive/*/*",
        Op.TOKEN,
        None,
        SERVICES,
        _roles(CONTROLLER, EXECUTOR, BROADCASTER, GATEWAY) | WATCHERS,
    ),
    Route("claim/*/*/*", Op.TOKEN, None, SERVICES, SERVICES | WATCHERS),
)
"""Every key of a cell. ``motocell ps`` queries ``service/*/*`` with no request body."""

PAYLOADS: dict[str, type[msgspec.Struct]] = {
    route.suffix: route.payload for route in ROUTES if route.op is Op.PUT and route.payload
}
"""What a subscriber receives, by key suffix (queries and tokens are not samples)."""

_decoders = {suffix: msgspec.msgpack.Decoder(kind) for suffix, kind in PAYLOADS.items()}


def suffix_of(key: str) -> str:
    """``motocell/cell1/group/2/queue`` -> ``group/*/queue``."""
    parts = key.split("/")[2:]
    if len(parts) >= 2 and parts[0] == "group":
        parts[1] = "*"
    return "/".join(parts)


def route_of(key: str, op: Op | None = None) -> Route | None:
    """The route a concrete key (``motocell/<cell>/...`` or ``@motocell/<cell>/...``) is on;
    an exact suffix wins over a wildcard one. A key that is both published and asked (a
    group's slot) is on its publication's route unless ``op`` says otherwise."""
    parts = key.split("/")[2:]
    matches = [
        route
        for route in ROUTES
        if _matches(route.suffix.split("/"), parts)
        and (route.op is Op.TOKEN) == key.startswith("@")
        and (op is None or route.op is op)
    ]
    matches.sort(key=lambda route: route.suffix.count("*"))
    return matches[0] if matches else None


def _matches(pattern: list[str], parts: list[str]) -> bool:
    if len(pattern) != len(parts):
        return False
    return all(level in ("*", part) for level, part in zip(pattern, parts, strict=True))


def cell_of(key: str) -> str:
    return key.split("/")[1]


def payload_type(key: str) -> type[msgspec.Struct] | None:
    return PAYLOADS.get(suffix_of(key))


def decode(key: str, data: bytes) -> msgspec.Struct | None:
    """The payload on ``key``, or None for a key this catalogue does not know."""
    decoder = _decoders.get(suffix_of(key))
    return None if decoder is None else decoder.decode(data)


def to_named(value: Any) -> Any:
    """Structs as dicts with field names (payloads travel as msgpack arrays), for JSON."""
    if isinstance(value, msgspec.Struct):
        return {field: to_named(getattr(value, field)) for field in value.__struct_fields__}
    if isinstance(value, list | tuple):
        return [to_named(item) for item in value]
    return value
