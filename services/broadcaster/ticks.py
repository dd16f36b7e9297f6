"""The executor's ticks as the broadcaster's thread reads them: straight from a ring channel of
the bus, with no Python callback and no queue in between.

While ticks come, the thread blocks in the channel's ``recv``. zenoh-python 1.10 has no ``recv``
with a timeout, so a ``Waker`` rings the channel's doorbell when ticks have been silent too long,
and at stop. While the executor's clock rests no tick is expected: the thread sleeps on a pipe
until the next beat it must send from the last tick (``core.states.PACING``), parked on the
tick key (``shared.bus.channels.Parking``), so that a tick ends the sleep at once: the resting
tick the executor sends again once a second, or the first tick of a motion, which observers
then see when it happens rather than at the next beat. Either wait ends early when the state
port's acceptor has a new client (``ring``).
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import time

from motocell.services.broadcaster.bus import Bus
from motocell.shared.bus.channels import Parking, StopSignal, Waker
from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, Tick

CHANNEL_SIZE = 8
"""Ticks kept while the main thread is busy; only the newest is used, older ones and
doorbells are dropped by the ring, never by blocking Zenoh."""

_tick_decoder = Decoder(Tick)


class TickSource:
    """A ``bus.TickFeed`` over a ``Bus``, with the ``Waker`` thread that ends its waits."""

    def __init__(self, bus: Bus, keys: CellKeys, stop: StopSignal) -> None:
        self._key = keys.executor_tick
        self._channel = bus.channel(keys.executor_tick, CHANNEL_SIZE)
        self._waker = Waker(self._channel.ring, stop, "tick-waker")
        self._parking = Parking(
            lambda on_sample: bus.subscribe(keys.executor_tick, on_sample), stop
        )
        self._stop = stop
        self._rung_read, self._rung_write = os.pipe()
        for fd in (self._rung_read, self._rung_write):
            os.set_blocking(fd, False)

    def start(self) -> None:
        self._waker.start()

    def next(self, deadline: float | None, ticks_expected: bool) -> Tick | None:
        """The newest tick, or None when woken without one at ``deadline`` (time.monotonic(),
        None: no deadline), by ``ring`` or at stop. ``ticks_expected``: block for a tick (the
        executor's clock runs); else sleep until ``deadline`` and take what came."""
        if ticks_expected:
            self._parking.unpark()
            self._waker.wake_at(deadline)
            return self._newest(self._channel.recv())
        self._parking.park()
        came = self._channel.try_recv()  # before the parking
        if came is None:
            self._sleep_until(deadline)
            came = self._channel.try_recv()
        return self._newest(came)

    def _sleep_until(self, deadline: float | None) -> None:
        poller = select.poll()
        poller.register(self._stop.fileno(), select.POLLIN)
        poller.register(self._rung_read, select.POLLIN)
        poller.register(self._parking.fileno(), select.POLLIN)
        wait = None if deadline is None else max(0.0, deadline - time.monotonic())
        if poller.poll(None if wait is None else math.ceil(wait * 1000)):
            self._parking.clear()
            with contextlib.suppress(BlockingIOError):
                os.read(self._rung_read, 64)

    def _newest(self, payload: bytes | None) -> Tick | None:
        newest: bytes | None = None
        while payload is not None:
            if payload:  # empty: the doorbell
                newest = payload
            payload = self._channel.try_recv()
        return decoded_payload(newest, _tick_decoder, self._key)

    def ring(self) -> None:
        """Wake ``next`` now, whichever way it waits (from another thread)."""
        with contextlib.suppress(BlockingIOError):  # a wake-up is pending already
            os.write(self._rung_write, b"\0")
        self._channel.ring()

    def close(self) -> None:
        """Once the stop flag is set: the waker ends with it."""
        self._waker.close()
        self._parking.close()
        self._channel.close()
        os.close(self._rung_read)
        os.close(self._rung_write)
