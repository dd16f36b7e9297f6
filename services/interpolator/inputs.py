"""The interpolator's inputs as its one thread reads them: straight from Zenoh channels, with no
Python callback and no queue in between (style §10).

A point is what the slot turnaround waits for (gateway publishes it -> the interpolator takes
it -> its slot says so), so the thread blocks on the point channel's ``recv`` and wakes the
moment one arrives; the executor's queue state and the controller's status are only read then,
newest first from latest-value channels. That removed one thread hand-off per point (a
callback's thread, then a queue to this one) and every wake-up for a queue state (250 a second
while the robot moves) or a status that nothing had to act on.

zenoh-python 1.10 has no ``select`` over channels and no ``recv`` with a timeout, so two cases
do not block on points:

- waiting for the ring (a segment waiting for room, a point for its epoch, no queue state yet):
  the thread polls every interpolation period instead, since only the ring can unblock it and
  it changes at most once a tick;
- the slot's refresh, metrics and stopping: a doorbell thread puts an empty sample on the
  point key every ``wake_s`` and once at stop. It never leaves this session
  (``Locality.SESSION_LOCAL``) and touches nothing else.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator

import zenoh

from motocell.shared.bus.channels import Doorbell, decoded, newest
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
    def __init__(self, ctx: ServiceContext, group: int, wake_s: float) -> None:
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
        self._period_s = ctx.cell.period_s
        self._wake_s = wake_s
        self._stop = ctx.stop
        self._woken_by: zenoh.Sample | None = None
        self._ringer = threading.Thread(target=self._ring, name="interpolator-doorbell")
        self._ringer.start()

    def _ring(self) -> None:
        while not self._stop.wait(self._wake_s):
            self._doorbell.ring()
        self._doorbell.ring()

    def close(self) -> None:
        """Call once stopped (the doorbell thread ends with the stop flag)."""
        self._ringer.join()
        self._doorbell.close()
        for subscriber in (self._points, self._queues, self._statuses):
            subscriber.undeclare()

    def wait(self, for_ring: bool) -> None:
        """Block until a point arrives (or the doorbell rings); ``for_ring``: for one period at
        most, as only the executor's next queue state can let the caller go on."""
        if for_ring:
            self._stop.wait(self._period_s)
        else:
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
