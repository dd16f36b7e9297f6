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


class ReadinessEvent(Enum):
    """What the readiness machine hears: from the controller's statuses, its liveliness token,
    and the clock's stall checks."""

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

TRANSITIONS: dict[tuple[Readiness, ReadinessEvent], Row] = {
    # A status without its controller's token may be the last of a dead controller.
    (Readiness.ABSENT, ReadinessEvent.READY_STATUS): (Readiness.ABSENT, _NOTHING),
    (Readiness.ABSENT, ReadinessEvent.NOT_READY_STATUS): (Readiness.ABSENT, _NOTHING),
    (Readiness.ABSENT, ReadinessEvent.ALARM_STATUS): (Readiness.ABSENT, _NOTHING),
    (Readiness.ABSENT, ReadinessEvent.CONTROLLER_GONE): (Readiness.ABSENT, _NOTHING),
    # Back (or first seen): its next status decides.
    (Readiness.ABSENT, ReadinessEvent.CONTROLLER_BACK): (Readiness.WAITING, _NOTHING),
    # Nothing is queued while not ready: a late tick stops nothing.
    (Readiness.ABSENT, ReadinessEvent.STALL): (Readiness.ABSENT, _NOTHING),
    (Readiness.ABSENT, ReadinessEvent.NOTICE_DUE): (Readiness.ABSENT, _NOTHING),
    (Readiness.WAITING, ReadinessEvent.READY_STATUS): (Readiness.READY, _NOTHING),
    (Readiness.WAITING, ReadinessEvent.NOT_READY_STATUS): (Readiness.WAITING, _NOTHING),
    (Readiness.WAITING, ReadinessEvent.ALARM_STATUS): (Readiness.WAITING, _NOTHING),
    (Readiness.WAITING, ReadinessEvent.CONTROLLER_GONE): (Readiness.ABSENT, _NOTHING),
    (Readiness.WAITING, ReadinessEvent.CONTROLLER_BACK): (Readiness.WAITING, _NOTHING),
    (Readiness.WAITING, ReadinessEvent.STALL): (Readiness.WAITING, _NOTHING),
    (Readiness.WAITING, ReadinessEvent.NOTICE_DUE): (Readiness.WAITING, _NOTHING),
    (Readiness.READY, ReadinessEvent.READY_STATUS): (Readiness.READY, _NOTHING),
    # Motion-ready dropped (motoros1 §3.3: the queue is cleared).
    (Readiness.READY, ReadinessEvent.NOT_READY_STATUS): (Readiness.WAITING, _CLEAR),
    (Readiness.READY, ReadinessEvent.ALARM_STATUS): (Readiness.WAITING, _CLEAR),
    (Readiness.READY, ReadinessEvent.CONTROLLER_GONE): (Readiness.ABSENT, _CLEAR),
    (Readiness.READY, ReadinessEvent.CONTROLLER_BACK): (Readiness.READY, _NOTHING),
    (Readiness.READY, ReadinessEvent.STALL): (Readiness.STALLED, _STOP),
    (Readiness.READY, ReadinessEvent.NOTICE_DUE): (Readiness.READY, _NOTHING),
    # Sent before the controller had the notice: old news, and the notice may have been lost.
    (Readiness.STALLED, ReadinessEvent.READY_STATUS): (Readiness.STALLED, _NOTICE),
    # Not ready for another reason: the notice may not have reached the controller yet.
    (Readiness.STALLED, ReadinessEvent.NOT_READY_STATUS): (Readiness.STALLED, _NOTHING),
    # The alarm's status: the controller knows; START_TRAJ_MODE makes it ready again.
    (Readiness.STALLED, ReadinessEvent.ALARM_STATUS): (Readiness.WAITING, _NOTHING),
    # The stall holds whatever the token does (a router stall deletes tokens too): only the
    # controller's alarm ends it.
    (Readiness.STALLED, ReadinessEvent.CONTROLLER_GONE): (Readiness.STALLED, _NOTHING),
    (Readiness.STALLED, ReadinessEvent.CONTROLLER_BACK): (Readiness.STALLED, _NOTHING),
    (Readiness.STALLED, ReadinessEvent.STALL): (Readiness.STALLED, _NOTHING),
    (Readiness.STALLED, ReadinessEvent.NOTICE_DUE): (Readiness.STALLED, _NOTICE),
}


class ReadinessMachine:
    """The current state and the transition that ``TRANSITIONS`` gives for each event."""

    def __init__(self) -> None:
        self.state = Readiness.ABSENT

    def on(self, event: ReadinessEvent) -> frozenset[Action]:
        """Take ``event``; the actions its row asks for."""
        self.state, actions = TRANSITIONS[(self.state, event)]
        return actions

    @property
    def ready(self) -> bool:
        return self.state is Readiness.READY

    @property
    def stalled(self) -> bool:
        return self.state is Readiness.STALLED
