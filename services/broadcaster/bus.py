"""The broadcaster's bus, behind Protocols: what its loop needs (``TickFeed``, ``StateReports``,
a ``Publication`` for ``state``), what its bus shells need of a Zenoh session (``Bus``), and
``ZenohBus``, the thin adapter over a real session.

The shells (``ticks.TickSource``, ``controller_watch.ControllerWatch``,
``reports.StatePortReports``) are written against ``Bus``, so their unit tests script the bus
instead of running a router: payloads go in and out as bytes (the shells decode them, so a test
can send garbage). No Python runs on Zenoh's threads for ticks or statuses: they wait in
Zenoh's own channel handlers for the broadcaster's thread (docs/conventions.md, The bus).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

import zenoh

from motocell.shared.bus.adapters import (
    Channel,
    Declared,
    Latest,
    Publication,
    ZenohChannel,
    ZenohLatest,
    ZenohPublication,
    callback_subscriber,
)
from motocell.shared.bus.schemas import CommandReply, Tick
from motocell.shared.bus.session import Liveness, answer, publisher

# -- what the loop needs ---------------------------------------------------------------------


class TickFeed(Protocol):
    def next(self, deadline: float | None, ticks_expected: bool) -> Tick | None:
        """The newest tick; None when woken without one at ``deadline`` (time.monotonic(),
        None: no deadline). ``ticks_expected``: block for a tick; else sleep until
        ``deadline`` and take what came."""
        ...


class StateReports(Protocol):
    """What the loop tells the cell about its state port (``reports.StatePortReports``)."""

    def written(self, age_ns: int) -> None:
        """A tick's frames were handed to the clients ``age_ns`` after its wake-up."""
        ...

    def report(self, now: float, clients: int, replaced: int, stuck_closed: int) -> None:
        """Publish what changed, and everything when due (``now``: time.monotonic())."""
        ...

    @property
    def next_due(self) -> float:
        """When ``report`` must run again at the latest (time.monotonic())."""
        ...


# -- what the bus shells need of a session ---------------------------------------------------


class Tokens(Protocol):
    """The liveliness tokens present under a key (``shared.bus.session.Liveness``)."""

    def ask(self) -> threading.Event:
        """Query for tokens the events missed; returns at once."""
        ...

    def present(self) -> frozenset[str]: ...

    def close(self) -> None: ...


class Bus(Protocol):
    def channel(self, key: str, size: int) -> Channel:
        """The samples of ``key``, the newest ``size`` kept."""
        ...

    def latest(self, key: str) -> Latest: ...

    def subscribe(self, key: str, on_sample: Callable[[object], None]) -> Declared:
        """``on_sample`` runs on the bus's threads, once per sample: it must only hand it on."""
        ...

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        """As ``shared.bus.session.publisher``."""
        ...

    def tokens(self, key: str) -> Tokens:
        """Watch the tokens under ``key``; nothing is asked until ``Tokens.ask``."""
        ...

    def serve(self, key: str, reply: Callable[[], CommandReply]) -> Declared:
        """Answer every query on ``key`` with ``reply()``, called on the bus's threads."""
        ...


# -- over Zenoh ------------------------------------------------------------------------------


class ZenohBus:
    """``Bus`` over a Zenoh session."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session

    def channel(self, key: str, size: int) -> Channel:
        return ZenohChannel(self._session, key, size)

    def latest(self, key: str) -> Latest:
        return ZenohLatest(self._session, key)

    def subscribe(self, key: str, on_sample: Callable[[object], None]) -> Declared:
        return callback_subscriber(self._session, key, on_sample)

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        return ZenohPublication(publisher(self._session, key, realtime=realtime, latest=latest))

    def tokens(self, key: str) -> Tokens:
        return Liveness(self._session, key)

    def serve(self, key: str, reply: Callable[[], CommandReply]) -> Declared:
        return self._session.declare_queryable(key, lambda query: answer(query, reply()))
