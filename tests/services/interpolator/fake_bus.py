"""A scripted ``Bus`` for the interpolator's shells: the test publishes payloads (garbage
included) into what is subscribed, asks the slot as a gateway would, and reads what the shells
published, rang and declared. A channel's ``recv`` blocks as Zenoh's does, until a payload (or
a doorbell) is there, so the shells' own threads can be driven from a test."""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from tests.services.fakes import FakeDoorbell, FakePublication

WAIT_S = 5.0
"""Deadline for what another thread is expected to do soon (generous for a loaded host)."""


class FakeChannel:
    def __init__(self, key: str, newest_only: bool) -> None:
        self.key = key
        self.newest_only = newest_only
        """A ``RingChannel(1)``: a payload replaces the one not read yet."""
        self._payloads: deque[bytes] = deque()
        self._arrived = threading.Condition()
        self.undeclared = False

    def put(self, payload: bytes) -> None:
        with self._arrived:
            if self.newest_only:
                self._payloads.clear()
            self._payloads.append(payload)
            self._arrived.notify_all()

    def recv(self) -> bytes:
        with self._arrived:
            if not self._arrived.wait_for(lambda: self._payloads, WAIT_S):
                raise TimeoutError(f"nothing arrived on {self.key} within {WAIT_S} s")
            return self._payloads.popleft()

    def try_recv(self) -> bytes | None:
        with self._arrived:
            return self._payloads.popleft() if self._payloads else None

    def undeclare(self) -> None:
        self.undeclared = True


class FakeAnswer:
    """A declared queryable (or callback subscriber)."""

    def __init__(
        self, payload: Callable[[], bytes], on_undeclare: Callable[[], None] = lambda: None
    ) -> None:
        self.payload = payload
        self.undeclared = False
        self._on_undeclare = on_undeclare

    def undeclare(self) -> None:
        self.undeclared = True
        self._on_undeclare()


@dataclass
class FakeBus:
    channels: dict[str, list[FakeChannel]] = field(default_factory=dict)
    doorbells: dict[str, FakeDoorbell] = field(default_factory=dict)
    publications: dict[str, FakePublication] = field(default_factory=dict)
    answers: dict[str, FakeAnswer] = field(default_factory=dict)
    callbacks: dict[str, list[Callable[[object], None]]] = field(default_factory=dict)

    # -- Bus -------------------------------------------------------------------------------
    def fifo(self, key: str, size: int) -> FakeChannel:
        return self._declare(FakeChannel(key, newest_only=False))

    def latest(self, key: str) -> FakeChannel:
        return self._declare(FakeChannel(key, newest_only=True))

    def doorbell(self, key: str) -> FakeDoorbell:
        return self.doorbells.setdefault(key, FakeDoorbell(self, key))

    def subscribe(self, key: str, on_sample: Callable[[object], None]) -> FakeAnswer:
        """A callback subscriber; run on the publishing thread, as Zenoh runs it on its own."""
        callbacks = self.callbacks.setdefault(key, [])
        callbacks.append(on_sample)
        return FakeAnswer(lambda: b"", lambda: callbacks.remove(on_sample))

    def publisher(
        self, key: str, *, realtime: bool = False, latest: bool = False
    ) -> FakePublication:
        return self.publications.setdefault(key, FakePublication(key, realtime, latest))

    def answer(self, key: str, payload: Callable[[], bytes]) -> FakeAnswer:
        return self.answers.setdefault(key, FakeAnswer(payload))

    def _declare(self, channel: FakeChannel) -> FakeChannel:
        self.channels.setdefault(channel.key, []).append(channel)
        return channel

    # -- the rest of the cell --------------------------------------------------------------
    def publish(self, key: str, payload: bytes) -> None:
        """A sample arrives in every live channel on ``key``."""
        for channel in self.channels.get(key, []):
            if not channel.undeclared:
                channel.put(payload)
        for callback in list(self.callbacks.get(key, [])):
            callback(payload)

    def query(self, key: str) -> bytes:
        """What a query on ``key`` is answered."""
        answer = self.answers[key]
        assert not answer.undeclared
        return answer.payload()

    def published(self, key: str) -> list[bytes]:
        publication = self.publications.get(key)
        return [] if publication is None else publication.payloads
