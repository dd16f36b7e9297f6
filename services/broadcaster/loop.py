"""The broadcaster's one thread: a tick in, its state out to the TCP clients and on Zenoh.

Every cycle, in this order: the newest tick (or a wake-up without one), the snapshot if one is
due, waiting connections taken, the frames encoded once and written to every client, then the
``state`` sample for observers with the commanded joints and the arms' poses (after the
sockets: the TCP clients are the ones a late frame hurts, and their frames carry the feedback
joints only), then the reports, and last when to wake if no tick comes
(``core.broadcaster.Broadcaster.next_wake``). Nothing here blocks except the wait for the next
tick, or for the next beat while the executor's clock rests.

The ``state`` sample, and the commanded joints and poses only it carries, are made only while a
subscriber on the bus matches the key: with nobody observing, the kinematics would take CPU from
the cell's own processes for nothing (docs/state-path.md, One thread per cycle).

Written against Protocols: the bus's (``bus.TickFeed``, ``bus.StateReports``,
``bus.Publication``) and the state port's (``StateClients``), so a unit test drives a cycle with
fakes.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Protocol

from motocell.services.broadcaster.bus import StateReports, TickFeed
from motocell.services.broadcaster.core.backlog import Cycle
from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.services.broadcaster.core.frames import state_frames
from motocell.shared.bus.adapters import Publication
from motocell.shared.bus.channels import StopSignal
from motocell.shared.bus.schemas import State, encode
from motocell.shared.protocol.codec import ByteOrder


class StateClients(Protocol):
    """The state port as the loop drives it (``state_port.StatePort``)."""

    @property
    def clients(self) -> Sequence[object]:
        """The clients connected now."""
        ...

    @property
    def closed_stuck(self) -> int:
        """Clients closed because they took nothing for ``core.backlog.STUCK_S``."""
        ...

    def admit(self, motion_queued: bool) -> None:
        """Take the connections waiting (motoros1 §6 limits)."""
        ...

    def send(self, cycle: Cycle, now: float) -> None:
        """One cycle's frames to every client, as far as each takes them now."""
        ...

    def flush(self, now: float) -> None:
        """The backlogs, as far as the clients take them now."""
        ...

    def replaced_total(self) -> int:
        """Cycles clients missed because a newer one replaced them."""
        ...

    def close(self) -> None: ...


class StateLoop:
    def __init__(
        self,
        broadcaster: Broadcaster,
        ticks: TickFeed,
        port: StateClients,
        *,
        byte_order: ByteOrder,
        state: Publication,
        reports: StateReports,
        clock: Callable[[], float] = time.monotonic,
        clock_ns: Callable[[], int] = time.monotonic_ns,
    ) -> None:
        self.broadcaster = broadcaster
        self.ticks = ticks
        self.port = port
        self.byte_order = byte_order
        self.state = state
        self.reports = reports
        self.clock = clock
        self.clock_ns = clock_ns
        self._wake: float | None = None
        self._framed: tuple[State | None, tuple[bytes, ...]] = (None, ())

    def run(self, stop: StopSignal) -> None:
        """Cycles until ``stop`` is set (the tick feed wakes at stop)."""
        while not stop.is_set():
            self.cycle()

    def cycle(self) -> None:
        tick = self.ticks.next(self._wake, ticks_expected=self.broadcaster.ticks_expected)
        broadcaster, port = self.broadcaster, self.port
        now = self.clock()
        port.admit(broadcaster.motion_queued())
        clients = bool(port.clients)
        state = (
            broadcaster.on_wake(now, clients) if tick is None else broadcaster.on_tick(tick, now)
        )
        if state is not None and port.clients:
            port.send(self._frames(state), now)
            if tick is not None:
                self.reports.written(self.clock_ns() - state.tick_ns)
        else:
            port.flush(now)
        if state is not None and self.state.observed():
            self.state.put(encode(broadcaster.for_observers(state)))
        self.reports.report(now, len(port.clients), port.replaced_total(), port.closed_stuck)
        beat = broadcaster.next_wake(now, bool(port.clients))
        self._wake = self.reports.next_due if beat is None else min(beat, self.reports.next_due)

    def _frames(self, state: State) -> tuple[bytes, ...]:
        """The frames of ``state``; a beat that repeats the last tick with the controller as it
        was (the executor resting) reuses the last frames: they carry no sequence number."""
        last, frames = self._framed
        if last is None or state.groups is not last.groups or state.status != last.status:
            frames = state_frames(state, self.byte_order)
            self._framed = (state, frames)
        return frames

    def close(self) -> None:
        """Close the port and tell the controller its state clients are gone."""
        port = self.port
        port.close()
        self.reports.report(self.clock(), 0, port.replaced_total(), port.closed_stuck)
