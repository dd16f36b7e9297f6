"""A scripted ``Bus`` and loop-side fakes for the broadcaster's shells: the test publishes payloads
(garbage included) to what is subscribed, makes tokens appear and vanish, asks what is served,
and reads what the shell published and declared."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field

from motocell.shared.bus.schemas import CommandReply, Tick
from tests.services.fakes import FakeChannel, FakePublication


class FakeLatest:
    def __init__(self, key: str) -> None:
        self.key = key
        self._payload: bytes | None = None
        self.undeclared = False

    def put(self, payload: bytes) -> None:
        self._payload = payload

    def take(self) -> bytes | None:
        payload, self._payload = self._payload, None
        return payload

    def undeclare(self) -> None:
        self.undeclared = True


class FakeTokens:
    def __init__(self, key: str) -> None:
        self.key = key
        self.tokens: set[str] = set()
        self.asked = 0
        self.closed = False

    def ask(self) -> threading.Event:
        self.asked += 1
        return threading.Event()

    def present(self) -> frozenset[str]:
        return frozenset(self.tokens)

    def close(self) -> None:
        self.closed = True


@dataclass
class FakeServed:
    """A declared queryable (or callback subscriber)."""

    key: str
    reply: Callable[[], CommandReply]
    undeclared: bool = False
    on_undeclare: Callable[[], None] = lambda: None

    def undeclare(self) -> None:
        self.undeclared = True
        self.on_undeclare()


@dataclass
class FakeBus:
    channels: dict[str, FakeChannel] = field(default_factory=dict)
    latests: dict[str, FakeLatest] = field(default_factory=dict)
    publications: dict[str, FakePublication] = field(default_factory=dict)
    watched: dict[str, FakeTokens] = field(default_factory=dict)
    served: dict[str, FakeServed] = field(default_factory=dict)
    callbacks: dict[str, list[Callable[[object], None]]] = field(default_factory=dict)

    # -- Bus -------------------------------------------------------------------------------
    def channel(self, key: str, size: int) -> FakeChannel:
        return self.channels.setdefault(key, FakeChannel(key, size))

    def latest(self, key: str) -> FakeLatest:
        return self.latests.setdefault(key, FakeLatest(key))

    def publisher(
        self, key: str, *, realtime: bool = False, latest: bool = False
    ) -> FakePublication:
        return self.publications.setdefault(key, FakePublication(key, realtime, latest))

    def tokens(self, key: str) -> FakeTokens:
        return self.watched.setdefault(key, FakeTokens(key))

    def serve(self, key: str, reply: Callable[[], CommandReply]) -> FakeServed:
        return self.served.setdefault(key, FakeServed(key, reply))

    def subscribe(self, key: str, on_sample: Callable[[object], None]) -> FakeServed:
        """A callback subscriber, run on the publishing thread as Zenoh runs it on its own."""
        callbacks = self.callbacks.setdefault(key, [])
        callbacks.append(on_sample)

        def undeclared() -> CommandReply:
            raise AssertionError("a subscriber answers nothing")

        served = FakeServed(key, undeclared, on_undeclare=lambda: callbacks.remove(on_sample))
        return served

    # -- the rest of the cell --------------------------------------------------------------
    def publish(self, key: str, payload: bytes) -> None:
        """A sample arrives on ``key``: into its channel or latest-value subscription."""
        if key in self.channels:
            self.channels[key].put(payload)
        if key in self.latests:
            self.latests[key].put(payload)
        for callback in list(self.callbacks.get(key, [])):
            callback(payload)


class ScriptedTicks:
    """A ``TickFeed`` from a list (None: woken without a tick), each ``step_s`` after the last
    on the clock it keeps (``now``); the waits the loop asked for are kept."""

    def __init__(self, step_s: float) -> None:
        self.ticks: list[Tick | None] = []
        self.now = 0.0
        self.step_s = step_s
        self.waits: list[tuple[float | None, bool]] = []

    def next(self, deadline: float | None, ticks_expected: bool) -> Tick | None:
        self.waits.append((deadline, ticks_expected))
        self.now += self.step_s
        return self.ticks.pop(0)


class RecordedReports:
    """A ``StateReports`` that keeps what it is told."""

    def __init__(self, next_due: float = 1e9) -> None:
        self.ages: list[int] = []
        self.clients: list[int] = []
        self.replaced: list[int] = []
        self.stuck_closed: list[int] = []
        self.next_due = next_due

    def written(self, age_ns: int) -> None:
        self.ages.append(age_ns)

    def report(self, now: float, clients: int, replaced: int, stuck_closed: int) -> None:
        self.clients.append(clients)
        self.replaced.append(replaced)
        self.stuck_closed.append(stuck_closed)
