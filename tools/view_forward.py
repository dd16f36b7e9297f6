"""``motocell view``'s forwarder: Zenoh's threads keep each key's newest sample
(``view_rate.Pacing``), and one thread hands the samples that are due to the view's channels.

Unlike ``motocell record``'s queue, which keeps every sample and, on a machine that cannot keep
up, falls further and further behind, this one holds one sample per key: the sending thread
is never more than one sample per key behind, however slow it is.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import zenoh

from motocell.shared.service import StopFlag
from motocell.tools.view_rate import Pacing, Sample

Write = Callable[[int, str, bytes], None]
"""Where a due sample goes: its receive time (ns since the Unix epoch), key and payload."""
Clock = Callable[[], int]
"""A monotonic clock in ns."""


class PacedForwarder:
    """At most ``rate_hz`` samples a second of each key to ``write``, each its key's newest.

    A ``write`` that raises (a bug: the view's channels only publish) stops the view through
    ``stop`` and is kept in ``error``."""

    def __init__(
        self, write: Write, rate_hz: float, stop: StopFlag, clock: Clock = time.monotonic_ns
    ) -> None:
        self._write = write
        self._stop = stop
        self._clock = clock
        self._pacing = Pacing(max(1, round(1e9 / rate_hz)))
        self._changed = threading.Condition()
        """Held to offer or take a sample; notified when one may be due sooner, or on close."""
        self._closed = False
        self.error: Exception | None = None
        self._thread = threading.Thread(target=self._send, name="view-forwarder", daemon=True)

    def start(self) -> None:
        """Start the sending thread; ``close`` ends it."""
        self._thread.start()

    def on_sample(self, sample: zenoh.Sample) -> None:
        """Runs on a Zenoh thread: only stamps and keeps the sample."""
        self.offer(Sample(time.time_ns(), str(sample.key_expr), sample.payload.to_bytes()))

    def offer(self, sample: Sample) -> None:
        with self._changed:
            if self._pacing.offer(sample):
                self._changed.notify()

    def close(self) -> None:
        """End the sending thread; what waits is dropped (the view keeps nothing)."""
        with self._changed:
            self._closed = True
            self._changed.notify()
        self._thread.join()

    def _send(self) -> None:
        while (due := self._next_due()) is not None:
            try:
                for sample in due:
                    self._write(*sample)
            except Exception as exc:  # reported by the command, which then stops
                self.error = exc
                self._stop.set()
                return

    def _next_due(self) -> list[Sample] | None:
        """The samples due, once there are any; None once closed."""
        with self._changed:
            while not self._closed:
                now = self._clock()
                due = self._pacing.due(now)
                if due:
                    return due
                next_ns = self._pacing.next_due_ns()
                self._changed.wait(None if next_ns is None else (next_ns - now) / 1e9)
            return None
