"""What the interpolator tells the rest of the cell besides its increments: its slot, published
when it changes and answered to a query on the same key (a gateway that starts, or lost track of
it, asks), and its metrics every METRICS_S while anyone subscribes to them."""

from __future__ import annotations

import time
from collections.abc import Callable

from motocell.services.interpolator.bus import Bus
from motocell.services.interpolator.core.feeder import Feeder
from motocell.services.interpolator.core.states import Phase
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import InterpolatorMetrics, Slot, encode

METRICS_S = 1.0


class Reports:
    """The slot (published on every change, answered when asked) and the metrics, with the
    time the slot was full."""

    def __init__(
        self,
        bus: Bus,
        keys: CellKeys,
        group_index: int,
        feeder: Feeder,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.feeder = feeder
        self.clock = clock
        self.slot_pub = bus.publisher(keys.group_slot(group_index), realtime=True)
        self.metrics_pub = bus.publisher(keys.group_metrics(group_index), latest=True)
        self.published_slot: Slot | None = None
        self._slot_bytes = encode(feeder.slot())
        """What a slot query is answered: encoded in the loop's thread, read on Zenoh's."""
        self._asked = bus.answer(keys.group_slot(group_index), lambda: self._slot_bytes)
        self.next_metrics = clock() + METRICS_S
        self.busy_s = 0.0
        self.last = clock()

    def before_progress(self) -> None:
        now = self.clock()
        if self.feeder.phase is Phase.SENDING:
            self.busy_s += now - self.last  # the slot was full since the last pass
        self.last = now

    def after_progress(self) -> None:
        feeder = self.feeder
        slot = feeder.slot()
        if slot != self.published_slot:
            data = encode(slot)
            self.slot_pub.put(data)
            self._slot_bytes = data
            self.published_slot = slot
        now = self.clock()
        if now >= self.next_metrics:
            self.next_metrics = now + METRICS_S
            if self.metrics_pub.observed():
                counts = feeder.counts
                metrics = InterpolatorMetrics(
                    counts.points_accepted,
                    counts.increments_sent,
                    self.busy_s,
                    counts.busy_episodes,
                )
                self.metrics_pub.put(encode(metrics))

    def close(self) -> None:
        self._asked.undeclare()
