"""Reading Zenoh channel handlers from a service's own thread, with no Python callback.

zenoh-python 1.10 has no ``recv`` with a timeout and no ``select`` over channels, so a thread
blocked in ``recv()`` is woken by a *doorbell*: an empty sample put on the channel's own key
that never leaves the session (``Locality.SESSION_LOCAL``). Every motocell payload is a
non-empty msgpack array, so an empty sample can only be a doorbell.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol, TypeVar

import zenoh

from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.schemas import Decoder
from motocell.shared.timerfd import DeadlineTimer

if TYPE_CHECKING:
    from motocell.shared.bus.adapters import Declared

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
    at stop. Its own thread sleeps in ``poll`` on a kernel timer (``shared.timerfd``) until
    then, so a service waiting for nothing but its inputs costs no wake-up at all, and an owner
    that moves its deadline at every sample (the ROS 2 face, following the cell's state) costs
    none either.

    A deadline is rung once; the owner sets the next one each time it is about to block.
    """

    def __init__(self, ring: Callable[[], None], stop: StopSignal, name: str) -> None:
        self._ring = ring
        self._stop = stop
        self._timer = DeadlineTimer()
        self._thread = threading.Thread(target=self._run, name=name)

    def start(self) -> None:
        self._thread.start()

    def wake_at(self, deadline: float | None) -> None:
        """Ring at ``deadline`` (CLOCK_MONOTONIC seconds; None: only at stop) instead of the
        deadline set before, waking nobody; from the owner's thread alone (the timer's one
        setting is not guarded)."""
        self._timer.set(None if deadline is None else round(deadline * 1e9))

    def _run(self) -> None:
        poller = select.poll()
        poller.register(self._stop.fileno(), select.POLLIN)
        poller.register(self._timer.fileno(), select.POLLIN)
        while not self._stop.is_set():
            poller.poll()
            if self._timer.take():
                self._ring()
        self._ring()

    def close(self) -> None:
        """After the stop flag is set: the thread ends, having rung once more."""
        self._thread.join()
        self._timer.close()


class Parking:
    """A thread's wait for the samples on a key while it expects none for a while, without
    waking: zenoh-python 1.10's blocking ``recv()`` waits in slices of 100 ms to run Python's
    signal handlers, 10 wake-ups a second of a thread with nothing to do (docs/timing.md, At
    rest).

    Parked, the thread polls a pipe instead, to which a callback subscriber on the same key
    writes a byte per sample (doorbells included); the samples themselves still wait in the
    thread's own channel, read as before. The subscriber is declared only while parked, so no
    Python runs on Zenoh's threads while the key is busy (docs/conventions.md, The bus): the
    owner parks when it has had nothing for a while and unparks when something comes.

    ``subscribe`` declares a callback subscriber on the key. ``park_and_wait`` reads the owner's
    channel once more after parking (a sample may have come before the subscriber) and only
    then waits; an owner that polls the pipe itself (``fileno``) does the same. A byte left by a
    sample already read wakes the next wait once, for nothing.
    """

    def __init__(
        self, subscribe: Callable[[Callable[[object], None]], Declared], stop: StopSignal
    ) -> None:
        self._subscribe = subscribe
        self._stop = stop
        self._read, self._write = os.pipe()
        for fd in (self._read, self._write):
            os.set_blocking(fd, False)
        self._subscription: Declared | None = None
        self._closing = threading.Lock()
        self._closed = False

    def park(self) -> None:
        if self._subscription is None:
            self._subscription = self._subscribe(self._on_sample)

    def _on_sample(self, _sample: object) -> None:
        # zenoh-python may still call a callback after its undeclare returned: never into a
        # pipe already closed, whose descriptor may be another file's by then.
        with self._closing, contextlib.suppress(BlockingIOError):  # a byte is waiting already
            if not self._closed:
                os.write(self._write, b"\0")

    def park_and_wait(self, take: Callable[[], T | None]) -> T | None:
        """Parked, what ``take`` (the owner's channel's ``try_recv``) has at once, else None once
        a sample came (the owner reads its channel next) or the stop."""
        self.park()
        came = take()
        if came is None:
            self.wait()
        return came

    def wait(self) -> None:
        """Until a sample came since the last wait (or while parked before it), or the stop."""
        poller = select.poll()
        poller.register(self._stop.fileno(), select.POLLIN)
        poller.register(self._read, select.POLLIN)
        poller.poll()
        self.clear()

    def fileno(self) -> int:
        """Readable once a sample came while parked: for an owner that polls it beside other
        descriptors of its own, and then calls ``clear``."""
        return self._read

    def clear(self) -> None:
        """Forget the samples told so far (the owner reads its channel next)."""
        with contextlib.suppress(BlockingIOError):
            while os.read(self._read, 64):
                pass

    def unpark(self) -> None:
        """Cheap when not parked: the interpolator calls it for every point it reads."""
        if self._subscription is None:
            return
        self._subscription.undeclare()
        self._subscription = None
        self.clear()

    def close(self) -> None:
        self.unpark()
        with self._closing:
            self._closed = True
            os.close(self._read)
            os.close(self._write)


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
