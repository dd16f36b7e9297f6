"""What reaches the executor, as its clock thread reads it: ``InputPort`` over the ``Bus``.

While the clock runs, the thread drains everything at the start of each tick: increment
batches, points and the controller token's events wait in Zenoh's own channels, so no Python
runs on Zenoh's threads for them. A Python callback holding the GIL on an ordinary thread would
make the real-time clock thread wait for it (up to the interpreter's 5 ms switch interval); a
batch per tick per group would do that often.

While the clock rests it waits for the point channel: every trajectory starts with a point the
gateway publishes (and the executor counts), before any of its increments exist. It waits
parked (``shared.bus.channels.Parking``): a callback on the point key, declared for the rest
only, tells a pipe the thread polls, since the channel's own ``recv()`` would wake it 10 times
a second for nothing.
Two rarer inputs must wake it too: a controller status whose readiness is not the executor's
own (the gateway waits for the executor's ``ready`` after START_TRAJ_MODE; a controller back
after a router restart says ready unchanged, but the executor lost it meanwhile), and
STOP_MOTION's query. They arrive in callbacks that only append to a queue and, while the clock
rests, ring the point channel's doorbell (an empty sample that never leaves this session). The
status callback is tiny and runs ten times a second at most while anything moves. A ``Waker``
rings the same doorbell at the deadline the resting clock sets, and at stop.

Once, at start, before the core exists: where the robot was (``remembered_positions``).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Iterator

import msgspec

from motocell.services.executor.bus import Bus, Query, Sample
from motocell.services.executor.controller_token import ControllerToken
from motocell.shared.bus import ignored
from motocell.shared.bus.channels import Parking, StopSignal, Waker
from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.keys import CellKeys, group_of
from motocell.shared.bus.liveness import QUERY_TIMEOUT_S
from motocell.shared.bus.schemas import (
    CommandReply,
    ControllerStatus,
    Decoder,
    IncrementBatch,
    Point,
)

CHANNEL_DEPTH = 10_000
"""Zenoh-side queue per key, and the bound of the callbacks' queues. A full channel would stall
Zenoh's network thread; four groups at 250 Hz never come near it, since every tick drains them
all."""

_status = Decoder(ControllerStatus)
_batch = Decoder(IncrementBatch)
_point = Decoder(Point)


NO_GROUP = "point for no group of this cell"
"""What a point on ``group/*/point`` whose group chunk is no group of the cell is noted as."""


class Inputs:
    def __init__(self, bus: Bus, keys: CellKeys, groups: int, stop: StopSignal) -> None:
        self._bus = bus
        self._keys = keys
        self._groups = groups
        self._points = bus.channel(keys.group_point_all, CHANNEL_DEPTH)
        self._batches = [
            bus.channel(keys.group_increments(g), CHANNEL_DEPTH) for g in range(groups)
        ]
        self._statuses: deque[tuple[int, ControllerStatus]] = deque(maxlen=CHANNEL_DEPTH)
        self._stops: deque[Query] = deque(maxlen=CHANNEL_DEPTH)
        self._status_sub = bus.subscribe(keys.controller_status, self._on_status)
        self._stop_queries = bus.queryable(keys.executor_cmd("stop"), self._on_stop)
        self.controller = ControllerToken(bus, keys.alive("controller", "0"))
        self._doorbell = bus.doorbell(keys.group_point(0))
        self._parking = Parking(
            lambda on_sample: bus.subscribe(keys.group_point_all, on_sample), stop
        )
        self._waker = Waker(self._doorbell.ring, stop, "executor-waker")
        self._resting = False
        self.executor_ready = False
        """What the clock thread last made of readiness; a status saying otherwise wakes it."""
        self._woken_by: Sample | None = None

    def start(self) -> None:
        self._waker.start()

    def close(self) -> None:
        """Once stopped: the waker ends with the stop flag."""
        self._waker.close()
        self._doorbell.close()
        self._parking.close()

    def remembered_positions(self) -> CommandReply | None:
        """The broadcaster's answer to ``positions``: the commanded pulses of the newest tick
        it had, which a restarted executor resumes from (``core.start.starting_pulses``). None
        when nobody answered."""
        return self._bus.call(self._keys.broadcaster_cmd("positions"), QUERY_TIMEOUT_S)

    def _on_status(self, sample: Sample) -> None:
        status = decoded_payload(sample.payload.to_bytes(), _status, self._keys.controller_status)
        if status is None:
            return
        self._statuses.append((time.monotonic_ns(), status))
        if self._resting and status.motion_ready != self.executor_ready:
            self._doorbell.ring()

    def _on_stop(self, query: Query) -> None:
        self._stops.append(query)
        if self._resting:
            self._doorbell.ring()

    def rest(self, deadline_s: float) -> None:
        """Block until a point arrives, a status changes what may move, STOP_MOTION is asked,
        ``deadline_s`` (CLOCK_MONOTONIC) passes, or the service stops."""
        self._resting = True
        try:
            if self._statuses or self._stops:
                return  # arrived before the flag was up
            self._waker.wake_at(deadline_s)
            self._woken_by = self._parking.park_and_wait(self._points.try_recv)
        finally:
            self._resting = False

    def awake(self) -> None:
        """The clock runs again: no Python on Zenoh's threads for points while it does."""
        self._parking.unpark()

    def statuses(self) -> Iterator[tuple[int, ControllerStatus]]:
        """Every status since the last call, in order, with when it arrived."""
        while self._statuses:
            yield self._statuses.popleft()

    def points(self) -> Iterator[tuple[int, Point]]:
        """The points the gateway published since the last call, with their group. One that
        does not decode, or is on a key of no group of this cell (``group/*/point``,
        ``group/7/point`` in a cell of two), is not owed either: no interpolator takes it."""
        sample, self._woken_by = self._woken_by, None
        if sample is None:
            sample = self._points.try_recv()
        while sample is not None:
            key = str(sample.key_expr)
            point = decoded_payload(sample.payload.to_bytes(), _point, key)
            if point is not None:  # None too for the doorbell (empty)
                group = group_of(key, self._groups)
                if group is None:
                    ignored.note(key, NO_GROUP)
                else:
                    yield group, point
            sample = self._points.try_recv()

    def batches(self, group: int) -> Iterator[IncrementBatch | None]:
        """``group``'s batches since the last call; None for one that does not decode."""
        channel = self._batches[group]
        while (sample := channel.try_recv()) is not None:
            try:
                yield _batch.decode(sample.payload.to_bytes())
            except msgspec.DecodeError:
                yield None

    def stop_queries(self) -> Iterator[Query]:
        while self._stops:
            yield self._stops.popleft()
