"""The executor's ticks as the broadcaster's main thread reads them: straight from a Zenoh ring
channel, with no Python callback and no queue in between (style §10).

zenoh-python 1.10 has no ``recv`` with a timeout, and the thread must also wake when ticks stop
(the state port keeps beating without them) and when the service stops. A small watch thread
does that: it rings a doorbell, an empty sample put on the tick key that never leaves this
session (``Locality.SESSION_LOCAL``), after ``silence_s`` without a tick and once at stop. It
touches neither the state nor the sockets; only ticks and the doorbell reach the main thread.
"""

from __future__ import annotations

import logging
import threading
import time

import msgspec
import zenoh

from motocell.shared.bus.channels import Doorbell, is_doorbell
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, Tick
from motocell.shared.service import StopFlag

log = logging.getLogger("broadcaster")

CHANNEL_SIZE = 8
"""Ticks kept while the main thread is busy; only the newest is used, older ones and
doorbells are dropped by the ring, never by blocking Zenoh."""

_tick_decoder = Decoder(Tick)


class TickSource:
    def __init__(
        self, session: zenoh.Session, keys: CellKeys, silence_s: float, stop: StopFlag
    ) -> None:
        self._subscriber = session.declare_subscriber(
            keys.executor_tick, zenoh.handlers.RingChannel(CHANNEL_SIZE)
        )
        self._doorbell = Doorbell(session, keys.executor_tick)
        self._silence_s = silence_s
        self._stop = stop
        self._last_tick_at = time.monotonic()
        self._watch = threading.Thread(target=self._ring_on_silence, name="tick-watch")
        self._watch.start()

    def next(self) -> Tick | None:
        """The newest tick; None when woken without one (``silence_s`` of silence, or stop)."""
        newest: bytes | None = None
        sample: zenoh.Sample | None = self._subscriber.recv()
        while sample is not None:
            if not is_doorbell(sample):
                newest = sample.payload.to_bytes()
            sample = self._subscriber.try_recv()
        if newest is None:
            return None
        self._last_tick_at = time.monotonic()
        try:
            return _tick_decoder.decode(newest)
        except msgspec.DecodeError as exc:
            log.warning("undecodable tick dropped: %s", exc)
            return None

    def _ring_on_silence(self) -> None:
        wait = self._silence_s
        while not self._stop.wait(wait):
            quiet = time.monotonic() - self._last_tick_at
            if quiet >= self._silence_s:
                self._doorbell.ring()
                wait = self._silence_s
            else:
                wait = self._silence_s - quiet
        self._doorbell.ring()

    def close(self) -> None:
        """Stops the watch thread too: it waits on the service's stop flag."""
        self._stop.set()
        self._watch.join()
        self._doorbell.close()
        self._subscriber.undeclare()
