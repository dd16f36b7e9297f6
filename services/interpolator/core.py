"""The interpolator's logic without I/O: points in, numbered increment batches out, with
credit-based flow control against the executor's ring.

Where a trajectory stands is the state machine ``TRANSITIONS`` (one row per phase and event);
what the ring can take is ``RingView``; the segment being sent is a ``Work``.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np

from motocell.shared.bus.schemas import ControllerStatus, IncrementBatch, Point, QueueState, Slot
from motocell.shared.config import Group
from motocell.shared.motion.interpolation import Entries, Knot, Segment, Trajectory, time_to_ns
from motocell.shared.motion.kinematics import AxisMap, IntArray
from motocell.shared.protocol.constants import MAX_AXES

log = logging.getLogger("interpolator")

MAX_BATCH = 50
"""Entries per message: 200 ms of motion at 4 ms, about 1.7 kB."""


def queue_point(points: deque[Point], point: Point, limit: int) -> bool:
    """Keep ``point`` for the feeder; False (dropped) when ``limit`` points already wait. The
    gateway lets no more be outstanding (``Cell.points_outstanding``) but for type-14
    sequence-0 points, which never get BUSY (motoros1 §2.4): only a client sending several in a
    row while a segment waits for room reaches the limit."""
    if len(points) >= limit:
        log.error("more than %d points pending; dropping %s", len(points), point)
        return False
    points.append(point)
    return True


class Phase(Enum):
    IDLE = "no trajectory"
    """Nothing started, or the executor cleared the ring: a point continuing a trajectory is
    dropped."""
    STARTED = "a trajectory's first point taken, none of its segments yet"
    """Its first segment gets the start buffer if the ring is at rest."""
    SENDING = "a segment's entries going to the ring, as far as it has room"
    BETWEEN = "between segments: the trajectory waits for its next point"


class Event(Enum):
    FIRST_POINT = "a sequence-0 point"
    NEXT_POINT = "a point with sequence > 0"
    SEGMENT_SENT = "the segment's last entry sent"
    RING_CLEARED = "the executor cleared the ring (a new epoch)"


TRANSITIONS: dict[tuple[Phase, Event], Phase] = {
    (Phase.IDLE, Event.FIRST_POINT): Phase.STARTED,
    # Nothing to extend: the point is dropped (and taken, so the slot frees).
    (Phase.IDLE, Event.NEXT_POINT): Phase.IDLE,
    (Phase.IDLE, Event.RING_CLEARED): Phase.IDLE,
    # A new start replaces one that never moved.
    (Phase.STARTED, Event.FIRST_POINT): Phase.STARTED,
    (Phase.STARTED, Event.NEXT_POINT): Phase.SENDING,
    (Phase.STARTED, Event.RING_CLEARED): Phase.IDLE,
    (Phase.SENDING, Event.SEGMENT_SENT): Phase.BETWEEN,
    # STOP_MOTION, a fault, not ready: the trajectory is over (motoros1 §3.3).
    (Phase.SENDING, Event.RING_CLEARED): Phase.IDLE,
    (Phase.BETWEEN, Event.FIRST_POINT): Phase.STARTED,
    (Phase.BETWEEN, Event.NEXT_POINT): Phase.SENDING,
    (Phase.BETWEEN, Event.RING_CLEARED): Phase.IDLE,
}
"""Points are taken only when no segment is being sent, so SENDING takes no point."""


@dataclass
class RingView:
    """The executor's ring as this interpolator knows it: the newest queue state, and how many
    entries were sent in its epoch (some may still be on their way)."""

    queue: QueueState | None = None
    sent: int = 0

    def room(self) -> int:
        if self.queue is None:
            return 0
        in_flight = self.sent - self.queue.received
        return self.queue.capacity - self.queue.depth - in_flight

    def idle(self) -> bool:
        """Nothing queued or on its way: the robot is at rest."""
        queue = self.queue
        return queue is not None and queue.depth == 0 and self.sent == queue.received


@dataclass
class Work:
    """The segment being sent."""

    segment: Segment
    point_id: int
    tool: int
    """Captured when the segment was interpolated, never changed mid-segment (motoros1 §2.7,
    SELECT_TOOL)."""
    hold: int
    """Hold entries (no motion) still to send before the segment's own: a new trajectory's
    start buffer (``Cell.start_buffer_periods``)."""
    sync: tuple[int, list[int]] | None
    """(sync id, groups) for the next batch, on the first segment of a 2016 trajectory."""

    @property
    def remaining(self) -> int:
        return self.hold + self.segment.remaining


@dataclass
class Counts:
    """What the metrics report."""

    points_accepted: int = 0
    increments_sent: int = 0
    busy_episodes: int = 0
    """Times a segment had to wait for room in the ring (the slot stayed full)."""
    waiting_for_room: bool = False


class Feeder:
    def __init__(
        self,
        group: Group,
        period_ns: int,
        send: Callable[[IncrementBatch], None],
        instance: int = 0,
        start_buffer_periods: int = 0,
    ) -> None:
        self.group_index = group.index
        self.axis_map = AxisMap(group)
        self.period_ns = period_ns
        self.send = send
        self.instance = instance
        self.start_buffer_periods = start_buffer_periods
        self.phase = Phase.IDLE
        self.ring = RingView()
        self.trajectory: Trajectory | None = None
        self.trajectory_id = 0
        """The point id of the sequence-0 point behind ``trajectory``."""
        self.work: Work | None = None
        self.tool = 0
        self.received_id = 0
        self.taken_id = 0
        self.counts = Counts()

    @property
    def segment(self) -> Segment | None:
        return None if self.work is None else self.work.segment

    @property
    def sent(self) -> int:
        """Entries sent in the current epoch (the next batch's first_seq)."""
        return self.ring.sent

    def _on(self, event: Event) -> None:
        self.phase = TRANSITIONS[(self.phase, event)]

    def on_status(self, status: ControllerStatus) -> None:
        """The group's selected tool, for the segments interpolated from now on."""
        tools = status.tools
        self.tool = tools[self.group_index] if self.group_index < len(tools) else 0

    def on_queue(self, state: QueueState) -> None:
        queue = self.ring.queue
        if queue is not None and state.epoch != queue.epoch:
            # The executor cleared the ring (stop, fault, not ready): this trajectory is over.
            # Dropping it also frees the pending slot, as MotoROS 1.9.10 does (motoros1 §3.3).
            if self.phase is not Phase.IDLE:
                log.info("queue cleared by the executor; trajectory dropped")
            self.trajectory = None
            self.trajectory_id = 0
            self.work = None
            self.ring.sent = 0
            self.taken_id = self.received_id
            self._on(Event.RING_CLEARED)
        self.ring.queue = state

    def room(self) -> int:
        return self.ring.room()

    def waits_for_ring(self, points: deque[Point]) -> bool:
        """Whether only the executor's next queue state can let the feeder go on: a segment
        short of room, a point checked against a ring this interpolator has not heard of yet,
        or points before the first queue state. Otherwise the next point can."""
        queue = self.ring.queue
        if queue is None:
            return bool(points)
        if self.work is not None:
            return True
        return bool(points) and points[0].epoch > queue.epoch

    def progress(self, points: deque[Point]) -> None:
        """Send what the ring has room for and take new points while the slot is free."""
        while self.ring.queue is not None:
            if self.work is not None:
                if not self._send_some(self.work):
                    return
                continue
            if not points:
                return
            if points[0].epoch > self.ring.queue.epoch:
                return  # checked against a ring this interpolator has not heard of yet
            self._take(points.popleft())

    def _send_some(self, work: Work) -> bool:
        """Send as much of ``work`` as the ring has room for; False while it waits for room.
        It waits for room for a whole batch (or the rest of the segment): with a full ring
        draining one entry a tick, sending whatever fits would mean a message per entry."""
        room = self.ring.room()
        if room < min(MAX_BATCH, work.remaining):
            if not self.counts.waiting_for_room:
                self.counts.waiting_for_room = True
                self.counts.busy_episodes += 1
            return False
        self.counts.waiting_for_room = False
        entries = self._next_entries(work, min(room, MAX_BATCH))
        if work.remaining == 0:
            self.work = None
            self.taken_id = work.point_id
            self._on(Event.SEGMENT_SENT)
        self._send(entries, work)
        return True

    def _take(self, point: Point) -> None:
        assert self.ring.queue is not None
        self.received_id = max(self.received_id, point.point_id)
        knot = Knot(
            time_to_ns(point.time),
            np.array(point.positions, dtype=np.float64),
            np.array(point.velocities, dtype=np.float64),
        )
        if point.sequence == 0:
            self.trajectory = Trajectory(self.axis_map, self.period_ns, knot, self._start_pulses())
            self.trajectory_id = self.taken_id = point.point_id
            self.counts.points_accepted += 1
            self._on(Event.FIRST_POINT)
            return
        if self.trajectory is None:
            log.warning(
                "point %d (sequence %d) without a trajectory start; dropped",
                point.point_id,
                point.sequence,
            )
            self.taken_id = point.point_id
            self._on(Event.NEXT_POINT)
            return
        try:
            segment = self.trajectory.segment_to(knot)
        except ValueError as exc:
            log.warning("point %d dropped: %s", point.point_id, exc)
            self.taken_id = point.point_id
            return
        # A trajectory that starts from rest moves after the start buffer, so every later
        # point has that much more time to arrive before the ring runs dry.
        starting = self.phase is Phase.STARTED and self.ring.idle()
        self.work = Work(
            segment,
            point.point_id,
            tool=self.tool,
            hold=self.start_buffer_periods if starting else 0,
            # The first segment of a 2016 trajectory starts in step with its partner groups.
            sync=(point.sync_id, point.sync_groups) if point.sync_groups else None,
        )
        self.counts.points_accepted += 1
        self._on(Event.NEXT_POINT)

    def _next_entries(self, work: Work, limit: int) -> Entries:
        """Up to ``limit`` entries: hold entries first (zero increments, at the trajectory's
        start time), then the segment's own."""
        held = min(limit, work.hold)
        if held == 0:
            return work.segment.take(limit)
        work.hold -= held
        assert self.trajectory is not None
        hold = Entries(
            times_ns=np.full(held, self.trajectory.anchor_ns, dtype=np.int64),
            increments=np.zeros((held, self.axis_map.axes), dtype=np.int32),
            partial=np.zeros(held, dtype=np.bool_),
        )
        if held == limit:
            return hold
        rest = work.segment.take(limit - held)
        return Entries(
            times_ns=np.concatenate((hold.times_ns, rest.times_ns)),
            increments=np.concatenate((hold.increments, rest.increments)),
            partial=np.concatenate((hold.partial, rest.partial)),
        )

    def _start_pulses(self) -> IntArray:
        """The base of the new trajectory's increments: where the commanded position will be
        once everything already sent has been applied (exact, so no pulse is lost)."""
        assert self.ring.queue is not None
        if self.trajectory is not None and self.ring.sent > 0:
            return self.trajectory.pulses
        return np.array(self.ring.queue.command_pulses[: self.axis_map.axes], dtype=np.int64)

    def _send(self, entries: Entries, work: Work) -> None:
        assert self.ring.queue is not None
        count = len(entries)
        rows = np.zeros((count, MAX_AXES), dtype="<i4")
        rows[:, : self.axis_map.axes] = entries.increments
        self.send(
            IncrementBatch(
                epoch=self.ring.queue.epoch,
                first_seq=self.ring.sent,
                count=count,
                increments=rows.tobytes(),
                partial=np.flatnonzero(entries.partial).tolist(),
                tool=work.tool,
                times_ns=entries.times_ns.tolist(),
                sync_id=work.sync[0] if work.sync else 0,
                sync_groups=work.sync[1] if work.sync else [],
                through=self.taken_id,
            )
        )
        work.sync = None
        self.ring.sent += count
        self.counts.increments_sent += count

    def slot(self) -> Slot:
        epoch = self.ring.queue.epoch if self.ring.queue is not None else 0
        return Slot(
            self.taken_id,
            epoch,
            self.counts.points_accepted,
            self.counts.increments_sent,
            self.instance,
            self.trajectory_id,
        )
