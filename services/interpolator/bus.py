"""What the interpolator's shells need of their Zenoh session (``Bus``), and ``ZenohBus``, the
thin adapter over a real one.

``Inputs`` and ``Reports`` are written against the Protocol, so their unit tests script the bus
instead of running a router: payloads go in and out as bytes (the shells decode them, so a test
can send garbage), and an empty payload is a doorbell (``shared.bus.channels``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import zenoh

from motocell.shared.bus.adapters import (
    Declared,
    Publication,
    ZenohPublication,
    callback_subscriber,
)
from motocell.shared.bus.channels import Channel as ZenohChannel
from motocell.shared.bus.channels import Doorbell as ZenohDoorbell
from motocell.shared.bus.session import ENCODING, publisher


class Channel(Protocol):
    """A subscription whose samples wait in Zenoh until the reading thread takes them (a
    ``FifoChannel`` or a ``RingChannel``): no Python runs on the bus's threads for it."""

    def recv(self) -> bytes:
        """The next payload, blocking until one is there."""
        ...

    def try_recv(self) -> bytes | None:
        """The next payload, None if none is there; never blocks."""
        ...

    def undeclare(self) -> None: ...


class Doorbell(Protocol):
    def ring(self) -> None:
        """Put an empty sample on the key, for this session's subscribers only."""
        ...

    def close(self) -> None: ...


class Bus(Protocol):
    def fifo(self, key: str, size: int) -> Channel:
        """Every sample on ``key``, in order, ``size`` held at most."""
        ...

    def latest(self, key: str) -> Channel:
        """The newest sample on ``key`` only."""
        ...

    def doorbell(self, key: str) -> Doorbell: ...

    def subscribe(self, key: str, on_sample: Callable[[object], None]) -> Declared:
        """``on_sample`` runs on the bus's threads, once per sample: it must only hand it on."""
        ...

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        """As ``shared.bus.session.publisher``."""
        ...

    def answer(self, key: str, payload: Callable[[], bytes]) -> Declared:
        """Answer every query on ``key`` with ``payload()``, called on the bus's threads."""
        ...


class _Channel:
    def __init__(self, subscriber: ZenohChannel) -> None:
        self._subscriber = subscriber

    def recv(self) -> bytes:
        return self._subscriber.recv().payload.to_bytes()

    def try_recv(self) -> bytes | None:
        sample = self._subscriber.try_recv()
        return None if sample is None else sample.payload.to_bytes()

    def undeclare(self) -> None:
        self._subscriber.undeclare()


class ZenohBus:
    """``Bus`` over a Zenoh session."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session

    def fifo(self, key: str, size: int) -> Channel:
        return _Channel(self._session.declare_subscriber(key, zenoh.handlers.FifoChannel(size)))

    def latest(self, key: str) -> Channel:
        return _Channel(self._session.declare_subscriber(key, zenoh.handlers.RingChannel(1)))

    def doorbell(self, key: str) -> Doorbell:
        return ZenohDoorbell(self._session, key)

    def subscribe(self, key: str, on_sample: Callable[[object], None]) -> Declared:
        return callback_subscriber(self._session, key, on_sample)

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        return ZenohPublication(publisher(self._session, key, realtime=realtime, latest=latest))

    def answer(self, key: str, payload: Callable[[], bytes]) -> Declared:
        def on_query(query: zenoh.Query) -> None:
            query.reply(key, payload(), encoding=ENCODING)
            query.drop()

        return self._session.declare_queryable(
            key, zenoh.handlers.Callback(on_query, indirect=False)
        )
