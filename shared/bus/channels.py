"""Reading Zenoh channel handlers from a service's own thread, with no Python callback.

zenoh-python 1.10 has no ``recv`` with a timeout and no ``select`` over channels, so a thread
blocked in ``recv()`` is woken by a *doorbell*: an empty sample put on the channel's own key
that never leaves the session (``Locality.SESSION_LOCAL``). Every motocell payload is a
non-empty msgpack array, so an empty sample can only be a doorbell.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import threading
import time
from collections.abc import Callable
from typing import Protocol, TypeVar

import zenoh

from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.schemas import Decoder

T = TypeVar("T")

Channel = zenoh.Subscriber[zenoh.handlers.Handler[zenoh.Sample]]
"""A subscriber declared with a ``FifoChannel`` or ``RingChannel`` handler."""


class Doorbell:
    """Wakes whoever blocks in ``recv()`` on ``key``'s channel in this session, and no one else."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self._publisher = session.declare_publisher(
            key, allowed_destination=zenoh.Locality.SESSION_LOCAL
        )

    def ring(self) -> None:
        self._publisher.put(b"")

    def close(self) -> None:
        self._publisher.undeclare()


class StopSignal(Protocol):
    def is_set(self) -> bool: ...

    def fileno(self) -> int:
        """Readable once set."""
        ...


class Waker:
    """The timer of a thread that blocks in a channel's ``recv()``: calls ``ring`` (a doorbell's,
    or whichever the thread waits behind) at the deadline its owner sets (``wake_at``) and once
    at stop. Its own thread sleeps in ``poll`` until then, so a service waiting for nothing but
    its inputs costs no wake-up at all.

    A deadline is rung once; the owner sets the next one each time it is about to block.
    """

    def __init__(self, ring: Callable[[], None], stop: StopSignal, name: str) -> None:
        self._ring = ring
        self._stop = stop
        self._deadline: float | None = None
        self._lock = threading.Lock()
        self._poke_read, self._poke_write = os.pipe()
        for fd in (self._poke_read, self._poke_write):
            os.set_blocking(fd, False)
        self._thread = threading.Thread(target=self._run, name=name)

    def start(self) -> None:
        self._thread.start()

    def wake_at(self, deadline: float | None) -> None:
        """Ring at ``deadline`` (CLOCK_MONOTONIC seconds; None: only at stop) instead of the
        deadline set before. Only an earlier one wakes the thread now; a later one is found
        when it wakes for the old one."""
        with self._lock:
            earlier = deadline is not None and (self._deadline is None or deadline < self._deadline)
            self._deadline = deadline
        if earlier:
            with contextlib.suppress(BlockingIOError):  # a poke is pending already
                os.write(self._poke_write, b"\0")

    def _run(self) -> None:
        poller = select.poll()
        poller.register(self._stop.fileno(), select.POLLIN)
        poller.register(self._poke_read, select.POLLIN)
        while not self._stop.is_set():
            with self._lock:
                deadline = self._deadline
            wait = None if deadline is None else deadline - time.monotonic()
            if wait is not None and wait <= 0:
                with self._lock:
                    if self._deadline == deadline:
                        self._deadline = None
                self._ring()
                continue
            poller.poll(None if wait is None else math.ceil(wait * 1000))
            with contextlib.suppress(BlockingIOError):
                os.read(self._poke_read, 64)
        self._ring()

    def close(self) -> None:
        """After the stop flag is set: the thread ends, having rung once more."""
        self._thread.join()
        os.close(self._poke_read)
        os.close(self._poke_write)


def is_doorbell(sample: zenoh.Sample) -> bool:
    return not sample.payload.to_bytes()


def decoded(sample: zenoh.Sample | None, decoder: Decoder[T]) -> T | None:
    """The sample's payload as ``decoded_payload`` gives it; None for no sample."""
    if sample is None:
        return None
    return decoded_payload(sample.payload.to_bytes(), decoder, str(sample.key_expr))


def newest(channel: Channel, decoder: Decoder[T]) -> T | None:
    """A latest-value channel's sample since the last read, decoded; None when nothing came."""
    return decoded(channel.try_recv(), decoder)
