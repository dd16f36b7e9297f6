"""What the services' fake buses share: a publication (``shared.bus.adapters.Publication``) that
keeps what was put and says it is observed when the test says a subscriber matches, a ring
channel (``shared.bus.adapters.Channel``) a test puts payloads on, and a doorbell that puts its
empty sample on the fake bus it rings."""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Protocol

WAIT_S = 5.0
"""Deadline for what another thread is expected to do soon (generous for a loaded host)."""


@dataclass
class FakePublication:
    key: str
    realtime: bool = False
    latest: bool = False
    payloads: list[bytes] = field(default_factory=list)
    subscribed: bool = False
    """What ``observed`` says: whether a subscriber on the bus matches."""
    undeclared: bool = False

    def put(self, payload: bytes) -> None:
        self.payloads.append(payload)

    def observed(self) -> bool:
        return self.subscribed

    def undeclare(self) -> None:
        self.undeclared = True


class Publishing(Protocol):
    def publish(self, key: str, payload: bytes) -> None: ...


class FakeDoorbell:
    def __init__(self, bus: Publishing, key: str) -> None:
        self._bus = bus
        self.key = key
        self.rung = 0
        self.closed = False

    def ring(self) -> None:
        self.rung += 1
        self._bus.publish(self.key, b"")

    def close(self) -> None:
        self.closed = True


class FakeChannel:
    """A ring channel: the newest ``size`` payloads; ``recv`` blocks until one comes (at most
    ``WAIT_S``: a test that would hang fails instead)."""

    def __init__(self, key: str, size: int) -> None:
        self.key = key
        self.size = size
        self._kept: deque[bytes] = deque(maxlen=size)
        self._arrived = threading.Condition()
        self.rung = 0
        self.closed = False

    def put(self, payload: bytes) -> None:
        with self._arrived:
            self._kept.append(payload)
            self._arrived.notify_all()

    def recv(self) -> bytes:
        with self._arrived:
            if not self._arrived.wait_for(lambda: bool(self._kept), WAIT_S):
                raise TimeoutError(f"nothing on {self.key} within {WAIT_S} s")
            return self._kept.popleft()

    def try_recv(self) -> bytes | None:
        with self._arrived:
            return self._kept.popleft() if self._kept else None

    def ring(self) -> None:
        self.rung += 1
        self.put(b"")

    def close(self) -> None:
        self.closed = True
