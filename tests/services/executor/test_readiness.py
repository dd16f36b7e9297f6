"""The executor's readiness machine, one test per (state, event): each row below states a rule
of docs/behaviour.md ("Stalls", "Motion") independently of the table it checks."""

from __future__ import annotations

import pytest

from motocell.services.executor.readiness import (
    TRANSITIONS,
    Action,
    Event,
    Readiness,
    ReadinessMachine,
)

A, W, R, S = Readiness.ABSENT, Readiness.WAITING, Readiness.READY, Readiness.STALLED
CLEAR, NOTICE = Action.CLEAR_RINGS, Action.NOTICE

ROWS = [
    (A, Event.READY_STATUS, A, set(), "a status without the token may be a dead controller's"),
    (A, Event.NOT_READY_STATUS, A, set(), "nothing to do without a controller"),
    (A, Event.ALARM_STATUS, A, set(), "nothing to do without a controller"),
    (A, Event.CONTROLLER_GONE, A, set(), "already gone"),
    (A, Event.CONTROLLER_BACK, W, set(), "back: its next status decides"),
    (A, Event.STALL, A, set(), "nothing was queued, so nothing to stop"),
    (A, Event.NOTICE_DUE, A, set(), "no stall to tell"),
    (W, Event.READY_STATUS, R, set(), "motion-ready from a live controller"),
    (W, Event.NOT_READY_STATUS, W, set(), "still not ready"),
    (W, Event.ALARM_STATUS, W, set(), "an alarm is never ready"),
    (W, Event.CONTROLLER_GONE, A, set(), "gone"),
    (W, Event.CONTROLLER_BACK, W, set(), "a repeated presence changes nothing"),
    (W, Event.STALL, W, set(), "nothing was queued, so nothing to stop"),
    (W, Event.NOTICE_DUE, W, set(), "no stall to tell"),
    (R, Event.READY_STATUS, R, set(), "the heartbeat"),
    (R, Event.NOT_READY_STATUS, W, {CLEAR}, "motion-ready dropped: the queue is cleared"),
    (R, Event.ALARM_STATUS, W, {CLEAR}, "an alarm: the queue is cleared"),
    (R, Event.CONTROLLER_GONE, A, {CLEAR}, "the controller died: nothing queued may move"),
    (R, Event.CONTROLLER_BACK, R, set(), "a repeated presence changes nothing"),
    (R, Event.STALL, S, {CLEAR, NOTICE}, "a stall: nothing queued is applied late; alarm 4200"),
    (R, Event.NOTICE_DUE, R, set(), "no stall to tell"),
    (S, Event.READY_STATUS, S, {NOTICE}, "old news, and the notice may have been lost"),
    (S, Event.NOT_READY_STATUS, S, set(), "not ready for another reason: not yet confirmed"),
    (S, Event.ALARM_STATUS, W, set(), "the controller confirmed the stall with its alarm"),
    (S, Event.CONTROLLER_GONE, S, set(), "only a not-ready status ends a stall"),
    (S, Event.CONTROLLER_BACK, S, set(), "only a not-ready status ends a stall"),
    (S, Event.STALL, S, set(), "already stopped"),
    (S, Event.NOTICE_DUE, S, {NOTICE}, "told again once a second until confirmed"),
]


@pytest.mark.parametrize(
    ("state", "event", "after", "actions", "why"), ROWS, ids=[row[4] for row in ROWS]
)
def test_each_transition(
    state: Readiness, event: Event, after: Readiness, actions: set[Action], why: str
) -> None:
    machine = ReadinessMachine()
    machine.state = state
    assert machine.on(event) == actions, why
    assert machine.state is after, why


def test_every_state_takes_every_event() -> None:
    assert set(TRANSITIONS) == {(state, event) for state in Readiness for event in Event}
    assert len(ROWS) == len(TRANSITIONS)


def test_only_ready_lets_anything_move() -> None:
    for state in Readiness:
        machine = ReadinessMachine()
        machine.state = state
        assert machine.ready is (state is R)
        assert machine.stalled is (state is S)


def test_it_starts_without_a_controller() -> None:
    assert ReadinessMachine().state is A
