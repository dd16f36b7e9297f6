"""The face's bus, behind Protocols: the feed of the cell's ``state`` its loop reads
(``StateFeed``), the queries of its motion API (``motion_api``), what those need of a session
(``Bus``), and ``ZenohBus`` over a real one.

While the cell's clock runs the loop's thread blocks in a ring channel's ``recv`` (no Python on
Zenoh's threads for the samples, docs/conventions.md, The bus); a ``Waker`` rings the channel's
doorbell at the face's next deadline and at stop, since zenoh-python has no ``recv`` with a
timeout. While the cell rests the thread sleeps until its deadline and takes what came: one
wake-up a period, no doorbell.
"""

from __future__ import annotations

import math
import select
import time
from typing import Protocol

import zenoh

from motocell.shared.bus.adapters import Channel, Latest, ZenohChannel, ZenohLatest
from motocell.shared.bus.channels import StopSignal, Waker
from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ControllerStatus, Decoder, State
from motocell.shared.bus.session import ENCODING

CHANNEL_SIZE = 4
"""Samples kept while the loop publishes; only the newest is used."""

_state_decoder = Decoder(State)
_status_decoder = Decoder(ControllerStatus)


class Bus(Protocol):
    def latest(self, key: str) -> Latest: ...

    def channel(self, key: str, size: int) -> Channel:
        """The samples of ``key``, the newest ``size`` kept."""
        ...

    def ask(self, key: str, payload: bytes, timeout: float) -> bytes | None:
        """One query's first answer, blocking; None when nobody answered within ``timeout``."""
        ...


class ZenohBus:
    """``Bus`` over a Zenoh session."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session

    def latest(self, key: str) -> Latest:
        return ZenohLatest(self._session, key)

    def channel(self, key: str, size: int) -> Channel:
        return ZenohChannel(self._session, key, size)

    def ask(self, key: str, payload: bytes, timeout: float) -> bytes | None:
        for reply in self._session.get(key, payload=payload, encoding=ENCODING, timeout=timeout):
            if reply.ok is not None:
                return reply.ok.payload.to_bytes()
        return None


class StateFeed:
    """The cell's ``state`` samples for the loop's thread, with the ``Waker`` that ends its
    waits, and the controller's newest status (a latest-value channel, read when the loop
    wakes)."""

    def __init__(self, bus: Bus, keys: CellKeys, stop: StopSignal) -> None:
        self._key = keys.state
        self._channel = bus.channel(keys.state, CHANNEL_SIZE)
        self._status_key = keys.controller_status
        self._statuses = bus.latest(keys.controller_status)
        self._waker = Waker(self._channel.ring, stop, "state-waker")
        self._stop_poller = select.poll()
        self._stop_poller.register(stop.fileno(), select.POLLIN)

    def start(self) -> None:
        self._waker.start()

    def next(self, deadline_ns: int | None, samples_expected: bool) -> State | None:
        """The newest sample; None when woken without one, at ``deadline_ns`` (CLOCK_MONOTONIC
        ns; None: no deadline) or at stop. ``samples_expected``: block for a sample (the cell's
        clock runs), woken at the deadline by the waker; else sleep until the deadline and take
        what came, with no wake-up but that one (the cell rests: its state comes once a
        second, the face publishes every period)."""
        if samples_expected or deadline_ns is None:
            self._waker.wake_at(None if deadline_ns is None else deadline_ns / 1e9)
            return self._newest(self._channel.recv())
        self._sleep_until(deadline_ns)
        return self._newest(self._channel.try_recv())

    def _sleep_until(self, deadline_ns: int) -> None:
        wait_ms = math.ceil(max(0, deadline_ns - time.monotonic_ns()) / 1e6)
        self._stop_poller.poll(wait_ms)

    def _newest(self, payload: bytes | None) -> State | None:
        newest: State | None = None
        while payload is not None:
            # A doorbell (empty) or garbage decodes to None and leaves the newest good one.
            newest = decoded_payload(payload, _state_decoder, self._key) or newest
            payload = self._channel.try_recv()
        return newest

    def controller_status(self) -> ControllerStatus | None:
        return decoded_payload(self._statuses.take(), _status_decoder, self._status_key)

    def ring(self) -> None:
        """Wake ``next`` now, from any thread (a new reader of the face's topics)."""
        self._channel.ring()

    def close(self) -> None:
        """Once the stop flag is set: the waker ends with it."""
        self._waker.close()
        self._channel.close()
        self._statuses.undeclare()
