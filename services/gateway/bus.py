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

from motocell.shared.bus.adapters import Latest, Publication, ZenohLatest, ZenohPublication
from motocell.shared.bus.session import ENCODING, Liveness, publisher


class Subscription(Protocol):
    def undeclare(self) -> None:
        """Returns once none of its callbacks runs any more: never call it holding a lock that
        a callback takes."""
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

    def answer(self, key: str, on_query: Callable[[bytes, Answer], None]) -> Subscription:
        """Take the queries on ``key``: ``on_query(payload, answer)`` runs on the bus's threads
        for each; ``answer`` replies to it once, from any thread."""
        ...


Answer = Callable[[bytes], None]


class ZenohBus:
    """``Bus`` over a Zenoh session."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session

    def latest(self, key: str) -> Latest:
        return ZenohLatest(self._session, key)

    def subscribe(self, key: str, on_payload: Callable[[bytes], None]) -> Subscription:
        def on_sample(sample: zenoh.Sample) -> None:
            on_payload(sample.payload.to_bytes())

        return self._session.declare_subscriber(key, on_sample)

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        return ZenohPublication(publisher(self._session, key, realtime=realtime, latest=latest))

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

    def answer(self, key: str, on_query: Callable[[bytes, Answer], None]) -> Subscription:
        def take(query: zenoh.Query) -> None:
            payload = b"" if query.payload is None else query.payload.to_bytes()

            def reply(data: bytes) -> None:
                query.reply(key, data, encoding=ENCODING)
                query.drop()  # the asker's get ends only once the query is finalised

            on_query(payload, reply)

        return self._session.declare_queryable(key, take)
