"""What the interpolator tells the rest of the cell besides its increments: its slot, published
when it changes and answered to a query on the same key (a gateway that starts, or lost track of
it, asks), and its metrics every METRICS_S while anyone subscribes to them."""

from __future__ import annotations

import time

import zenoh

from motocell.services.interpolator.core import Feeder
from motocell.shared.bus.schemas import InterpolatorMetrics, Slot, encode
from motocell.shared.bus.session import ENCODING, observed, publisher
from motocell.shared.service import ServiceContext

METRICS_S = 1.0


class Reports:
    """The slot (published on every change, answered when asked) and the metrics, with the
    time the slot was full."""

    def __init__(self, ctx: ServiceContext, group_index: int, feeder: Feeder) -> None:
        self.feeder = feeder
        self._slot_key = ctx.keys.group_slot(group_index)
        self.slot_pub = publisher(ctx.session, self._slot_key, realtime=True)
        self.metrics_pub = publisher(ctx.session, ctx.keys.group_metrics(group_index), latest=True)
        self.published_slot: Slot | None = None
        self._slot_bytes = encode(feeder.slot())
        """What a slot query is answered: encoded in the loop's thread, read on Zenoh's."""
        self._asked = ctx.session.declare_queryable(
            self._slot_key, zenoh.handlers.Callback(self._answer, indirect=False)
        )
        self.next_metrics = time.monotonic() + METRICS_S
        self.busy_s = 0.0
        self.last = time.monotonic()

    def _answer(self, query: zenoh.Query) -> None:
        query.reply(self._slot_key, self._slot_bytes, encoding=ENCODING)
        query.drop()

    def before_progress(self) -> None:
        now = time.monotonic()
        if self.feeder.segment is not None:
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
        now = time.monotonic()
        if now >= self.next_metrics:
            self.next_metrics = now + METRICS_S
            if observed(self.metrics_pub):
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
