"""The interpolator's logic without I/O: points in, numbered increment batches out, with
credit-based flow control against the executor's ring.

What each point, each sent segment and each cleared ring does is the row of
``states.TRANSITIONS`` for the phase the feeder is in; what the ring can take is ``RingView``;
the segment being sent is an ``OutgoingSegment``.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from motocell.services.interpolator.core.states import TRANSITIONS, Action, FeederEvent, Phase
from motocell.shared.bus.schemas import ControllerStatus, IncrementBatch, Point, QueueState, Slot
from motocell.shared.config import Group
from motocell.shared.motion.interpolation import Entries, Knot, Segment, Trajectory, time_to_ns
from motocell.shared.motion.kinematics import AxisMap, IntArray
from motocell.shared.protocol.constants import MAX_AXES

log = logging.getLogger("interpolator")

MAX_BATCH = 50
"""Entries per message: 200 ms of motion at 4 ms, about 1.7 kB."""


class ImpossibleEventError(RuntimeError):
    """An event its phase cannot have (``Action.IMPOSSIBLE``): a bug in the feeder."""


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


@dataclass(frozen=True)
class TakenPoint:
    """A point the feeder took, with the knot it is to the trajectory."""

    point: Point
    knot: Knot

    @classmethod
    def of(cls, point: Point) -> TakenPoint:
        return cls(
            point,
            Knot(
                time_to_ns(point.time),
                np.array(point.positions, dtype=np.float64),
                np.array(point.velocities, dtype=np.float64),
            ),
        )


@dataclass
class OutgoingSegment:
    """The segment being sent, to the ring as far as it has room."""

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
        self.outgoing: OutgoingSegment | None = None
        self.tool = 0
        self.received_id = 0
        self.taken_id = 0
        self.counts = Counts()

    @property
    def segment(self) -> Segment | None:
        return None if self.outgoing is None else self.outgoing.segment

    @property
    def sent(self) -> int:
        """Entries sent in the current epoch (the next batch's first_seq)."""
        return self.ring.sent

    def on_status(self, status: ControllerStatus) -> None:
        """The group's selected tool, for the segments interpolated from now on."""
        tools = status.tools
        self.tool = tools[self.group_index] if self.group_index < len(tools) else 0

    def on_queue(self, state: QueueState) -> None:
        queue = self.ring.queue
        if queue is not None and state.epoch != queue.epoch:
            self.ring.sent = 0  # a new epoch's ring starts empty
            self._on(FeederEvent.RING_CLEARED)
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
        if self.phase is Phase.SENDING:
            return True
        return bool(points) and points[0].epoch > queue.epoch

    def progress(self, points: deque[Point]) -> None:
        """Send what the ring has room for and, between segments, take new points."""
        while (queue := self.ring.queue) is not None:
            if self.phase is Phase.SENDING:
                outgoing = self.outgoing
                assert outgoing is not None
                if not self._send_some(outgoing):
                    return
            elif points and points[0].epoch <= queue.epoch:
                self.take(points.popleft())
            else:
                return  # no point, or one checked against a ring not heard of yet

    def take(self, point: Point) -> None:
        """Take ``point`` (``progress`` hands them over between segments): what it is to the
        trajectory is its event."""
        self.received_id = max(self.received_id, point.point_id)
        taken = TakenPoint.of(point)
        self._on(self._event_of(taken), taken)

    def _event_of(self, taken: TakenPoint) -> FeederEvent:
        if taken.point.sequence == 0:
            return FeederEvent.FIRST_POINT
        trajectory = self.trajectory
        if trajectory is not None and not trajectory.reaches(taken.knot):
            return FeederEvent.UNREACHABLE_POINT
        return FeederEvent.NEXT_POINT

    def _on(self, event: FeederEvent, taken: TakenPoint | None = None) -> None:
        """Do what ``event``'s row says for the phase the feeder is in, then enter the row's
        next phase."""
        row = TRANSITIONS[(self.phase, event)]
        match row.action:
            case Action.START_TRAJECTORY if taken is not None:
                self._start_trajectory(taken)
            case Action.SEND_FIRST_SEGMENT if taken is not None:
                hold = self.start_buffer_periods if self.ring.idle() else 0
                self._start_segment(taken, hold)
            case Action.SEND_NEXT_SEGMENT if taken is not None:
                self._start_segment(taken, hold=0)
            case Action.DROP_ORPHAN if taken is not None:
                log.warning(
                    "point %d (sequence %d) without a trajectory start; dropped",
                    taken.point.point_id,
                    taken.point.sequence,
                )
                self.taken_id = taken.point.point_id
            case Action.DROP_UNREACHABLE if taken is not None:
                log.warning(
                    "point %d dropped: its time is not after the previous point's",
                    taken.point.point_id,
                )
                self.taken_id = taken.point.point_id
            case Action.SEGMENT_DONE if self.outgoing is not None:
                self.taken_id = self.outgoing.point_id
                self.outgoing = None
            case Action.END_TRAJECTORY:
                log.info("queue cleared by the executor; trajectory dropped")
                self.trajectory = None
                self.trajectory_id = 0
                self.outgoing = None
                self.taken_id = self.received_id
            case Action.TAKE_ALL:
                self.taken_id = self.received_id
            case _:
                raise ImpossibleEventError(
                    f"{event.name} while {self.phase.name}: {row.action.name}"
                )
        self.phase = row.next_phase

    def _start_trajectory(self, taken: TakenPoint) -> None:
        self.trajectory = Trajectory(
            self.axis_map, self.period_ns, taken.knot, self._start_pulses()
        )
        self.trajectory_id = self.taken_id = taken.point.point_id
        self.counts.points_accepted += 1

    def _start_segment(self, taken: TakenPoint, hold: int) -> None:
        assert self.trajectory is not None
        point = taken.point
        self.outgoing = OutgoingSegment(
            self.trajectory.segment_to(taken.knot),
            point.point_id,
            tool=self.tool,
            hold=hold,
            # The first segment of a 2016 trajectory starts in step with its partner groups.
            sync=(point.sync_id, point.sync_groups) if point.sync_groups else None,
        )
        self.counts.points_accepted += 1

    def _send_some(self, outgoing: OutgoingSegment) -> bool:
        """Send as much of ``outgoing`` as the ring has room for; False while it waits for room.
        It waits for room for a whole batch (or the rest of the segment): with a full ring
        draining one entry a tick, sending whatever fits would mean a message per entry."""
        room = self.ring.room()
        if room < min(MAX_BATCH, outgoing.remaining):
            if not self.counts.waiting_for_room:
                self.counts.waiting_for_room = True
                self.counts.busy_episodes += 1
            return False
        self.counts.waiting_for_room = False
        entries = self._next_entries(outgoing, min(room, MAX_BATCH))
        if outgoing.remaining == 0:
            self._on(FeederEvent.SEGMENT_SENT)
        self._send(entries, outgoing)
        return True

    def _next_entries(self, outgoing: OutgoingSegment, limit: int) -> Entries:
        """Up to ``limit`` entries: hold entries first (zero increments, at the trajectory's
        start time), then the segment's own."""
        held = min(limit, outgoing.hold)
        if held == 0:
            return outgoing.segment.take(limit)
        outgoing.hold -= held
        assert self.trajectory is not None
        hold = Entries(
            times_ns=np.full(held, self.trajectory.anchor_ns, dtype=np.int64),
            increments=np.zeros((held, self.axis_map.axes), dtype=np.int32),
            partial=np.zeros(held, dtype=np.bool_),
        )
        if held == limit:
            return hold
        rest = outgoing.segment.take(limit - held)
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

    def _send(self, entries: Entries, outgoing: OutgoingSegment) -> None:
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
                tool=outgoing.tool,
                times_ns=entries.times_ns.tolist(),
                sync_id=outgoing.sync[0] if outgoing.sync else 0,
                sync_groups=outgoing.sync[1] if outgoing.sync else [],
                through=self.taken_id,
            )
        )
        outgoing.sync = None
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
