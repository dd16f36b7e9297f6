"""A scripted ``Bus`` for the executor's adapters (``Inputs``, ``ControllerToken``,
``Outputs``), as ``tests/services/gateway/fake_bus.py`` is the gateway's: the test publishes
payloads (garbage included) to what is subscribed, asks STOP_MOTION, declares and undeclares the
controller's token, answers liveliness and command queries or leaves them open, and reads what
the adapters published, answered and declared. Callbacks run on the test's thread as it
publishes; a reader blocked in ``recv`` wakes when a sample (a doorbell's too) reaches its
channel."""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

from motocell.services.executor.bus import Query, TokenEvent
from motocell.shared.bus.schemas import CommandReply
from tests.services.fakes import FakeDoorbell, FakePublication

WAIT_S = 5.0
"""Deadline for what another thread is expected to do soon (generous for a loaded host)."""


def matches(pattern: str, key: str) -> bool:
    """Whether ``key`` is under the key expression ``pattern`` (``*``: one chunk; ``**``: any
    number of them), as Zenoh matches them."""
    return _matches(pattern.split("/"), key.split("/"))


def _matches(pattern: list[str], key: list[str]) -> bool:
    if not pattern:
        return not key
    head, rest = pattern[0], pattern[1:]
    if head == "**":
        return any(_matches(rest, key[skip:]) for skip in range(len(key) + 1))
    return bool(key) and head in ("*", key[0]) and _matches(rest, key[1:])


@dataclass(frozen=True)
class FakePayload:
    data: bytes

    def to_bytes(self) -> bytes:
        return self.data


class Kind(Enum):
    PUT = "put"
    DELETE = "delete"


@dataclass(frozen=True)
class FakeSample:
    key_expr: str
    payload: FakePayload
    kind: Kind = Kind.PUT


class FakeChannel:
    """A FIFO channel of samples; ``recv`` blocks until one comes (at most ``WAIT_S``, so a
    test that expected a wake-up fails instead of hanging)."""

    def __init__(self, key: str, depth: int) -> None:
        self.key = key
        self.depth = depth
        self._samples: deque[FakeSample] = deque()
        self._arrived = threading.Condition()
        self.waiting = 0
        """Readers blocked in ``recv`` now."""

    def put(self, sample: FakeSample) -> None:
        with self._arrived:
            self._samples.append(sample)
            self._arrived.notify_all()

    def try_recv(self) -> FakeSample | None:
        with self._arrived:
            return self._samples.popleft() if self._samples else None

    def recv(self) -> FakeSample:
        with self._arrived:
            self.waiting += 1
            self._arrived.notify_all()  # for wait_for_reader
            try:
                if not self._arrived.wait_for(lambda: self._samples, WAIT_S):
                    raise TimeoutError(f"nothing reached {self.key} within {WAIT_S} s")
                return self._samples.popleft()
            finally:
                self.waiting -= 1

    def wait_for_reader(self) -> None:
        """Until a reader blocks in ``recv``."""
        with self._arrived:
            if not self._arrived.wait_for(lambda: self.waiting > 0, WAIT_S):
                raise TimeoutError(f"nobody waited on {self.key} within {WAIT_S} s")


class FakeDeclared:
    def __init__(self, key: str, on_undeclare: Callable[[], None] = lambda: None) -> None:
        self.key = key
        self.undeclared = False
        self._on_undeclare = on_undeclare

    def undeclare(self) -> None:
        self.undeclared = True
        self._on_undeclare()


@dataclass
class FakeQuery:
    key: str
    replies: list[CommandReply] = field(default_factory=list)

    def answer(self, reply: CommandReply) -> None:
        self.replies.append(reply)


@dataclass
class TokenQuery:
    """A liveliness query, open until the test finishes it."""

    key: str
    timeout: float
    _tokens: list[str] = field(default_factory=list)
    _finished: bool = False

    def reply(self, *tokens: str) -> None:
        self._tokens += tokens

    def finish(self) -> None:
        self._finished = True

    def take(self) -> tuple[list[str], bool]:
        tokens, self._tokens = self._tokens, []
        return tokens, self._finished


@dataclass
class FakeBus:
    channels: list[FakeChannel] = field(default_factory=list)
    callbacks: dict[str, list[Callable[[FakeSample], None]]] = field(default_factory=dict)
    queryables: dict[str, Callable[[Query], None]] = field(default_factory=dict)
    publications: dict[str, FakePublication] = field(default_factory=dict)
    doorbells: list[FakeDoorbell] = field(default_factory=list)
    token_channels: list[FakeChannel] = field(default_factory=list)
    token_queries: list[TokenQuery] = field(default_factory=list)
    calls: list[tuple[str, float]] = field(default_factory=list)
    call_replies: dict[str, CommandReply] = field(default_factory=dict)
    """By key: the answer to a command query (unlisted: nobody answers)."""

    # -- Bus -------------------------------------------------------------------------------
    def channel(self, key: str, depth: int) -> FakeChannel:
        channel = FakeChannel(key, depth)
        self.channels.append(channel)
        return channel

    def subscribe(self, key: str, on_sample: Callable[[FakeSample], None]) -> FakeDeclared:
        callbacks = self.callbacks.setdefault(key, [])
        callbacks.append(on_sample)
        return FakeDeclared(key, lambda: callbacks.remove(on_sample))

    def queryable(self, key: str, on_query: Callable[[Query], None]) -> FakeDeclared:
        self.queryables[key] = on_query
        return FakeDeclared(key)

    def publisher(
        self, key: str, *, realtime: bool = False, latest: bool = False
    ) -> FakePublication:
        return self.publications.setdefault(key, FakePublication(key, realtime, latest))

    def doorbell(self, key: str) -> FakeDoorbell:
        doorbell = FakeDoorbell(self, key)
        self.doorbells.append(doorbell)
        return doorbell

    def token_events(self, key: str, depth: int) -> FakeChannel:
        channel = FakeChannel(key, depth)
        self.token_channels.append(channel)
        return channel

    def declared(self, event: TokenEvent) -> bool:
        return event.kind is Kind.PUT

    def ask_tokens(self, key: str, depth: int, timeout: float) -> TokenQuery:
        query = TokenQuery(key, timeout)
        self.token_queries.append(query)
        return query

    def call(self, key: str, timeout: float) -> CommandReply | None:
        self.calls.append((key, timeout))
        return self.call_replies.get(key)

    # -- the rest of the cell --------------------------------------------------------------
    def publish(self, key: str, payload: bytes) -> None:
        """A sample on ``key``: into every channel and callback whose key expression it is
        under."""
        sample = FakeSample(key, FakePayload(payload))
        for channel in self.channels:
            if matches(channel.key, key):
                channel.put(sample)
        for pattern, callbacks in self.callbacks.items():
            if matches(pattern, key):
                for callback in callbacks:
                    callback(sample)

    def ask(self, key: str) -> FakeQuery:
        query = FakeQuery(key)
        self.queryables[key](query)
        return query

    def token(self, key: str, *, declared: bool) -> None:
        """A liveliness token declared (or undeclared) under ``key``."""
        event = FakeSample(key, FakePayload(b""), Kind.PUT if declared else Kind.DELETE)
        for channel in self.token_channels:
            if matches(channel.key, key):
                channel.put(event)

    def subscribed(self, key: str) -> int:
        """How many callbacks are subscribed to exactly ``key`` now."""
        return len(self.callbacks.get(key, []))

    def channel_of(self, key: str) -> FakeChannel:
        [channel] = [channel for channel in self.channels if channel.key == key]
        return channel
