"""What the services' fake buses share: a publication (``shared.bus.adapters.Publication``) that
keeps what was put and says it is observed when the test says a subscriber matches, and a
doorbell that puts its empty sample on the fake bus it rings."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol


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
