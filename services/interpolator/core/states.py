"""Where a group's trajectory stands, as one table: for every phase and event, the phase that
follows and what the feeder does (``TRANSITIONS``). ``Feeder`` looks each event up here and does
the row's action; it decides nothing on its own. Pure.

A point is taken only between segments (the slot stays full while a segment is being sent,
so the gateway answers BUSY), and a segment is sent only while SENDING: the rows where a point
meets a segment being sent, or a sent segment meets none, are ``Action.IMPOSSIBLE``.
"""

from __future__ import annotations

from enum import Enum
from typing import NamedTuple


class Phase(Enum):
    IDLE = "no trajectory"
    """Nothing started, or the executor cleared the ring: a point continuing a trajectory is
    dropped."""
    STARTED = "a trajectory's first point taken, none of its segments yet"
    """Its first segment gets the start buffer if the ring is at rest."""
    SENDING = "a segment's entries going to the ring, as far as it has room"
    BETWEEN = "between segments: the trajectory waits for its next point"


class FeederEvent(Enum):
    FIRST_POINT = "a sequence-0 point"
    NEXT_POINT = "a point with sequence > 0"
    UNREACHABLE_POINT = "a point with sequence > 0 that no segment reaches"
    """Its time is not after the trajectory's last point: it cannot be interpolated."""
    SEGMENT_SENT = "the segment's last entry sent"
    RING_CLEARED = "the executor cleared the ring (a new epoch)"


class Action(Enum):
    START_TRAJECTORY = "start a trajectory at the point, replacing any other; the point is taken"
    SEND_FIRST_SEGMENT = "send the segment to the point, after the start buffer if at rest"
    """A trajectory that starts from rest moves after the start buffer
    (``Cell.start_buffer_periods``), so every later point has that much more time to arrive
    before the ring runs dry; one chained onto queued motion is not held."""
    SEND_NEXT_SEGMENT = "send the segment to the point"
    DROP_ORPHAN = "drop the point, which has no trajectory to extend; it counts as taken"
    DROP_UNREACHABLE = "drop the point, which no segment reaches; it counts as taken"
    """The trajectory is kept: the next point that reaches it goes on from its last point."""
    SEGMENT_DONE = "the segment is all in the ring: its point is taken"
    END_TRAJECTORY = "drop the trajectory and what is left of its segment; all points taken"
    """STOP_MOTION, a fault, not ready: the trajectory is over, and dropping it also frees the
    pending slot, as MotoROS 1.9.10 does (motoros1 §3.3)."""
    TAKE_ALL = "every point received counts as taken"
    IMPOSSIBLE = "cannot happen: raised as a bug"


class Row(NamedTuple):
    next_phase: Phase
    action: Action


_IDLE, _STARTED, _SENDING, _BETWEEN = Phase.IDLE, Phase.STARTED, Phase.SENDING, Phase.BETWEEN
_FIRST, _NEXT, _UNREACHABLE = (
    FeederEvent.FIRST_POINT,
    FeederEvent.NEXT_POINT,
    FeederEvent.UNREACHABLE_POINT,
)
_SENT, _CLEARED = FeederEvent.SEGMENT_SENT, FeederEvent.RING_CLEARED

TRANSITIONS: dict[tuple[Phase, FeederEvent], Row] = {
    (_IDLE, _FIRST): Row(_STARTED, Action.START_TRAJECTORY),
    (_IDLE, _NEXT): Row(_IDLE, Action.DROP_ORPHAN),
    # Without a trajectory there is no last point for a point to be behind.
    (_IDLE, _UNREACHABLE): Row(_IDLE, Action.IMPOSSIBLE),
    (_IDLE, _SENT): Row(_IDLE, Action.IMPOSSIBLE),
    (_IDLE, _CLEARED): Row(_IDLE, Action.TAKE_ALL),
    # A new start replaces one that never moved.
    (_STARTED, _FIRST): Row(_STARTED, Action.START_TRAJECTORY),
    (_STARTED, _NEXT): Row(_SENDING, Action.SEND_FIRST_SEGMENT),
    (_STARTED, _UNREACHABLE): Row(_STARTED, Action.DROP_UNREACHABLE),
    (_STARTED, _SENT): Row(_STARTED, Action.IMPOSSIBLE),
    (_STARTED, _CLEARED): Row(_IDLE, Action.END_TRAJECTORY),
    (_SENDING, _FIRST): Row(_SENDING, Action.IMPOSSIBLE),
    (_SENDING, _NEXT): Row(_SENDING, Action.IMPOSSIBLE),
    (_SENDING, _UNREACHABLE): Row(_SENDING, Action.IMPOSSIBLE),
    (_SENDING, _SENT): Row(_BETWEEN, Action.SEGMENT_DONE),
    (_SENDING, _CLEARED): Row(_IDLE, Action.END_TRAJECTORY),
    (_BETWEEN, _FIRST): Row(_STARTED, Action.START_TRAJECTORY),
    (_BETWEEN, _NEXT): Row(_SENDING, Action.SEND_NEXT_SEGMENT),
    (_BETWEEN, _UNREACHABLE): Row(_BETWEEN, Action.DROP_UNREACHABLE),
    (_BETWEEN, _SENT): Row(_BETWEEN, Action.IMPOSSIBLE),
    (_BETWEEN, _CLEARED): Row(_IDLE, Action.END_TRAJECTORY),
}
