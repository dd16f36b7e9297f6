"""Whether the executor lets anything move: a state machine fed by the controller's statuses, its
liveliness token and the clock's stall checks. Pure.

Its states and every transition are the one table ``TRANSITIONS`` (one row per state and event),
so the stall rules of docs/behaviour.md ("Stalls") that concern readiness read as rows:

- a tick later than the lateness bound, or a controller unheard for ``SILENT_HEARTBEATS``, while
  anything may be queued (READY) stops motion: the rings are cleared and the controller is told
  (the stall notice), which raises alarm 4200;
- after a stall, statuses are old news until one shows the stall's alarm: a ready one was sent
  before the controller had the notice, and a not-ready one may be for another reason (services
  it lost sight of while the router was down); meanwhile the notice is repeated once a second,
  and at once when a ready status arrives, in case the router lost it;
- a status counts only from a controller whose token is present: a dead controller's last
  status can still be on its way after its token's DELETE.
"""

from __future__ import annotations

from enum import Enum


class Readiness(Enum):
    ABSENT = "no controller"
    """Its liveliness token is not present (or not yet known)."""
    WAITING = "not ready"
    """The controller is there; its last status was not motion-ready."""
    READY = "ready"
    """Increments are taken and applied."""
    STALLED = "stopped for a stall"
    """Until a status shows the stall's alarm: the controller had the notice."""


class Event(Enum):
    READY_STATUS = "a motion-ready status"
    NOT_READY_STATUS = "a not-ready status"
    ALARM_STATUS = "a status showing the stall's alarm (never motion-ready)"
    CONTROLLER_GONE = "the controller's token deleted"
    CONTROLLER_BACK = "the controller's token present"
    STALL = "a stall: a tick past the lateness bound, or a silent controller"
    NOTICE_DUE = "a second since the last stall notice"


class Action(Enum):
    CLEAR_RINGS = "clear every ring"
    NOTICE = "tell the controller about the stall"


Row = tuple[Readiness, frozenset[Action]]

_NOTHING: frozenset[Action] = frozenset()
_CLEAR = frozenset({Action.CLEAR_RINGS})
_NOTICE = frozenset({Action.NOTICE})
_STOP = frozenset({Action.CLEAR_RINGS, Action.NOTICE})

A, W, R, S = Readiness.ABSENT, Readiness.WAITING, Readiness.READY, Readiness.STALLED
E = Event

TRANSITIONS: dict[tuple[Readiness, Event], Row] = {
    # A status without its controller's token may be the last of a dead controller.
    (A, E.READY_STATUS): (A, _NOTHING),
    (A, E.NOT_READY_STATUS): (A, _NOTHING),
    (A, E.ALARM_STATUS): (A, _NOTHING),
    (A, E.CONTROLLER_GONE): (A, _NOTHING),
    # Back (or first seen): its next status decides.
    (A, E.CONTROLLER_BACK): (W, _NOTHING),
    # Nothing is queued while not ready: a late tick stops nothing.
    (A, E.STALL): (A, _NOTHING),
    (A, E.NOTICE_DUE): (A, _NOTHING),
    (W, E.READY_STATUS): (R, _NOTHING),
    (W, E.NOT_READY_STATUS): (W, _NOTHING),
    (W, E.ALARM_STATUS): (W, _NOTHING),
    (W, E.CONTROLLER_GONE): (A, _NOTHING),
    (W, E.CONTROLLER_BACK): (W, _NOTHING),
    (W, E.STALL): (W, _NOTHING),
    (W, E.NOTICE_DUE): (W, _NOTHING),
    (R, E.READY_STATUS): (R, _NOTHING),
    # Motion-ready dropped (motoros1 §3.3: the queue is cleared).
    (R, E.NOT_READY_STATUS): (W, _CLEAR),
    (R, E.ALARM_STATUS): (W, _CLEAR),
    (R, E.CONTROLLER_GONE): (A, _CLEAR),
    (R, E.CONTROLLER_BACK): (R, _NOTHING),
    (R, E.STALL): (S, _STOP),
    (R, E.NOTICE_DUE): (R, _NOTHING),
    # Sent before the controller had the notice: old news, and the notice may have been lost.
    (S, E.READY_STATUS): (S, _NOTICE),
    # Not ready for another reason: the notice may not have reached the controller yet.
    (S, E.NOT_READY_STATUS): (S, _NOTHING),
    # The alarm's status: the controller knows; START_TRAJ_MODE makes it ready again.
    (S, E.ALARM_STATUS): (W, _NOTHING),
    # The stall holds whatever the token does (a router stall deletes tokens too): only the
    # controller's alarm ends it.
    (S, E.CONTROLLER_GONE): (S, _NOTHING),
    (S, E.CONTROLLER_BACK): (S, _NOTHING),
    (S, E.STALL): (S, _NOTHING),
    (S, E.NOTICE_DUE): (S, _NOTICE),
}


class ReadinessMachine:
    """The current state and the transition that ``TRANSITIONS`` gives for each event."""

    def __init__(self) -> None:
        self.state = Readiness.ABSENT

    def on(self, event: Event) -> frozenset[Action]:
        """Take ``event``; the actions its row asks for."""
        self.state, actions = TRANSITIONS[(self.state, event)]
        return actions

    @property
    def ready(self) -> bool:
        return self.state is Readiness.READY

    @property
    def stalled(self) -> bool:
        return self.state is Readiness.STALLED
