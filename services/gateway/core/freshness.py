"""How old the republished state the gateway decides on is. Pure: the adapter passes the time.

The controller status and each group's queue state are republished every HEARTBEAT_S even when
nothing changes. A stream not heard for STALE_AFTER_S has stopped reaching the gateway, whatever
the reason (once a queue state stayed frozen here for minutes while the executor published it
at 10 Hz); what it last said is then treated as missing (``CellState.expire``), which is logged
once, and the adapter subscribes again, every STALE_AFTER_S until the stream is heard again.

Silence counts only while the gateway itself runs. The adapter checks every HEARTBEAT_S; when
a check comes much later than that, the gateway was stalled (a loaded host), the samples sent
meanwhile are still queued behind it, and the stall counts as CHECK_GAP_S at most. Otherwise
every stall of the gateway would make it forget the whole cell the moment it wakes.
"""

from __future__ import annotations

import logging

from motocell.shared.bus.liveness import HEARTBEAT_S

log = logging.getLogger("gateway")

STALE_HEARTBEATS = 5
"""Heartbeats a stream may miss before it counts as stopped: a loaded host delays samples by
tens of milliseconds, not half a second, and a trajectory point must not be checked against
older state than that."""
STALE_AFTER_S = STALE_HEARTBEATS * HEARTBEAT_S
CHECK_GAP_S = 2 * HEARTBEAT_S
"""The most one check adds to a stream's silence (see the module's docstring)."""


class Freshness:
    """How long each stream has been silent, and which have stopped."""

    def __init__(self) -> None:
        self._silent: dict[str, float] = {}
        """Per stream heard at least once: seconds of silence since, while the gateway ran."""
        self._stale: dict[str, float] = {}
        """The streams that stopped, and their silence when last subscribed to again."""
        self._checked: float | None = None

    def heard(self, stream: str) -> None:
        self._silent[stream] = 0.0
        if self._stale.pop(stream, None) is not None:
            log.info("%s heard again", stream)

    def went_stale(self, now: float) -> list[str]:
        """Call every HEARTBEAT_S: the streams that stopped since the last call (each logged
        once). A stream never heard has not stopped: its publisher may not run yet."""
        gap = 0.0 if self._checked is None else min(now - self._checked, CHECK_GAP_S)
        self._checked = now
        for stream in self._silent:
            self._silent[stream] += gap
        stopped = [
            stream
            for stream, silent in self._silent.items()
            if stream not in self._stale and silent > STALE_AFTER_S
        ]
        for stream in stopped:
            log.warning(
                "%s not heard for %.2f s: treated as missing; subscribing again",
                stream,
                self._silent[stream],
            )
            self._stale[stream] = self._silent[stream]
        return stopped

    def retry_due(self) -> list[str]:
        """The streams still stopped STALE_AFTER_S after they were last subscribed to again."""
        due = [
            stream
            for stream, tried in self._stale.items()
            if self._silent[stream] - tried > STALE_AFTER_S
        ]
        for stream in due:
            self._stale[stream] = self._silent[stream]
        return due
