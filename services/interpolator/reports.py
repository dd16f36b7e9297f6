"""What the interpolator tells the rest of the cell besides its increments: its slot (on every
change, and every SLOT_REFRESH_S) and its metrics (every METRICS_S)."""

from __future__ import annotations

import time

from motocell.services.interpolator.core import Feeder
from motocell.shared.bus.schemas import InterpolatorMetrics, Slot, encode
from motocell.shared.bus.session import publisher
from motocell.shared.service import ServiceContext

SLOT_REFRESH_S = 0.1
"""Also publish the slot periodically, so a gateway that (re)starts learns it, and one that
forgot it learns it again: at start-up the controller's statuses can still list this
interpolator as missing after its first slot went out, and the gateway forgets a missing
interpolator's slot. At 0.5 s that wait made up a quarter of a cell's start-up (motion-ready
1.2 s instead of 0.9 s); ten small samples a second cost nothing measurable."""
METRICS_S = 1.0


class Reports:
    """The slot (on every change, and every SLOT_REFRESH_S) and the metrics (every METRICS_S),
    with the time the slot was full."""

    def __init__(self, ctx: ServiceContext, group_index: int, feeder: Feeder) -> None:
        self.feeder = feeder
        self.slot_pub = publisher(ctx.session, ctx.keys.group_slot(group_index), realtime=True)
        self.metrics_pub = publisher(ctx.session, ctx.keys.group_metrics(group_index), latest=True)
        self.published_slot: Slot | None = None
        self.next_refresh = 0.0
        self.next_metrics = time.monotonic() + METRICS_S
        self.busy_s = 0.0
        self.last = time.monotonic()

    def before_progress(self) -> None:
        now = time.monotonic()
        if self.feeder.segment is not None:
            self.busy_s += now - self.last  # the slot was full since the last pass
        self.last = now

    def after_progress(self) -> None:
        feeder = self.feeder
        slot = feeder.slot()
        now = time.monotonic()
        if slot != self.published_slot or now >= self.next_refresh:
            self.slot_pub.put(encode(slot))
            self.published_slot = slot
            self.next_refresh = now + SLOT_REFRESH_S
        if now >= self.next_metrics:
            metrics = InterpolatorMetrics(
                feeder.points_accepted, feeder.increments_sent, self.busy_s, feeder.busy_episodes
            )
            self.metrics_pub.put(encode(metrics))
            self.next_metrics = now + METRICS_S
