"""The interpolator's inputs as its one thread reads them: straight from Zenoh channels, with no
Python callback and no queue in between (docs/conventions.md).

A point is what the slot turnaround waits for (gateway publishes it -> the interpolator takes
it -> its slot says so), so the thread blocks on the point channel's ``recv`` and wakes the
moment one arrives; the executor's queue state and the controller's status are only read then,
newest first from latest-value channels. No wake-up for a queue state (250 a second while the
robot moves) or a status that nothing had to act on.

zenoh-python 1.10 has no ``select`` over channels and no ``recv`` with a timeout, so:

- waiting for the ring (a segment short of room, a point waiting for its epoch), the thread
  sleeps as long as ``core.Feeder.wait_s`` says, since only the ring can let it go on;
- its metrics and stopping: a ``Waker`` puts an empty sample on the point key at the deadline
  the thread sets, and once at stop. It never leaves this session (``Locality.SESSION_LOCAL``).
"""

from __future__ import annotations

from collections.abc import Iterator

import zenoh

from motocell.shared.bus.channels import Doorbell, Waker, decoded, newest
from motocell.shared.bus.schemas import ControllerStatus, Decoder, Point, QueueState
from motocell.shared.service import ServiceContext

POINT_CHANNEL_SIZE = 1024
"""Points (and doorbells) held in Zenoh until read. Far above what the gateway lets a group
have outstanding (``Cell.points_outstanding``), so Zenoh never blocks on it: the bound that
counts is ``queue_point``'s."""

_point_decoder = Decoder(Point)
_queue_decoder = Decoder(QueueState)
_status_decoder = Decoder(ControllerStatus)


class Inputs:
    def __init__(self, ctx: ServiceContext, group: int) -> None:
        session, keys = ctx.session, ctx.keys
        self._points = session.declare_subscriber(
            keys.group_point(group), zenoh.handlers.FifoChannel(POINT_CHANNEL_SIZE)
        )
        self._queues = session.declare_subscriber(
            keys.group_queue(group), zenoh.handlers.RingChannel(1)
        )
        self._statuses = session.declare_subscriber(
            keys.controller_status, zenoh.handlers.RingChannel(1)
        )
        self._doorbell = Doorbell(session, keys.group_point(group))
        self._waker = Waker(self._doorbell, ctx.stop, "interpolator-waker")
        self._stop = ctx.stop
        self._woken_by: zenoh.Sample | None = None

    def start(self) -> None:
        self._waker.start()

    def close(self) -> None:
        """Call once stopped (the waker ends with the stop flag)."""
        self._waker.close()
        self._doorbell.close()
        for subscriber in (self._points, self._queues, self._statuses):
            subscriber.undeclare()

    def wait(self, sleep_s: float | None, deadline: float) -> None:
        """Sleep ``sleep_s`` (waiting for the ring), or with None block until a point arrives
        or ``deadline`` (time.monotonic()) passes; a stop ends either."""
        if sleep_s is not None:
            self._stop.wait(sleep_s)
            return
        self._waker.wake_at(deadline)
        self._woken_by = self._points.recv()

    def status(self) -> ControllerStatus | None:
        """The controller's newest status since the last call, if any."""
        return newest(self._statuses, _status_decoder)

    def queue(self) -> QueueState | None:
        """The executor's newest queue state of the group since the last call, if any."""
        return newest(self._queues, _queue_decoder)

    def points(self) -> Iterator[Point]:
        """The points that arrived, in order; doorbells (empty samples) are skipped."""
        sample, self._woken_by = self._woken_by, None
        if sample is None:
            sample = self._points.try_recv()
        while sample is not None:
            point = decoded(sample, _point_decoder)
            if point is not None:
                yield point
            sample = self._points.try_recv()
