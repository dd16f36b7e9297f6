"""The pacing table, one test per row: a real ``Broadcaster`` driven into the row's pacing by ticks
and wake-ups, fed the row's event; each checks what it sends, the pacing that follows, and when
it next wakes. Then: every (pacing, event) pair has a row, and every row its test here."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import pytest

from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.services.broadcaster.core.states import PACING, Pacing, PacingEvent
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.bus.schemas import State
from tests.services.broadcaster.scripted import MS, FakeController, cell, resting_tick, tick

T0 = 10.0
"""When the broadcaster is driven into the row's pacing (its own clock, seconds)."""
PERIOD_S = 0.01
"""The state period of the cell every row runs in."""

TESTED: set[tuple[Pacing, PacingEvent]] = set()

Test = Callable[[], None]


def row(pacing: Pacing, event: PacingEvent) -> Callable[[Test], Test]:
    """Marks the test of one row of ``PACING``."""

    def mark(test: Test) -> Test:
        TESTED.add((pacing, event))
        return test

    return mark


def into(pacing: Pacing) -> Broadcaster:
    """A broadcaster brought into ``pacing`` at ``T0`` by what brings it there: nothing, a tick
    (deadline 0), the silence after it, or a resting tick."""
    broadcaster = Broadcaster(cell(state_period_ms=PERIOD_S * 1000), FakeController())
    match pacing:
        case Pacing.WAITING:
            pass
        case Pacing.TICKS:
            assert broadcaster.on_tick(tick(1, 0), T0) is not None
        case Pacing.SILENT:
            broadcaster.on_tick(tick(1, 0), T0 - broadcaster.silence_s)
            assert broadcaster.on_wake(T0, clients=False) is not None
        case Pacing.AT_REST:
            assert broadcaster.on_tick(resting_tick(), T0) is not None
    assert broadcaster.pacing is pacing
    return broadcaster


def rest_silence(broadcaster: Broadcaster) -> float:
    """How long after a resting tick observers' beat waits for the executor's next one."""
    return AT_REST_HEARTBEAT_S + broadcaster.silence_s


def pacing(broadcaster: Broadcaster) -> Pacing:
    """Read afresh: a check of the pacing before an event does not hold after it."""
    return broadcaster.pacing


def sent(state: State | None) -> State:
    assert state is not None, "a snapshot is sent"
    return state


# -- WAITING: no tick yet ----------------------------------------------------------------------


@row(Pacing.WAITING, PacingEvent.TICK)
def test_the_first_tick_is_sent_and_starts_the_silence_watch() -> None:
    broadcaster = into(Pacing.WAITING)
    assert sent(broadcaster.on_tick(tick(1, 0), T0)).tick == 1
    assert broadcaster.pacing is Pacing.TICKS
    assert broadcaster.next_wake(T0, clients=True) == T0 + broadcaster.silence_s


@row(Pacing.WAITING, PacingEvent.RESTING_TICK)
def test_a_first_tick_that_rests_is_sent_and_beats_a_state_period_later() -> None:
    broadcaster = into(Pacing.WAITING)
    assert sent(broadcaster.on_tick(resting_tick(), T0)).tick == 9
    assert broadcaster.pacing is Pacing.AT_REST
    assert broadcaster.next_wake(T0, clients=True) == pytest.approx(T0 + PERIOD_S)
    assert broadcaster.next_wake(T0, clients=False) == pytest.approx(T0 + rest_silence(broadcaster))


@row(Pacing.WAITING, PacingEvent.WAKE_WITH_CLIENTS)
def test_before_any_tick_a_client_gets_nothing() -> None:
    broadcaster = into(Pacing.WAITING)
    assert broadcaster.on_wake(T0, clients=True) is None
    assert broadcaster.pacing is Pacing.WAITING
    assert broadcaster.next_wake(T0, clients=True) is None


@row(Pacing.WAITING, PacingEvent.WAKE_WITHOUT_CLIENTS)
def test_before_any_tick_observers_get_nothing() -> None:
    broadcaster = into(Pacing.WAITING)
    assert broadcaster.on_wake(T0, clients=False) is None
    assert broadcaster.pacing is Pacing.WAITING
    assert broadcaster.next_wake(T0, clients=False) is None


# -- TICKS: the executor's clock runs ----------------------------------------------------------


@row(Pacing.TICKS, PacingEvent.TICK)
def test_ticks_are_sent_on_the_schedule_and_each_moves_the_silence_watch() -> None:
    controller = FakeController()
    broadcaster = Broadcaster(cell(state_period_ms=PERIOD_S * 1000), controller)
    broadcaster.on_tick(tick(1, 0), T0)
    assert broadcaster.on_tick(tick(2, 4 * MS), T0 + 0.004) is None  # before its due time
    assert controller.asked == 1
    assert broadcaster.pacing is Pacing.TICKS
    assert broadcaster.next_wake(T0 + 0.004, clients=True) == T0 + 0.004 + broadcaster.silence_s
    assert sent(broadcaster.on_tick(tick(3, 12 * MS), T0 + 0.012)).tick == 3
    assert broadcaster.pacing is Pacing.TICKS


@row(Pacing.TICKS, PacingEvent.RESTING_TICK)
def test_the_tick_the_clock_rests_after_is_sent_even_before_its_due_time() -> None:
    broadcaster = into(Pacing.TICKS)
    assert sent(broadcaster.on_tick(resting_tick(1), T0 + 0.004)).tick == 1
    assert broadcaster.pacing is Pacing.AT_REST
    assert broadcaster.next_wake(T0 + 0.004, clients=True) == pytest.approx(T0 + 0.004 + PERIOD_S)


@row(Pacing.TICKS, PacingEvent.WAKE_WITH_CLIENTS)
def test_silence_found_with_a_client_repeats_the_last_tick_then_every_silence_s() -> None:
    broadcaster = into(Pacing.TICKS)
    silence = broadcaster.silence_s
    assert broadcaster.on_wake(T0 + silence / 2, clients=True) is None
    assert pacing(broadcaster) is Pacing.TICKS
    late = T0 + 1.5 * silence  # woken late: the next beat counts from now
    assert sent(broadcaster.on_wake(late, clients=True)).tick == 1
    assert broadcaster.pacing is Pacing.SILENT
    assert broadcaster.next_wake(late, clients=True) == pytest.approx(late + silence)


@row(Pacing.TICKS, PacingEvent.WAKE_WITHOUT_CLIENTS)
def test_silence_found_for_observers_only_beats_the_same() -> None:
    broadcaster = into(Pacing.TICKS)
    silence = broadcaster.silence_s
    assert broadcaster.on_wake(T0 + silence / 2, clients=False) is None
    late = T0 + 1.5 * silence
    assert sent(broadcaster.on_wake(late, clients=False)).tick == 1
    assert broadcaster.pacing is Pacing.SILENT
    assert broadcaster.next_wake(late, clients=False) == pytest.approx(late + silence)


# -- SILENT: ticks stopped unannounced ---------------------------------------------------------


@row(Pacing.SILENT, PacingEvent.TICK)
def test_a_tick_after_silence_is_sent_on_the_schedule_and_ends_the_beats() -> None:
    broadcaster = into(Pacing.SILENT)
    assert sent(broadcaster.on_tick(tick(2, 12 * MS), T0 + 0.001)).tick == 2
    assert broadcaster.pacing is Pacing.TICKS
    assert broadcaster.next_wake(T0 + 0.001, clients=True) == T0 + 0.001 + broadcaster.silence_s


@row(Pacing.SILENT, PacingEvent.RESTING_TICK)
def test_a_resting_tick_after_silence_is_sent_and_beats_a_state_period_later() -> None:
    broadcaster = into(Pacing.SILENT)
    assert sent(broadcaster.on_tick(resting_tick(2), T0 + 0.001)).tick == 2
    assert broadcaster.pacing is Pacing.AT_REST
    assert broadcaster.next_wake(T0 + 0.001, clients=True) == pytest.approx(T0 + 0.001 + PERIOD_S)
    following = T0 + 0.001 + rest_silence(broadcaster)
    assert broadcaster.next_wake(T0 + 0.001, clients=False) == pytest.approx(following)


@row(Pacing.SILENT, PacingEvent.WAKE_WITH_CLIENTS)
def test_silent_beats_keep_their_rate_for_a_client_with_no_burst_after_falling_behind() -> None:
    broadcaster = into(Pacing.SILENT)
    silence = broadcaster.silence_s
    assert broadcaster.on_wake(T0 + silence / 2, clients=True) is None
    assert sent(broadcaster.on_wake(T0 + 1.2 * silence, clients=True)).tick == 1
    assert broadcaster.pacing is Pacing.SILENT
    assert broadcaster.next_wake(T0, clients=True) == pytest.approx(T0 + 2 * silence)
    behind = T0 + 5.5 * silence
    assert broadcaster.on_wake(behind, clients=True) is not None
    assert broadcaster.on_wake(behind, clients=True) is None
    assert broadcaster.next_wake(behind, clients=True) == pytest.approx(behind + silence)


@row(Pacing.SILENT, PacingEvent.WAKE_WITHOUT_CLIENTS)
def test_silent_beats_go_on_for_observers_every_silence_s() -> None:
    broadcaster = into(Pacing.SILENT)
    silence = broadcaster.silence_s
    assert broadcaster.on_wake(T0 + silence / 2, clients=False) is None
    late = T0 + 1.5 * silence  # the next beat keeps the rate: counted from the due time
    assert sent(broadcaster.on_wake(late, clients=False)).seq == 3
    assert broadcaster.pacing is Pacing.SILENT
    assert broadcaster.next_wake(late, clients=False) == pytest.approx(T0 + 2 * silence)


# -- AT_REST: the executor's clock rests -------------------------------------------------------


@row(Pacing.AT_REST, PacingEvent.TICK)
def test_the_first_tick_after_a_rest_is_sent_and_ends_the_beats() -> None:
    broadcaster = into(Pacing.AT_REST)
    assert sent(broadcaster.on_tick(tick(300, 1200 * MS), T0 + 2.0)).tick == 300
    assert broadcaster.pacing is Pacing.TICKS
    assert broadcaster.next_wake(T0 + 2.0, clients=True) == T0 + 2.0 + broadcaster.silence_s


@row(Pacing.AT_REST, PacingEvent.RESTING_TICK)
def test_a_resting_tick_again_is_sent_and_the_next_beat_waits_for_the_one_after() -> None:
    """The executor republishes its resting tick every rest heartbeat (for a broadcaster that
    joined since, with the readiness as it is now): observers get one state a second, not the
    tick and a beat of the broadcaster's own after it; a client still gets every period."""
    broadcaster = into(Pacing.AT_REST)
    assert sent(broadcaster.on_tick(resting_tick(9), T0 + 0.5)).seq == 2
    assert broadcaster.pacing is Pacing.AT_REST
    assert broadcaster.next_wake(T0 + 0.5, clients=True) == pytest.approx(T0 + 0.5 + PERIOD_S)
    resent = T0 + 0.5 + AT_REST_HEARTBEAT_S
    assert broadcaster.on_wake(T0 + 0.5 + PERIOD_S, clients=False) is None
    overdue = T0 + 0.5 + rest_silence(broadcaster)
    assert broadcaster.next_wake(T0 + 0.5, clients=False) == pytest.approx(overdue)
    assert overdue > resent
    assert sent(broadcaster.on_tick(resting_tick(9), resent)).seq == 3
    assert broadcaster.next_wake(resent, clients=False) == pytest.approx(
        resent + rest_silence(broadcaster)
    )


@row(Pacing.AT_REST, PacingEvent.WAKE_WITH_CLIENTS)
def test_at_rest_a_client_gets_the_last_tick_every_state_period_and_at_once_on_arrival() -> None:
    broadcaster = into(Pacing.AT_REST)
    assert broadcaster.on_wake(T0 + PERIOD_S / 2, clients=True) is None
    late = T0 + 1.5 * PERIOD_S  # the next beat keeps the rate: counted from the due time
    assert sent(broadcaster.on_wake(late, clients=True)).tick == 9
    assert broadcaster.pacing is Pacing.AT_REST
    assert broadcaster.next_wake(late, clients=True) == pytest.approx(T0 + 2 * PERIOD_S)
    # Paced for observers only (the next beat a heartbeat away), then a client comes.
    assert broadcaster.on_wake(T0 + 2 * PERIOD_S, clients=False) is not None
    arrival = T0 + 0.3
    assert broadcaster.next_wake(arrival, clients=True) == pytest.approx(arrival)
    assert sent(broadcaster.on_wake(arrival, clients=True)).tick == 9
    assert broadcaster.next_wake(arrival, clients=True) == pytest.approx(arrival + PERIOD_S)


@row(Pacing.AT_REST, PacingEvent.WAKE_WITHOUT_CLIENTS)
def test_at_rest_observers_only_get_the_last_tick_once_the_next_resting_tick_is_overdue() -> None:
    """Then every rest heartbeat, from the broadcaster's own clock."""
    broadcaster = into(Pacing.AT_REST)
    assert broadcaster.on_wake(T0 + PERIOD_S, clients=False) is None
    assert broadcaster.on_wake(T0 + 0.5, clients=False) is None
    overdue = T0 + rest_silence(broadcaster)
    assert broadcaster.next_wake(T0 + 0.5, clients=False) == pytest.approx(overdue)
    late = overdue + 0.002  # the next beat keeps the rate: counted from the due time
    assert sent(broadcaster.on_wake(late, clients=False)).tick == 9
    assert broadcaster.pacing is Pacing.AT_REST
    following = overdue + AT_REST_HEARTBEAT_S
    assert broadcaster.next_wake(late, clients=False) == pytest.approx(following)
    assert broadcaster.on_wake(late + 0.5, clients=False) is None


# -- the table as a whole ----------------------------------------------------------------------


def test_every_pacing_and_event_has_a_row() -> None:
    assert set(PACING) == set(itertools.product(Pacing, PacingEvent))


def test_every_row_has_its_test_here() -> None:
    assert set(PACING) == TESTED
