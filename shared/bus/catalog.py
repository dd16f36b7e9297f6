"""Which payload type travels on which key: one decoder per key, for any observer."""

from __future__ import annotations

from typing import Any

import msgspec

from shared.bus.schemas import (
    CommandReply,
    CommandRequest,
    ControllerStatus,
    ExecutorMetrics,
    GatewayMetrics,
    IncrementBatch,
    InterpolatorMetrics,
    Point,
    QueueState,
    Slot,
    State,
    Tick,
)

# Key suffixes after ``motocell/<cell>/``; "*" is one level (a group number).
PAYLOADS: dict[str, type[msgspec.Struct]] = {
    "controller/status": ControllerStatus,
    "controller/cmd/incmove_error": CommandReply,
    "controller/cmd/connections": CommandRequest,
    "executor/tick": Tick,
    "executor/metrics": ExecutorMetrics,
    "gateway/metrics": GatewayMetrics,
    "state": State,
    "group/*/point": Point,
    "group/*/slot": Slot,
    "group/*/increments": IncrementBatch,
    "group/*/queue": QueueState,
    "group/*/metrics": InterpolatorMetrics,
}

_decoders = {suffix: msgspec.msgpack.Decoder(kind) for suffix, kind in PAYLOADS.items()}


def suffix_of(key: str) -> str:
    """``motocell/cell1/group/2/queue`` -> ``group/*/queue``."""
    parts = key.split("/")[2:]
    if len(parts) >= 2 and parts[0] == "group":
        parts[1] = "*"
    return "/".join(parts)


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
