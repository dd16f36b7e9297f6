"""A scripted Zenoh session for the launcher's notices: each declares one latest-value
subscription and reads it with ``try_recv``; the test puts the samples it would receive."""

from __future__ import annotations

from typing import cast

import msgspec
import zenoh

from motocell.shared.bus.schemas import encode


class Sample:
    def __init__(self, payload: bytes, key: str) -> None:
        self.payload = zenoh.ZBytes(payload)
        self.key_expr = key


class Subscriber:
    def __init__(self, key: str) -> None:
        self.key = key
        self.waiting: list[Sample] = []
        self.undeclared = 0

    def try_recv(self) -> Sample | None:
        return self.waiting.pop() if self.waiting else None

    def undeclare(self) -> None:
        self.undeclared += 1


class Session:
    def __init__(self) -> None:
        self.subscriber: Subscriber | None = None

    def declare_subscriber(self, key: str, _handler: object) -> Subscriber:
        self.subscriber = Subscriber(key)
        return self.subscriber

    def put(self, payload: msgspec.Struct) -> None:
        """``payload`` arrives on the one subscription."""
        assert self.subscriber is not None
        self.subscriber.waiting.append(Sample(encode(payload), self.subscriber.key))

    def zenoh(self) -> zenoh.Session:
        return cast(zenoh.Session, self)
