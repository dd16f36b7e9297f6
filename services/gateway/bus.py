"""What the gateway's shells need of their Zenoh session (``Bus``), and ``ZenohBus``, the thin
adapter over a real one.

The shells (``ZenohCell``, ``Reporter``) are written against the Protocol, so their unit tests
script the bus instead of running a router, as httpcore tests its connections on a mock
network: payloads go in and out as bytes (the shells decode them, so a test can send garbage),
and a test answers each query at once, late, or never.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

import zenoh

from motocell.shared.bus.session import ENCODING, Liveness, observed, publisher


class Latest(Protocol):
    """A subscription that keeps only the newest sample until it is read (a Zenoh
    ``RingChannel(1)``): no Python runs on the bus's threads for it."""

    def take(self) -> bytes | None:
        """The newest payload since the last read, None if none came; never blocks."""
        ...

    def undeclare(self) -> None: ...


class Subscription(Protocol):
    def undeclare(self) -> None:
        """Returns once none of its callbacks runs any more: never call it holding a lock that
        a callback takes."""
        ...


class Publication(Protocol):
    def put(self, payload: bytes) -> None: ...

    def observed(self) -> bool:
        """Whether any subscriber on the bus matches it now."""
        ...


class Tokens(Protocol):
    """The liveliness tokens present under a key (``shared.bus.session.Liveness``)."""

    def ask(self) -> threading.Event:
        """Query for tokens the events missed; returns at once, the event set once answered."""
        ...

    def present(self) -> frozenset[str]: ...

    def close(self) -> None: ...


class Bus(Protocol):
    def latest(self, key: str) -> Latest: ...

    def subscribe(self, key: str, on_payload: Callable[[bytes], None]) -> Subscription:
        """``on_payload`` runs on the bus's threads, once per sample."""
        ...

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        """As ``shared.bus.session.publisher``."""
        ...

    def query(
        self,
        key: str,
        payload: bytes | None,
        on_reply: Callable[[bytes], None],
        on_done: Callable[[], None],
        timeout: float,
    ) -> None:
        """Ask and return at once: ``on_reply`` runs for each answer's payload, then
        ``on_done``, both on the bus's threads; the bus ends the query by ``timeout``."""
        ...

    def tokens(self, key: str, on_change: Callable[[], None]) -> Tokens:
        """Watch the tokens under ``key``; nothing is asked until ``Tokens.ask``."""
        ...


class _RingLatest:
    def __init__(self, subscriber: zenoh.Subscriber[zenoh.handlers.Handler[zenoh.Sample]]) -> None:
        self._subscriber = subscriber

    def take(self) -> bytes | None:
        sample = self._subscriber.try_recv()
        return None if sample is None else sample.payload.to_bytes()

    def undeclare(self) -> None:
        self._subscriber.undeclare()


class _Publication:
    def __init__(self, publisher: zenoh.Publisher) -> None:
        self._publisher = publisher

    def put(self, payload: bytes) -> None:
        self._publisher.put(payload)

    def observed(self) -> bool:
        return observed(self._publisher)


class ZenohBus:
    """``Bus`` over a Zenoh session."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session

    def latest(self, key: str) -> Latest:
        return _RingLatest(self._session.declare_subscriber(key, zenoh.handlers.RingChannel(1)))

    def subscribe(self, key: str, on_payload: Callable[[bytes], None]) -> Subscription:
        def on_sample(sample: zenoh.Sample) -> None:
            on_payload(sample.payload.to_bytes())

        return self._session.declare_subscriber(key, on_sample)

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        return _Publication(publisher(self._session, key, realtime=realtime, latest=latest))

    def query(
        self,
        key: str,
        payload: bytes | None,
        on_reply: Callable[[bytes], None],
        on_done: Callable[[], None],
        timeout: float,
    ) -> None:
        def on_answer(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                on_reply(reply.ok.payload.to_bytes())

        self._session.get(
            key,
            zenoh.handlers.Callback(on_answer, on_done),
            payload=payload,
            encoding=None if payload is None else ENCODING,
            timeout=timeout,
        )

    def tokens(self, key: str, on_change: Callable[[], None]) -> Tokens:
        return Liveness(self._session, key, on_change)
