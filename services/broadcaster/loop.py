"""The broadcaster's one thread: a tick in, its state out to the TCP clients and on Zenoh.

Every cycle, in this order: the newest tick (or a wake-up without one), the snapshot if one is
due, waiting connections taken, the frames encoded once and written to every client, then the
``state`` sample for observers with the commanded joints and the arms' poses (after the
sockets: the TCP clients are the ones a late frame hurts, and their frames carry the feedback
joints only), then the reports, and last when to wake if no tick comes
(``core.Broadcaster.next_wake``). Nothing here blocks except the wait for the next tick, or for
the next beat while the executor's clock rests.

The ``state`` sample, and the commanded joints and poses only it carries, are made only while a
subscriber on the bus matches the key (Zenoh's matching status, well under a microsecond to
read): with nobody observing, the kinematics would take CPU from the cell's own processes for
nothing (figure 5's slot turnaround p99 measured about 0.4 ms worse on this 2-core machine with
them).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

from motocell.services.broadcaster.core import Broadcaster, Pacing
from motocell.services.broadcaster.frames import state_frames
from motocell.services.broadcaster.state_port import StatePort
from motocell.shared.bus.schemas import State, Tick, encode
from motocell.shared.protocol.codec import ByteOrder


class TickFeed(Protocol):
    def next(self, deadline: float | None, ticks_expected: bool) -> Tick | None:
        """The newest tick; None when woken without one at ``deadline`` (time.monotonic()).
        ``ticks_expected``: block for a tick; else sleep until ``deadline``."""
        ...


class ReportSink(Protocol):
    def written(self, age_ns: int) -> None: ...

    def report(self, now: float, clients: int, replaced: int, stuck_closed: int) -> None: ...

    @property
    def next_due(self) -> float: ...


class StateLoop:
    def __init__(
        self,
        broadcaster: Broadcaster,
        ticks: TickFeed,
        port: StatePort,
        *,
        byte_order: ByteOrder,
        publish_state: Callable[[bytes], object],
        observed: Callable[[], bool],
        reports: ReportSink,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.broadcaster = broadcaster
        self.ticks = ticks
        self.port = port
        self.byte_order = byte_order
        self.publish_state = publish_state
        self.observed = observed
        self.reports = reports
        self.clock = clock
        self._wake: float | None = None
        self._framed: tuple[State | None, tuple[bytes, ...]] = (None, ())

    def cycle(self) -> None:
        resting = self.broadcaster.pacing is Pacing.AT_REST
        tick = self.ticks.next(self._wake, ticks_expected=not resting)
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
                self.reports.written(time.monotonic_ns() - state.tick_ns)
        else:
            port.flush(now)
        if state is not None and self.observed():
            self.publish_state(encode(broadcaster.for_observers(state)))
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
