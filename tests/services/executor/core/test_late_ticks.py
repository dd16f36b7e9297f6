"""``LateTickTally``: the first late tick is said at once, later ones gathered, at most one
announcement per ``QUIET_NS``."""

from __future__ import annotations

from motocell.services.executor.core.late_ticks import QUIET_NS, LateTickTally
from motocell.shared.bus.schemas import LateTicks

PERIOD_NS = 4_000_000
T0 = 10_000_000_000


def test_the_first_late_tick_is_said_at_once() -> None:
    tally = LateTickTally()
    said = tally.count(7, T0, PERIOD_NS + 1, missed_total=1, now_ns=T0 + PERIOD_NS + 1)
    assert said == LateTicks(
        tick=7, deadline_ns=T0, lateness_ns=PERIOD_NS + 1, periods=1, missed_total=1
    )


def test_late_ticks_within_the_quiet_time_are_gathered_into_the_next() -> None:
    tally = LateTickTally()
    assert tally.count(1, T0, PERIOD_NS, missed_total=1, now_ns=T0) is not None
    assert tally.count(2, T0 + 10, 3 * PERIOD_NS, missed_total=2, now_ns=T0 + 10) is None
    assert tally.count(3, T0 + 20, 2 * PERIOD_NS, missed_total=3, now_ns=T0 + 20) is None
    assert tally.due(missed_total=3, now_ns=T0 + QUIET_NS - 1) is None
    said = tally.due(missed_total=3, now_ns=T0 + QUIET_NS)
    # The worst of them, and how many.
    assert said == LateTicks(
        tick=2, deadline_ns=T0 + 10, lateness_ns=3 * PERIOD_NS, periods=2, missed_total=3
    )


def test_nothing_is_due_without_a_late_tick() -> None:
    tally = LateTickTally()
    assert tally.due(missed_total=0, now_ns=T0) is None
    assert tally.count(1, T0, PERIOD_NS, missed_total=1, now_ns=T0) is not None
    assert tally.due(missed_total=1, now_ns=T0 + 2 * QUIET_NS) is None, "said once only"


def test_a_late_tick_after_a_quiet_second_is_said_at_once_again() -> None:
    tally = LateTickTally()
    tally.count(1, T0, PERIOD_NS, missed_total=1, now_ns=T0)
    again = tally.count(9, T0 + QUIET_NS, PERIOD_NS, missed_total=2, now_ns=T0 + QUIET_NS)
    assert again is not None and (again.tick, again.periods, again.missed_total) == (9, 1, 2)
