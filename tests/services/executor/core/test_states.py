"""The executor's readiness machine, one test per (state, event): each row below states a rule
of docs/behaviour.md ("Stalls", "Motion") independently of the table it checks. Each row is
driven through ``ExecutorCore``, the code that consults the table: brought into the row's state
by what the executor hears, then given the row's event as the executor would hear it, with
entries queued when the state allows; the outcome is read from what the core does (its rings
cleared or not, a stall notice told or not)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from motocell.services.executor.core.executor import NOTICE_EVERY_NS, ExecutorCore
from motocell.services.executor.core.rings import BatchOutcome
from motocell.services.executor.core.states import (
    TRANSITIONS,
    Action,
    Readiness,
    ReadinessEvent,
    ReadinessMachine,
)
from tests.services.executor.core.test_executor import (
    FIRST_EPOCH,
    PERIOD_NS,
    STALL_STATUS,
    START,
    batch,
    status,
    unit,
)

CLEAR, NOTICE = Action.CLEAR_RINGS, Action.NOTICE
ABSENT, WAITING, READY, STALLED = (
    Readiness.ABSENT,
    Readiness.WAITING,
    Readiness.READY,
    Readiness.STALLED,
)

ROWS = [
    (ABSENT, ReadinessEvent.READY_STATUS, ABSENT, set(),
     "a status without the token may be a dead controller's"),
    (ABSENT, ReadinessEvent.NOT_READY_STATUS, ABSENT, set(), "nothing to do without a controller"),
    (ABSENT, ReadinessEvent.ALARM_STATUS, ABSENT, set(), "nothing to do without a controller"),
    (ABSENT, ReadinessEvent.CONTROLLER_GONE, ABSENT, set(), "already gone"),
    (ABSENT, ReadinessEvent.CONTROLLER_BACK, WAITING, set(), "back: its next status decides"),
    (ABSENT, ReadinessEvent.STALL, ABSENT, set(), "nothing was queued, so nothing to stop"),
    (ABSENT, ReadinessEvent.NOTICE_DUE, ABSENT, set(), "no stall to tell"),
    (WAITING, ReadinessEvent.READY_STATUS, READY, set(), "motion-ready from a live controller"),
    (WAITING, ReadinessEvent.NOT_READY_STATUS, WAITING, set(), "still not ready"),
    (WAITING, ReadinessEvent.ALARM_STATUS, WAITING, set(), "an alarm is never ready"),
    (WAITING, ReadinessEvent.CONTROLLER_GONE, ABSENT, set(), "gone"),
    (WAITING, ReadinessEvent.CONTROLLER_BACK, WAITING, set(),
     "a repeated presence changes nothing"),
    (WAITING, ReadinessEvent.STALL, WAITING, set(), "nothing was queued, so nothing to stop"),
    (WAITING, ReadinessEvent.NOTICE_DUE, WAITING, set(), "no stall to tell"),
    (READY, ReadinessEvent.READY_STATUS, READY, set(), "the heartbeat"),
    (READY, ReadinessEvent.NOT_READY_STATUS, WAITING, {CLEAR},
     "motion-ready dropped: the queue is cleared"),
    (READY, ReadinessEvent.ALARM_STATUS, WAITING, {CLEAR}, "an alarm: the queue is cleared"),
    (READY, ReadinessEvent.CONTROLLER_GONE, ABSENT, {CLEAR},
     "the controller died: nothing queued may move"),
    (READY, ReadinessEvent.CONTROLLER_BACK, READY, set(), "a repeated presence changes nothing"),
    (READY, ReadinessEvent.STALL, STALLED, {CLEAR, NOTICE},
     "a stall: nothing queued is applied late; alarm 4200"),
    (READY, ReadinessEvent.NOTICE_DUE, READY, set(), "no stall to tell"),
    (STALLED, ReadinessEvent.READY_STATUS, STALLED, {NOTICE},
     "old news, and the notice may have been lost"),
    (STALLED, ReadinessEvent.NOT_READY_STATUS, STALLED, set(),
     "not ready for another reason: not yet confirmed"),
    (STALLED, ReadinessEvent.ALARM_STATUS, WAITING, set(),
     "the controller confirmed the stall with its alarm"),
    (STALLED, ReadinessEvent.CONTROLLER_GONE, STALLED, set(),
     "only the stall's alarm ends a stall"),
    (STALLED, ReadinessEvent.CONTROLLER_BACK, STALLED, set(),
     "only the stall's alarm ends a stall"),
    (STALLED, ReadinessEvent.STALL, STALLED, set(), "already stopped"),
    (STALLED, ReadinessEvent.NOTICE_DUE, STALLED, {NOTICE},
     "told again once a second until confirmed"),
]  # fmt: skip

LATE_NS = 1_000 * PERIOD_NS
"""Lateness far past any cell's bound: a stall."""
STALLED_AT_NS = PERIOD_NS
"""When ``core_in`` stalls a core; its notice is due again ``NOTICE_EVERY_NS`` later."""
NOW_NS = STALLED_AT_NS + PERIOD_NS
"""When each row's event comes, before any notice is due again."""


def core_in(state: Readiness) -> ExecutorCore:
    """A core brought into ``state`` by what the executor hears; when ready, group 0 has
    entries queued."""
    core = ExecutorCore(START, FIRST_EPOCH)
    if state is ABSENT:
        return core
    core.on_controller(True, 0)
    if state is WAITING:
        return core
    core.on_status(status(True), 0)
    assert core.accept(0, batch(FIRST_EPOCH, 0, [unit(1)] * 5)) is BatchOutcome.ACCEPTED
    if state is STALLED:
        core.on_tick(STALLED_AT_NS - LATE_NS, LATE_NS)
        core.take_notices()
    return core


EVENTS: dict[ReadinessEvent, Callable[[ExecutorCore], object]] = {
    ReadinessEvent.READY_STATUS: lambda core: core.on_status(status(True), NOW_NS),
    ReadinessEvent.NOT_READY_STATUS: lambda core: core.on_status(status(False), NOW_NS),
    ReadinessEvent.ALARM_STATUS: lambda core: core.on_status(STALL_STATUS, NOW_NS),
    ReadinessEvent.CONTROLLER_GONE: lambda core: core.on_controller(False, NOW_NS),
    ReadinessEvent.CONTROLLER_BACK: lambda core: core.on_controller(True, NOW_NS),
    ReadinessEvent.STALL: lambda core: core.on_tick(NOW_NS - LATE_NS, LATE_NS),
    ReadinessEvent.NOTICE_DUE: lambda core: core.notice_if_due(STALLED_AT_NS + NOTICE_EVERY_NS),
}
"""Each event as the executor hears it: a status, the token, a late tick, the clock."""


@pytest.mark.parametrize(
    ("state", "event", "after", "actions", "why"), ROWS, ids=[row[4] for row in ROWS]
)
def test_each_transition(
    state: Readiness, event: ReadinessEvent, after: Readiness, actions: set[Action], why: str
) -> None:
    core = core_in(state)
    assert core.readiness.state is state
    epochs = [ring.epoch for ring in core.rings]
    EVENTS[event](core)
    assert core.readiness.state is after, why
    cleared = [ring.epoch for ring in core.rings] != epochs
    assert cleared is (CLEAR in actions), why
    if cleared:
        assert all(not ring.entries for ring in core.rings), why
    told = core.take_notices()
    assert bool(told) is (NOTICE in actions), why


def test_every_state_takes_every_event() -> None:
    assert set(TRANSITIONS) == {(state, event) for state in Readiness for event in ReadinessEvent}
    assert len(ROWS) == len(TRANSITIONS)
    assert set(EVENTS) == set(ReadinessEvent)


def test_only_ready_lets_anything_move() -> None:
    for state in Readiness:
        machine = ReadinessMachine()
        machine.state = state
        assert machine.ready is (state is READY)
        assert machine.stalled is (state is STALLED)


def test_it_starts_without_a_controller() -> None:
    assert ReadinessMachine().state is ABSENT
