"""A scripted ``Bus`` for the gateway's shells (as httpcore's mock network backend): the test
publishes payloads (garbage included) to what is subscribed, answers each query at once, late
or never, makes tokens appear and vanish, and reads what the shell published, asked and
declared. Every bus call made while the shell's decision lock is held is recorded
(``under_lock``): no I/O may be made under it."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field

from motocell.services.gateway.bus import Answer
from tests.services.fakes import FakePublication

WAIT_S = 5.0
"""Deadline for what another thread is expected to do soon (generous for a loaded host)."""


class FakeLatest:
    def __init__(self, bus: FakeBus, key: str) -> None:
        self._bus = bus
        self.key = key
        self._payload: bytes | None = None
        self.undeclared = False

    def put(self, payload: bytes) -> None:
        self._payload = payload

    def take(self) -> bytes | None:
        payload, self._payload = self._payload, None
        return payload

    def undeclare(self) -> None:
        self._bus.io(f"undeclare {self.key}")
        self.undeclared = True


class FakeSubscription:
    def __init__(self, bus: FakeBus, key: str, callback: Callable[[bytes], None]) -> None:
        self._bus = bus
        self.key = key
        self.callback = callback
        self.undeclared = False

    def undeclare(self) -> None:
        self._bus.io(f"undeclare {self.key}")
        self.undeclared = True


@dataclass
class Query:
    key: str
    payload: bytes | None
    on_reply: Callable[[bytes], None]
    on_done: Callable[[], None]
    timeout: float

    def reply(self, payload: bytes) -> None:
        """One answer, then the query ends."""
        self.on_reply(payload)
        self.on_done()

    def finish(self) -> None:
        """The query ends unanswered, as Zenoh ends one nobody answered by its timeout."""
        self.on_done()


class FakeTokens:
    def __init__(self, bus: FakeBus, key: str, on_change: Callable[[], None]) -> None:
        self._bus = bus
        self.key = key
        self._on_change = on_change
        self._present: set[str] = set()
        self.asked = 0
        self.closed = False

    def ask(self) -> threading.Event:
        self._bus.io(f"ask {self.key}")
        self.asked += 1
        return threading.Event()

    def present(self) -> frozenset[str]:
        return frozenset(self._present)

    def appear(self, key: str) -> None:
        self._present.add(key)
        self._on_change()

    def vanish(self, key: str) -> None:
        self._present.discard(key)
        self._on_change()

    def close(self) -> None:
        self.closed = True


@dataclass
class FakeBus:
    held: Callable[[], bool] = lambda: False
    """Whether the shell's decision lock is held now (the test sets it once the shell exists)."""
    under_lock: list[str] = field(default_factory=list)
    latests: dict[str, list[FakeLatest]] = field(default_factory=dict)
    subscriptions: dict[str, list[FakeSubscription]] = field(default_factory=dict)
    answering: dict[str, Callable[[bytes, Answer], None]] = field(default_factory=dict)
    publications: dict[str, FakePublication] = field(default_factory=dict)
    tokens_made: list[FakeTokens] = field(default_factory=list)
    answers: dict[str, Callable[[Query], None]] = field(default_factory=dict)
    """By key: what happens to a query as it is asked (unlisted: nothing, until the test acts)."""
    _queries: list[Query] = field(default_factory=list)
    _asked: threading.Condition = field(default_factory=threading.Condition)

    def io(self, what: str) -> None:
        if self.held():
            self.under_lock.append(what)

    # -- Bus -------------------------------------------------------------------------------
    def latest(self, key: str) -> FakeLatest:
        self.io(f"latest {key}")
        channel = FakeLatest(self, key)
        self.latests.setdefault(key, []).append(channel)
        return channel

    def subscribe(self, key: str, on_payload: Callable[[bytes], None]) -> FakeSubscription:
        self.io(f"subscribe {key}")
        subscription = FakeSubscription(self, key, on_payload)
        self.subscriptions.setdefault(key, []).append(subscription)
        return subscription

    def publisher(
        self, key: str, *, realtime: bool = False, latest: bool = False
    ) -> FakePublication:
        self.io(f"publisher {key}")
        return self.publications.setdefault(key, FakePublication(key))

    def query(
        self,
        key: str,
        payload: bytes | None,
        on_reply: Callable[[bytes], None],
        on_done: Callable[[], None],
        timeout: float,
    ) -> None:
        self.io(f"query {key}")
        query = Query(key, payload, on_reply, on_done, timeout)
        with self._asked:
            self._queries.append(query)
            self._asked.notify_all()
        answer = self.answers.get(key)
        if answer is not None:
            answer(query)

    def tokens(self, key: str, on_change: Callable[[], None]) -> FakeTokens:
        self.io(f"tokens {key}")
        tokens = FakeTokens(self, key, on_change)
        self.tokens_made.append(tokens)
        return tokens

    def answer(self, key: str, on_query: Callable[[bytes, Answer], None]) -> FakeSubscription:
        """Queries the test asks with ``ask``."""
        self.io(f"answer {key}")
        self.answering[key] = on_query
        return FakeSubscription(self, key, lambda payload: None)

    def ask(self, key: str, payload: bytes) -> list[bytes]:
        """A query on ``key`` as another process asks it; the answers it got (they may come
        from another thread: read the list once they have)."""
        answers: list[bytes] = []
        self.answering[key](payload, answers.append)
        return answers

    # -- the rest of the cell --------------------------------------------------------------
    def publish(self, key: str, payload: bytes) -> None:
        """A sample arrives: into every live latest-value channel and callback of ``key``."""
        for channel in self.latests.get(key, []):
            if not channel.undeclared:
                channel.put(payload)
        for subscription in self.subscriptions.get(key, []):
            if not subscription.undeclared:
                subscription.callback(payload)

    def queries(self, key: str | None = None) -> list[Query]:
        with self._asked:
            return [query for query in self._queries if key is None or query.key == key]

    def next_query(self, key: str, after: int = 0) -> Query:
        """The query on ``key`` numbered ``after`` (from 0), waiting for another thread to ask
        it."""
        with self._asked:
            if not self._asked.wait_for(lambda: len(self.queries(key)) > after, WAIT_S):
                raise TimeoutError(f"no query {after} on {key} within {WAIT_S} s")
            return self.queries(key)[after]

    def live(self, key: str) -> list[FakeLatest | FakeSubscription]:
        """The subscriptions on ``key`` not undeclared."""
        declared: list[FakeLatest | FakeSubscription] = [
            *self.latests.get(key, []),
            *self.subscriptions.get(key, []),
        ]
        return [entry for entry in declared if not entry.undeclared]
