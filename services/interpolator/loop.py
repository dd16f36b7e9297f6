"""The interpolator's one thread: points, queue states and statuses in, increments and the slot
out (``inputs`` for how a pass is woken, ``reports`` for what it publishes).

Every pass, in this order: wait for the next point, or for the executor's next queue state when
only that can let the feeder go on; the newest status (the tool for the segments to come); the
newest queue state, before the points, since a cleared ring ends the trajectory they might
extend; the points, kept for the feeder up to the limit (``core.pending``); the feeder sends what
the ring has room for and takes points; the slot is published in the same pass that took a
point.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from typing import Protocol

from motocell.services.interpolator.core.feeder import Feeder
from motocell.services.interpolator.core.pending import queue_point
from motocell.shared.bus.schemas import ControllerStatus, Point, QueueState


class InputFeed(Protocol):
    def wait(self, for_ring: bool, deadline: float) -> None:
        """Block until the executor's next queue state (``for_ring``) or the next point
        arrives, or ``deadline`` (time.monotonic()) passes; a stop ends either."""
        ...

    def status(self) -> ControllerStatus | None: ...

    def queue(self) -> QueueState | None: ...

    def points(self) -> Iterator[Point]: ...


class ReportSink(Protocol):
    @property
    def next_metrics(self) -> float:
        """When the metrics are next due (time.monotonic())."""
        ...

    def before_progress(self) -> None: ...

    def after_progress(self) -> None: ...


class Stop(Protocol):
    def is_set(self) -> bool: ...


class FeederLoop:
    def __init__(
        self, feeder: Feeder, inputs: InputFeed, reports: ReportSink, points_outstanding: int
    ) -> None:
        self.feeder = feeder
        self.inputs = inputs
        self.reports = reports
        self.points_outstanding = points_outstanding
        self.points: deque[Point] = deque()
        """The points waiting for the feeder."""

    def run(self, stop: Stop) -> None:
        while not stop.is_set():
            self.step()

    def step(self) -> None:
        """One pass: wait, read the inputs, let the feeder go on, report."""
        feeder, inputs, reports = self.feeder, self.inputs, self.reports
        inputs.wait(feeder.waits_for_ring(self.points), reports.next_metrics)
        status = inputs.status()
        if status is not None:
            feeder.on_status(status)
        queue = inputs.queue()
        if queue is not None:
            feeder.on_queue(queue)
        for point in inputs.points():
            queue_point(self.points, point, self.points_outstanding)
        reports.before_progress()
        feeder.progress(self.points)
        reports.after_progress()
