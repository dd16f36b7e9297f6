"""A publication for the services' fake buses (``shared.bus.adapters.Publication``): it keeps
what was put, and says it is observed when the test says a subscriber matches."""

from __future__ import annotations

from dataclasses import dataclass, field


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
