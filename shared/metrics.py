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
        values = self._values[: self._count]
        p50, p99 = np.percentile(values, (50, 99))
        return Percentiles(self._count, float(p50), float(p99), float(values.max()))

    def clear(self) -> None:
        self._next = 0
        self._count = 0
