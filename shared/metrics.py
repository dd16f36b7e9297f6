"""Rolling windows of measurements, summarised as percentiles for the metrics keys."""

from __future__ import annotations

import numpy as np

from motocell.shared.bus.schemas import Percentiles


class Window:
    """The last ``size`` values (microseconds) in a preallocated ring: adding costs no
    allocation, so the executor can record every tick's lateness on its hot path."""

    def __init__(self, size: int) -> None:
        self._values = np.zeros(size, dtype=np.float64)
        self._next = 0
        self._count = 0

    def add(self, value_us: float) -> None:
        self._values[self._next] = value_us
        self._next = (self._next + 1) % len(self._values)
        self._count = min(self._count + 1, len(self._values))

    def summary(self) -> Percentiles:
        if self._count == 0:
            return Percentiles(0, 0.0, 0.0, 0.0)
        ordered = np.sort(self._values[: self._count])
        return Percentiles(
            self._count, percentile(ordered, 50), percentile(ordered, 99), float(ordered[-1])
        )

    def clear(self) -> None:
        self._next = 0
        self._count = 0


def percentile(ordered: np.ndarray, q: float) -> float:
    """``np.percentile``'s default (linear between the two nearest ranks) of sorted values.
    Not numpy's own: its first call imports ``numpy.ma``, whose modules a forked service would
    hold as pages of its own (the executor's summary at its start: 4 MiB, docs/startup.md)."""
    rank = (len(ordered) - 1) * q / 100
    below = int(rank)
    above = min(below + 1, len(ordered) - 1)
    return float(ordered[below] + (rank - below) * (ordered[above] - ordered[below]))
