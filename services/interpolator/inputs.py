"""The interpolator's inputs as its one thread reads them: straight from Zenoh channels, with no
Python callback and no queue in between (docs/conventions.md).

A point is what the slot turnaround waits for (gateway publishes it -> the interpolator takes
it -> its slot says so), so the thread blocks on the point channel's ``recv`` and wakes the
moment one arrives; the executor's queue state and the controller's status are only read then,
newest first from latest-value channels. No wake-up for a queue state (250 a second while the
robot moves) or a status that nothing had to act on.

zenoh-python 1.10 has no ``select`` over channels and no ``recv`` with a timeout, so:

- waiting for the ring (a segment short of room, a point waiting for its epoch), the thread
  blocks on the queue channel's ``recv`` instead: only the executor's next queue state can let
  it go on, and a cleared ring (STOP_MOTION waits 50 ms for the slots to free) is seen at once;
- its metrics and stopping: a ``Waker`` puts an empty sample on the key the thread waits on, at
  the deadline the thread sets and once at stop. It never leaves this session (a doorbell).

The point channel's ``recv()`` waits in slices of 100 ms, 10 wake-ups a second for nothing at
rest. So once no point has come for ``PARK_AFTER_S`` the thread waits parked instead
(``shared.bus.channels.Parking``: a callback on the point key tells a pipe it polls), until the
next point; the first point of a trajectory after a rest then costs one hand-off more.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

from motocell.services.interpolator.bus import Bus
from motocell.shared.bus import ignored
from motocell.shared.bus.channels import Parking, StopSignal, Waker
from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import (
    ControllerStatus,
    Decoder,
    Point,
    QueueState,
    point_fits,
)

POINT_CHANNEL_SIZE = 1024
"""Points (and doorbells) held in Zenoh until read. Far above what the gateway lets a group
have outstanding (``Cell.points_outstanding``), so Zenoh never blocks on it: the bound that
counts is ``queue_point``'s."""

PARK_AFTER_S = 1.0
"""How long without a point before the thread waits parked. A stream whose points come within
a second of each other never waits parked; after a longer pause its next point costs one
hand-off more (the callback, then the pipe)."""

MISFIT = "point of the wrong shape"
"""What a point that decodes but no gateway would send is noted as."""

_point_decoder = Decoder(Point)
_queue_decoder = Decoder(QueueState)
_status_decoder = Decoder(ControllerStatus)


class Inputs:
    def __init__(
        self,
        bus: Bus,
        keys: CellKeys,
        group: int,
        axes: int,
        stop: StopSignal,
        *,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._axes = axes
        self._point_key = keys.group_point(group)
        self._queue_key = keys.group_queue(group)
        self._status_key = keys.controller_status
        self._points = bus.fifo(self._point_key, POINT_CHANNEL_SIZE)
        self._queues = bus.latest(self._queue_key)
        self._statuses = bus.latest(self._status_key)
        self._point_bell = bus.doorbell(self._point_key)
        self._queue_bell = bus.doorbell(self._queue_key)
        self._waiting_on = self._point_bell
        self._waker = Waker(self._ring_waiting, stop, "interpolator-waker")
        self._parking = Parking(lambda on_sample: bus.subscribe(self._point_key, on_sample), stop)
        self._clock = clock
        self._last_point = clock()
        self._woken_by: bytes | None = None
        self._queue_woken_by: bytes | None = None

    def _ring_waiting(self) -> None:
        """Ring the doorbell of the channel the thread waits on now."""
        self._waiting_on.ring()

    def start(self) -> None:
        self._waker.start()

    def close(self) -> None:
        """Call once stopped (the waker ends with the stop flag)."""
        self._waker.close()
        self._point_bell.close()
        self._queue_bell.close()
        self._parking.close()
        for channel in (self._points, self._queues, self._statuses):
            channel.undeclare()

    def wait(self, for_ring: bool, deadline: float) -> None:
        """Block until the executor's next queue state (``for_ring``) or the next point arrives,
        or ``deadline`` (time.monotonic()) passes; a stop ends either."""
        if for_ring:
            self._waiting_on = self._queue_bell
            self._waker.wake_at(deadline)
            self._queue_woken_by = self._queues.recv()
            return
        self._waiting_on = self._point_bell
        park_at = self._last_point + PARK_AFTER_S
        if self._clock() < park_at:
            self._waker.wake_at(min(deadline, park_at))
            self._woken_by = self._points.recv()
            return
        self._waker.wake_at(deadline)
        self._woken_by = self._parking.park_and_wait(self._points.try_recv)

    def status(self) -> ControllerStatus | None:
        """The controller's newest status since the last call, if any."""
        return decoded_payload(self._statuses.try_recv(), _status_decoder, self._status_key)

    def queue(self) -> QueueState | None:
        """The executor's newest queue state of the group since the last call, if any."""
        woken_by, self._queue_woken_by = self._queue_woken_by, None
        newer = decoded_payload(self._queues.try_recv(), _queue_decoder, self._queue_key)
        if newer is not None:
            return newer
        return decoded_payload(woken_by, _queue_decoder, self._queue_key)

    def points(self) -> Iterator[Point]:
        """The points that arrived, in order; doorbells (empty samples) are skipped, and points
        no gateway sends (``point_fits``) ignored."""
        payload, self._woken_by = self._woken_by, None
        if payload is None:
            payload = self._points.try_recv()
        while payload is not None:
            point = decoded_payload(payload, _point_decoder, self._point_key)
            if point is not None and not point_fits(point, self._axes):
                ignored.note(self._point_key, MISFIT)
            elif point is not None:
                self._last_point = self._clock()
                self._parking.unpark()
                yield point
            payload = self._points.try_recv()
