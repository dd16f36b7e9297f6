"""When the gateway asks an interpolator for its slot (interpolators publish it only when it
changes): when it has none, at start and whenever it forgot it with a missing interpolator,
once that interpolator is back; when the group's queue stream stopped (a slot may have been
lost the same way); never while the interpolator is reported missing; and at a slow rate while
nobody answers. Pure: the test's clock."""

from __future__ import annotations

from motocell.services.gateway.core.cell_state import CellState
from motocell.shared.bus.liveness import ASK_AGAIN_S, QUERY_TIMEOUT_S, Asking
from tests.services.gateway.core.fake_cell import NOW, FakeCell, queue, slot, status

GONE = ["interpolator/1"]


def test_every_group_is_asked_for_at_start_once() -> None:
    state = CellState(3)
    assert state.slots_to_ask(NOW) == [0, 1, 2]
    assert state.slots_to_ask(NOW) == []
    assert state.next_check() == NOW + QUERY_TIMEOUT_S + ASK_AGAIN_S


def test_a_slot_heard_is_not_asked_for() -> None:
    state = CellState(2)
    state.on_slot(0, slot())
    assert state.slots_to_ask(NOW) == [1]


def test_an_unanswered_group_is_asked_again_at_a_slow_rate() -> None:
    state = CellState(1)
    state.slots_to_ask(NOW)
    state.slot_answered(0, NOW + 0.01)
    assert state.sooner()
    assert state.next_check() == NOW + 0.01 + ASK_AGAIN_S
    assert state.slots_to_ask(NOW + ASK_AGAIN_S) == []
    assert state.slots_to_ask(NOW + 0.01 + ASK_AGAIN_S) == [0]


def test_a_question_never_finished_does_not_stop_the_asking() -> None:
    state = CellState(1)
    state.slots_to_ask(NOW)
    assert state.slots_to_ask(NOW + QUERY_TIMEOUT_S + ASK_AGAIN_S) == [0]


def test_a_missing_interpolator_is_not_asked_and_is_asked_at_once_when_back() -> None:
    cell = FakeCell(2).ready()
    state = cell.state
    state.on_status(status(ready=False, missing=GONE), NOW)
    assert not state.groups[1].known
    assert state.slots_to_ask(NOW + 10) == []

    state.on_status(status(), NOW + 10.5)
    assert state.sooner()
    assert state.slots_to_ask(NOW + 10.5) == [1]


def test_an_interpolator_back_is_asked_even_when_asked_a_moment_ago() -> None:
    state = CellState(2)
    state.slots_to_ask(NOW)  # at start, before the interpolators ran
    state.on_status(status(ready=False, missing=GONE), NOW)
    state.on_status(status(), NOW + 0.2)
    assert state.slots_to_ask(NOW + 0.2) == [1]


def test_a_group_whose_queue_stream_stopped_is_asked_although_its_slot_is_known() -> None:
    cell = FakeCell(2).ready()
    state = cell.state
    state.next_check()
    state.on_status(status(), NOW + 0.5)
    state.on_queue(0, queue(), NOW + 0.5)
    state.expire(NOW + 0.5)
    assert state.groups[1].known
    assert state.slots_to_ask(NOW + 0.5) == [1]
    assert state.slots_to_ask(NOW + 0.6) == []


def test_nothing_wanted_and_nothing_heard_plans_no_check() -> None:
    state = CellState(1)
    state.on_slot(0, slot())
    assert state.next_check() is None


def test_asking_renewed_is_due_at_once() -> None:
    asking = Asking(every=1.0, timeout=2.0)
    assert asking.due(NOW)
    asking.asked(NOW)
    assert not asking.due(NOW + 2.9)
    assert asking.due(NOW + 3.0)
    asking.finished(NOW + 0.5)
    assert asking.next == NOW + 1.5
    asking.renew()
    assert asking.due(NOW)
