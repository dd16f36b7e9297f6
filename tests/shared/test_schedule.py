"""The snapshot schedule on the executor's ticks: the first tick at or after each due time."""

from __future__ import annotations

import itertools

import pytest

from motocell.shared.schedule import Schedule
from tests.services.broadcaster.scripted import MS


def due_ticks(period_ns: int, tick_ns: int, ticks: int) -> list[int]:
    schedule = Schedule(period_ns)
    return [n for n in range(ticks) if schedule.due(n * tick_ns)]


def test_the_first_tick_is_due() -> None:
    assert Schedule(10 * MS).due(123 * MS)


def test_a_tick_before_the_due_time_is_not_due() -> None:
    schedule = Schedule(10 * MS)
    schedule.due(0)
    assert not schedule.due(9 * MS)


def test_a_tick_exactly_at_the_due_time_is_due() -> None:
    schedule = Schedule(10 * MS)
    schedule.due(0)
    assert schedule.due(10 * MS)


def test_a_period_of_one_tick_sends_on_every_tick() -> None:
    assert due_ticks(4 * MS, 4 * MS, 20) == list(range(20))


def test_a_period_of_whole_ticks_sends_on_every_nth_tick() -> None:
    assert due_ticks(12 * MS, 4 * MS, 30) == list(range(0, 30, 3))


def test_a_period_not_a_multiple_of_the_tick_alternates_intervals() -> None:
    sent = due_ticks(10 * MS, 4 * MS, 50)
    intervals = {4 * (b - a) for a, b in itertools.pairwise(sent)}
    assert intervals == {8, 12}


@pytest.mark.parametrize(
    ("period_ms", "tick_ms"), [(10, 4), (10, 3), (7, 2), (25, 4), (1000, 4), (10, 10)]
)
def test_the_rate_is_exact_on_average(period_ms: int, tick_ms: int) -> None:
    ticks = 10_000
    sent = due_ticks(period_ms * MS, tick_ms * MS, ticks)
    span_ms = (ticks - 1) * tick_ms
    assert len(sent) == span_ms // period_ms + 1


def test_each_snapshot_is_the_first_tick_at_or_after_its_due_time() -> None:
    period, step = 10 * MS, 3 * MS
    for n in due_ticks(period, step, 200)[1:]:
        due = n * step // period * period  # the due time this tick answers
        assert due <= n * step < due + step


def test_after_a_gap_in_ticks_there_is_no_burst_to_catch_up() -> None:
    schedule = Schedule(10 * MS)
    assert schedule.due(0)
    assert schedule.due(55 * MS)
    assert not schedule.due(59 * MS)
    assert schedule.due(65 * MS)
