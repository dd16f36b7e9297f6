"""``Resting``: the clock rests after ``REST_AFTER_NS`` of quiet ticks and runs again when
motion is asked for; a rested clock resumes on its grid (``next_on_grid``). How the core feeds
it: tests/services/executor/core/test_executor.py ("rest")."""

from __future__ import annotations

import pytest

from motocell.services.executor.core.resting import REST_AFTER_NS, Resting, next_on_grid

PERIOD_NS = 4_000_000


def quiet_ticks(rest: Resting, start_ns: int, end_ns: int) -> list[int]:
    """Quiet ticks every period from ``start_ns`` to ``end_ns``; the times at which the clock
    started resting."""
    return [now for now in range(start_ns, end_ns + 1, PERIOD_NS) if rest.after_tick(True, now)]


def test_it_rests_once_quiet_for_the_whole_span() -> None:
    rest = Resting()
    assert quiet_ticks(rest, 0, REST_AFTER_NS - PERIOD_NS) == []
    assert not rest.resting
    assert rest.after_tick(True, REST_AFTER_NS)
    assert rest.resting


def test_a_busy_tick_starts_the_span_again() -> None:
    rest = Resting()
    quiet_ticks(rest, 0, REST_AFTER_NS - PERIOD_NS)
    assert not rest.after_tick(False, REST_AFTER_NS)
    assert quiet_ticks(rest, REST_AFTER_NS + PERIOD_NS, 2 * REST_AFTER_NS) == []
    assert rest.after_tick(True, 2 * REST_AFTER_NS + PERIOD_NS)


def test_motion_asked_for_wakes_a_resting_clock_only() -> None:
    rest = Resting()
    assert not rest.wake()
    quiet_ticks(rest, 0, REST_AFTER_NS)
    assert rest.resting
    assert rest.wake()
    assert not rest.resting
    assert not rest.wake()


def test_a_woken_clock_counts_its_quiet_anew() -> None:
    rest = Resting()
    quiet_ticks(rest, 0, REST_AFTER_NS)
    rest.wake()
    later = 5 * REST_AFTER_NS
    assert quiet_ticks(rest, later, later + REST_AFTER_NS - PERIOD_NS) == []
    assert rest.after_tick(True, later + REST_AFTER_NS)


@pytest.mark.parametrize(
    ("now", "expected"),
    [(0, 100), (100, 100), (101, 104), (103, 104), (104, 104), (105, 108), (50, 100)],
)
def test_a_rested_clock_resumes_on_its_grid(now: int, expected: int) -> None:
    assert next_on_grid(100, 4, now) == expected
