"""The gateway's state table: where each group's trajectory stands, as the gateway follows it
to answer the group's points (motoros1 §2.4).

A trajectory begins with a sequence-0 point the gateway takes; a later point may continue it
only while it runs. It ends on STOP_MOTION, when motion-ready dropped since it began (the
controller cleared the queue, motoros1 §3.3), or when the group's interpolator no longer runs
it (its ring was cleared); the client then begins again with a sequence 0.

``TRANSITIONS`` is every (state, event) pair; ``GroupTrajectory.on`` consults it.
"""

from __future__ import annotations

from enum import Enum

from motocell.services.gateway.core.points import Verdict, invalid
from motocell.shared.protocol.constants import InvalidSubcode


class TrajectoryState(Enum):
    NONE = "no trajectory: the next point must be a sequence 0"
    RUNNING = "begun by a sequence-0 point the gateway took"


class TrajectoryEvent(Enum):
    STARTED = "a sequence-0 point taken"
    LATER_POINT = "a point after sequence 0 arrives, before its data checks"
    READINESS_DROPPED = "motion-ready dropped since the trajectory began"
    DROPPED_BY_INTERPOLATOR = "the interpolator took its first point and no longer runs it"
    STOPPED = "STOP_MOTION, asked by the client or on its disconnection"


Row = tuple[TrajectoryState, Verdict | None]
"""The state after the event, and the refusal the point is answered with (None: none)."""

OUT_OF_SEQUENCE: Verdict = invalid(InvalidSubcode.SEQUENCE)

NONE, RUNNING = TrajectoryState.NONE, TrajectoryState.RUNNING

TRANSITIONS: dict[tuple[TrajectoryState, TrajectoryEvent], Row] = {
    (NONE, TrajectoryEvent.STARTED): (RUNNING, None),
    # A sequence 0 begins a new trajectory whatever ran before.
    (RUNNING, TrajectoryEvent.STARTED): (RUNNING, None),
    # MotoROS would interpolate from a stale state after a stop; a trajectory must (re)start
    # with sequence 0 (incremental-motion §2.5: after a stop the client plans a new trajectory
    # from the robot's current position).
    (NONE, TrajectoryEvent.LATER_POINT): (NONE, OUT_OF_SEQUENCE),
    (RUNNING, TrajectoryEvent.LATER_POINT): (RUNNING, None),
    (NONE, TrajectoryEvent.READINESS_DROPPED): (NONE, None),
    (RUNNING, TrajectoryEvent.READINESS_DROPPED): (NONE, None),
    (NONE, TrajectoryEvent.DROPPED_BY_INTERPOLATOR): (NONE, None),
    (RUNNING, TrajectoryEvent.DROPPED_BY_INTERPOLATOR): (NONE, None),
    (NONE, TrajectoryEvent.STOPPED): (NONE, None),
    (RUNNING, TrajectoryEvent.STOPPED): (NONE, None),
}
