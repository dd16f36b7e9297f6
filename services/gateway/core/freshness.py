"""How old the republished state the gateway decides on is, and when to ask again for what it
lacks. Pure: the owner passes the time.

The controller status and each group's queue state are republished while unchanged, and every
sample announces the most its publisher will wait before the next (``heartbeat_ms``: 100 ms
while motion is possible, 1 s while nothing can move). A stream not heard for STALE_HEARTBEATS
of the heartbeat its newest sample announced has stopped reaching the gateway, whatever the
reason; what it last said is then treated as missing (``CellState.expire``), which is logged
once, and the owner subscribes again, once per such span until the stream is heard again.

The owner does not check periodically: it checks when ``next_check`` says a stream could have
gone stale (an idle cell's gateway sleeps for seconds), and sooner when a sample announced a
shorter heartbeat than the plan assumed (``sooner``).

Silence counts only while the gateway itself runs. A check that comes more than LATE_CHECK_S
after the moment it was planned for was held up by a stall of the gateway (a loaded host), and
the samples sent meanwhile are still queued behind it. The silence is then counted only up to
LATE_CHECK_S before that moment, so every stream has LATE_CHECK_S of the gateway's running time
after the stall to be heard. Otherwise every stall of the gateway would make it forget the
whole cell the moment it wakes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from motocell.shared.bus.liveness import (
    HEARTBEAT_S,
    STALE_HEARTBEATS,
    heartbeat_ms,
    silence_bound_s,
)

log = logging.getLogger("gateway")

SHORTEST_HEARTBEAT_MS = heartbeat_ms(motion_possible=True)
LONGEST_HEARTBEAT_MS = heartbeat_ms(motion_possible=False)
"""The heartbeats the bus's publishers announce (``shared.bus.liveness``)."""
LATE_CHECK_S = HEARTBEAT_S
"""A loaded host delays a thread by tens of milliseconds; a check later than this was held up
by a stall of the gateway itself."""


def stale_after_s(announced_ms: int) -> float:
    """How long a stream whose newest sample announced ``announced_ms`` may stay silent. The
    heartbeat is taken within the bus's range: a nonsense announcement must neither make the
    owner check in a tight loop (0) nor switch ageing off (a huge one)."""
    heartbeat = min(max(announced_ms, SHORTEST_HEARTBEAT_MS), LONGEST_HEARTBEAT_MS)
    return silence_bound_s(heartbeat, STALE_HEARTBEATS)


@dataclass
class _Stream:
    bound: float
    """Seconds of silence after which it has stopped (``stale_after_s``)."""
    since: float
    """The instant from which its silence is not counted yet."""
    silent: float = 0.0
    """Seconds of silence counted up to ``since``, while the gateway ran."""
    tried: float | None = None
    """Once stopped: its silence when it was last subscribed to again."""

    def due(self) -> float:
        """When it goes stale or, stopped, is due to be subscribed to again, if the gateway
        runs until then and hears nothing."""
        counted = self.silent if self.tried is None else self.silent - self.tried
        return self.since + self.bound - counted


class Freshness:
    """How long each stream has been silent, and which have stopped."""

    def __init__(self) -> None:
        self._streams: dict[str, _Stream] = {}
        """Every stream heard at least once."""
        self._planned: float | None = None
        """What ``next_check`` answered since the last check: when the owner means to check."""
        self._sooner = False

    def heard(self, stream: str, now: float, announced_ms: int) -> None:
        """A sample of ``stream`` that announced its next within ``announced_ms``."""
        bound = stale_after_s(announced_ms)
        entry = self._streams.get(stream)
        if entry is None:
            entry = self._streams[stream] = _Stream(bound, now)
        elif entry.tried is not None:
            log.info("%s heard again", stream)
        entry.bound, entry.since, entry.silent, entry.tried = bound, now, 0.0, None
        if self._planned is None or now + bound < self._planned:
            self._sooner = True

    def sooner(self) -> bool:
        """Whether something was heard since the last ``next_check`` that may go stale before
        the check it planned (a shorter heartbeat, a first sample): plan again."""
        return self._sooner

    def went_stale(self, now: float) -> list[str]:
        """Count the silence since the last check; the streams that stopped since then (each
        logged once). A stream never heard has not stopped: its publisher may not run yet."""
        planned, self._planned = self._planned, None
        until = now
        if planned is not None and now > planned + LATE_CHECK_S:
            until = planned - LATE_CHECK_S
        stopped = []
        for stream, entry in self._streams.items():
            entry.silent += max(0.0, until - entry.since)
            entry.since = now
            if entry.tried is None and entry.silent >= entry.bound:
                log.warning(
                    "%s not heard for %.2f s: treated as missing; subscribing again",
                    stream,
                    entry.silent,
                )
                entry.tried = entry.silent
                stopped.append(stream)
        return stopped

    def retry_due(self) -> list[str]:
        """After ``went_stale``: the streams still stopped one span (their bound) after they
        were last subscribed to again."""
        due = [
            stream
            for stream, entry in self._streams.items()
            if entry.tried is not None and entry.silent - entry.tried >= entry.bound
        ]
        for stream in due:
            entry = self._streams[stream]
            entry.tried = entry.silent
        return due

    def next_check(self) -> float | None:
        """When a stream could go stale, or a stopped one is due to be subscribed to again,
        if nothing is heard meanwhile; None while no stream has been heard. The owner checks
        (``went_stale``) then: a check much later than that was held up by a stall."""
        self._sooner = False
        self._planned = min((entry.due() for entry in self._streams.values()), default=None)
        return self._planned
