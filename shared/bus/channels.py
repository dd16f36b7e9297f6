"""Reading Zenoh channel handlers from a service's own thread, with no Python callback.

zenoh-python 1.10 has no ``recv`` with a timeout and no ``select`` over channels, so a thread
blocked in ``recv()`` is woken by a *doorbell*: an empty sample put on the channel's own key
that never leaves the session (``Locality.SESSION_LOCAL``). Every motocell payload is a
non-empty msgpack array, so an empty sample can only be a doorbell.
"""

from __future__ import annotations

import logging
from typing import TypeVar

import msgspec
import zenoh

from motocell.shared.bus.schemas import Decoder

log = logging.getLogger("bus")

T = TypeVar("T")

Channel = zenoh.Subscriber[zenoh.handlers.Handler[zenoh.Sample]]
"""A subscriber declared with a ``FifoChannel`` or ``RingChannel`` handler."""


class Doorbell:
    """Wakes whoever blocks in ``recv()`` on ``key``'s channel in this session, and no one else."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self._publisher = session.declare_publisher(
            key, allowed_destination=zenoh.Locality.SESSION_LOCAL
        )

    def ring(self) -> None:
        self._publisher.put(b"")

    def close(self) -> None:
        self._publisher.undeclare()


def is_doorbell(sample: zenoh.Sample) -> bool:
    return not sample.payload.to_bytes()


def decoded(sample: zenoh.Sample | None, decoder: Decoder[T]) -> T | None:
    """The sample's payload; None for no sample, a doorbell, or one that does not decode
    (logged: a peer's bad sample must not stop the reading thread)."""
    if sample is None:
        return None
    payload = sample.payload.to_bytes()
    if not payload:
        return None
    try:
        return decoder.decode(payload)
    except msgspec.DecodeError:
        log.warning("undecodable sample on %s ignored", sample.key_expr)
        return None


def newest(channel: Channel, decoder: Decoder[T]) -> T | None:
    """A latest-value channel's sample since the last read, decoded; None when nothing came."""
    return decoded(channel.try_recv(), decoder)
