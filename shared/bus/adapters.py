"""The byte-level pieces of a Zenoh session that every service's bus adapter hands its shells:
a publication, the newest sample of a key, a channel a thread blocks on, a declaration to undo.
The Protocols are what the shells (and the fake buses of their unit tests) see; the Zenoh
classes are the thin implementations. Payloads are bytes both ways, so a shell decodes what it
gets and a test can feed it garbage."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import zenoh

from motocell.shared.bus.channels import Doorbell
from motocell.shared.bus.session import observed


class Publication(Protocol):
    def put(self, payload: bytes) -> None: ...

    def observed(self) -> bool:
        """Whether any subscriber on the bus matches it now."""
        ...

    def undeclare(self) -> None: ...


class Latest(Protocol):
    """A subscription that keeps only the newest sample until it is read (a Zenoh
    ``RingChannel(1)``): no Python runs on the bus's threads for it."""

    def take(self) -> bytes | None:
        """The newest payload since the last read, None if none came; never blocks."""
        ...

    def undeclare(self) -> None: ...


class Channel(Protocol):
    """A subscription whose samples wait in a Zenoh ring channel for the thread that reads it,
    which another thread can wake (a doorbell: an empty payload that never leaves the
    session)."""

    def recv(self) -> bytes:
        """The oldest payload kept, blocking until there is one; empty: the doorbell."""
        ...

    def try_recv(self) -> bytes | None:
        """The oldest payload kept, None if there is none; never blocks."""
        ...

    def ring(self) -> None:
        """Wake a thread blocked in ``recv`` (from any thread)."""
        ...

    def close(self) -> None: ...


class Declared(Protocol):
    def undeclare(self) -> None: ...


def callback_subscriber(
    session: zenoh.Session, key: str, on_sample: Callable[[zenoh.Sample], None]
) -> Declared:
    """``on_sample`` run on Zenoh's own thread for each sample on ``key``, with no thread of
    zenoh-python's in between: it must only hand the sample on (docs/conventions.md, The bus)."""
    return session.declare_subscriber(key, zenoh.handlers.Callback(on_sample, indirect=False))


class ZenohPublication:
    put: Callable[[bytes], None]

    def __init__(self, publisher: zenoh.Publisher) -> None:
        self._publisher = publisher
        self.put = publisher.put  # Zenoh's own call: no frame of ours per sample

    def observed(self) -> bool:
        return observed(self._publisher)

    def undeclare(self) -> None:
        self._publisher.undeclare()


class ZenohLatest:
    def __init__(self, session: zenoh.Session, key: str) -> None:
        self._subscriber = session.declare_subscriber(key, zenoh.handlers.RingChannel(1))

    def take(self) -> bytes | None:
        sample = self._subscriber.try_recv()
        return None if sample is None else sample.payload.to_bytes()

    def undeclare(self) -> None:
        self._subscriber.undeclare()


class ZenohChannel:
    def __init__(self, session: zenoh.Session, key: str, size: int) -> None:
        self._subscriber = session.declare_subscriber(key, zenoh.handlers.RingChannel(size))
        self._doorbell = Doorbell(session, key)

    def recv(self) -> bytes:
        return self._subscriber.recv().payload.to_bytes()

    def try_recv(self) -> bytes | None:
        sample = self._subscriber.try_recv()
        return None if sample is None else sample.payload.to_bytes()

    def ring(self) -> None:
        self._doorbell.ring()

    def close(self) -> None:
        self._doorbell.close()
        self._subscriber.undeclare()
