"""The interpolator's logic without I/O: points in, numbered increment batches out, with
credit-based flow control against the executor's ring."""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable

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


class Feeder:
    def __init__(
        self,
        group: Group,
        period_ns: int,
        send: Callable[[IncrementBatch], None],
        instance: int = 0,
        start_buffer_periods: int = 0,
    ) -> None:
        self.instance = instance
        self.start_buffer_periods = start_buffer_periods
        self.hold = 0
        """Hold entries (no motion) still to send before the current segment's own: a new
        trajectory's start buffer (``Cell.start_buffer_periods``)."""
        self.trajectory_starting = False
        """A sequence-0 point was taken and its trajectory's first segment not yet."""
        self.group_index = group.index
        self.axis_map = AxisMap(group)
        self.period_ns = period_ns
        self.send = send
        self.tool = 0
        self.queue: QueueState | None = None
        self.sent = 0
        """Entries sent in the current epoch (the next batch's first_seq)."""
        self.trajectory: Trajectory | None = None
        self.trajectory_id = 0
        """The point id of the sequence-0 point behind ``trajectory``."""
        self.segment: Segment | None = None
        self.segment_point_id = 0
        self.segment_tool = 0
        self.sync: tuple[int, list[int]] | None = None
        """(sync id, groups) for the next batch, when a synchronized trajectory just began."""
        self.received_id = 0
        self.taken_id = 0
        self.points_accepted = 0
        self.increments_sent = 0
        self.waiting_for_room = False
        self.busy_episodes = 0
        """Times a segment had to wait for room in the ring (the slot stayed full)."""

    def on_status(self, status: ControllerStatus) -> None:
        """The group's selected tool, for the segments interpolated from now on."""
        tools = status.tools
        self.tool = tools[self.group_index] if self.group_index < len(tools) else 0

    def on_queue(self, state: QueueState) -> None:
        if self.queue is not None and state.epoch != self.queue.epoch:
            # The executor cleared the ring (stop, fault, not ready): this trajectory is over.
            # Dropping it also frees the pending slot, as MotoROS 1.9.10 does (motoros1 §3.3).
            if self.trajectory is not None or self.segment is not None:
                log.info("queue cleared by the executor; trajectory dropped")
            self.trajectory = None
            self.trajectory_id = 0
            self.segment = None
            self.hold = 0
            self.sync = None
            self.sent = 0
            self.taken_id = self.received_id
        self.queue = state

    def _ring_idle(self) -> bool:
        """Nothing queued or on its way: the robot is at rest."""
        queue = self.queue
        return queue is not None and queue.depth == 0 and self.sent == queue.received

    def room(self) -> int:
        queue = self.queue
        if queue is None:
            return 0
        in_flight = self.sent - queue.received
        return queue.capacity - queue.depth - in_flight

    def progress(self, points: deque[Point]) -> None:
        """Send what the ring has room for and take new points while the slot is free."""
        while self.queue is not None:
            if self.segment is not None:
                room = self.room()
                # Wait for room for a whole batch (or the rest of the segment): with a full
                # ring draining one entry a tick, sending whatever fits would mean a message
                # per entry.
                if room < min(MAX_BATCH, self.hold + self.segment.remaining):
                    if not self.waiting_for_room:
                        self.waiting_for_room = True
                        self.busy_episodes += 1
                    return
                self.waiting_for_room = False
                entries = self._next_entries(self.segment, min(room, MAX_BATCH))
                if self.hold == 0 and self.segment.remaining == 0:
                    self.segment = None
                    self.taken_id = self.segment_point_id
                self._send(entries)
                continue
            if not points:
                return
            if points[0].epoch > self.queue.epoch:
                return  # checked against a ring this interpolator has not heard of yet
            self._take(points.popleft())

    def _take(self, point: Point) -> None:
        assert self.queue is not None
        self.received_id = max(self.received_id, point.point_id)
        knot = Knot(
            time_to_ns(point.time),
            np.array(point.positions, dtype=np.float64),
            np.array(point.velocities, dtype=np.float64),
        )
        if point.sequence == 0:
            self.trajectory = Trajectory(self.axis_map, self.period_ns, knot, self._start_pulses())
            self.trajectory_id = point.point_id
            self.trajectory_starting = True
            self.sync = None
            self.taken_id = point.point_id
            self.points_accepted += 1
            return
        if self.trajectory is None:
            log.warning(
                "point %d (sequence %d) without a trajectory start; dropped",
                point.point_id,
                point.sequence,
            )
            self.taken_id = point.point_id
            return
        try:
            self.segment = self.trajectory.segment_to(knot)
        except ValueError as exc:
            log.warning("point %d dropped: %s", point.point_id, exc)
            self.taken_id = point.point_id
            return
        self.segment_point_id = point.point_id
        if self.trajectory_starting and self._ring_idle():
            # A trajectory that starts from rest: it moves after the start buffer, so every
            # later point has that much more time to arrive before the ring runs dry.
            self.hold = self.start_buffer_periods
        self.trajectory_starting = False
        # The first segment of a 2016 trajectory starts in step with its partner groups.
        self.sync = (point.sync_id, point.sync_groups) if point.sync_groups else None
        # The tool is captured when a segment is interpolated, never changed mid-segment
        # (motoros1 §2.7, SELECT_TOOL).
        self.segment_tool = self.tool
        self.points_accepted += 1

    def _next_entries(self, segment: Segment, limit: int) -> Entries:
        """Up to ``limit`` entries: hold entries first (zero increments, at the trajectory's
        start time), then the segment's own."""
        held = min(limit, self.hold)
        if held == 0:
            return segment.take(limit)
        self.hold -= held
        assert self.trajectory is not None
        hold = Entries(
            times_ns=np.full(held, self.trajectory.anchor_ns, dtype=np.int64),
            increments=np.zeros((held, self.axis_map.axes), dtype=np.int32),
            partial=np.zeros(held, dtype=np.bool_),
        )
        if held == limit:
            return hold
        rest = segment.take(limit - held)
        return Entries(
            times_ns=np.concatenate((hold.times_ns, rest.times_ns)),
            increments=np.concatenate((hold.increments, rest.increments)),
            partial=np.concatenate((hold.partial, rest.partial)),
        )

    def _start_pulses(self) -> IntArray:
        """The base of the new trajectory's increments: where the commanded position will be
        once everything already sent has been applied (exact, so no pulse is lost)."""
        assert self.queue is not None
        if self.trajectory is not None and self.sent > 0:
            return self.trajectory.pulses
        return np.array(self.queue.command_pulses[: self.axis_map.axes], dtype=np.int64)

    def _send(self, entries: Entries) -> None:
        assert self.queue is not None
        count = len(entries)
        rows = np.zeros((count, MAX_AXES), dtype="<i4")
        rows[:, : self.axis_map.axes] = entries.increments
        self.send(
            IncrementBatch(
                epoch=self.queue.epoch,
                first_seq=self.sent,
                count=count,
                increments=rows.tobytes(),
                partial=np.flatnonzero(entries.partial).tolist(),
                tool=self.segment_tool,
                times_ns=entries.times_ns.tolist(),
                sync_id=self.sync[0] if self.sync else 0,
                sync_groups=self.sync[1] if self.sync else [],
                through=self.taken_id,
            )
        )
        self.sync = None
        self.sent += count
        self.increments_sent += count

    def slot(self) -> Slot:
        epoch = self.queue.epoch if self.queue is not None else 0
        return Slot(
            self.taken_id,
            epoch,
            self.points_accepted,
            self.increments_sent,
            self.instance,
            self.trajectory_id,
        )
