"""The face's pacing table, one test per row: a real ``Face`` brought into the row's pacing by
samples and wake-ups, fed the row's event; each checks what it publishes, the pacing that
follows and when it next wakes. Then: every (pacing, event) pair has a row, and every row its
test here."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import pytest

from motocell.services.ros2.core.face import SILENCE_NS, Face
from motocell.services.ros2.core.states import (
    PACING,
    ImpossibleEventError,
    Pacing,
    PacingEvent,
)
from tests.services.ros2.scripted import MS, PERIOD_NS, face_cell, sample

T0 = 10_000 * MS
"""When the face is brought into the row's pacing (CLOCK_MONOTONIC ns)."""
TICK0 = T0 - 2 * MS
"""The tick of the sample that brings it there: 2 ms old when it arrives."""
HOLD_AFTER_NS = PERIOD_NS * 3 // 2
CELL = face_cell()

TESTED: set[tuple[Pacing, PacingEvent]] = set()

Test = Callable[[], None]


def row(pacing: Pacing, event: PacingEvent) -> Callable[[Test], Test]:
    def mark(test: Test) -> Test:
        TESTED.add((pacing, event))
        return test

    return mark


def into(pacing: Pacing) -> Face:
    """A face brought into ``pacing`` by what brings it there: nothing (quiet), a sample
    (following), a sample and its deadline passing (holding)."""
    assert CELL.ros2 is not None
    face = Face(CELL, CELL.ros2)
    if pacing is not Pacing.QUIET:
        assert face.on_sample(sample(CELL, TICK0), T0 - HOLD_AFTER_NS) is not None
    if pacing is Pacing.HOLDING:
        assert face.on_wake(T0) is not None
    assert face.pacing is pacing
    return face


def pacing(face: Face) -> Pacing:
    """Read afresh: mypy narrows an attribute checked before an event."""
    return face.pacing


@row(Pacing.QUIET, PacingEvent.SAMPLE_DUE)
def test_the_first_sample_is_published_stamped_with_its_tick() -> None:
    face = into(Pacing.QUIET)
    values = face.on_sample(sample(CELL, TICK0), T0)
    assert values is not None and values.sampled_ns == TICK0
    assert (pacing(face), face.wake_ns) == (Pacing.FOLLOWING, T0 + HOLD_AFTER_NS)


@row(Pacing.QUIET, PacingEvent.SAMPLE_EARLY)
def test_after_a_silence_an_old_sample_is_news_all_the_same() -> None:
    face = into(Pacing.FOLLOWING)
    assert face.on_wake(T0 + SILENCE_NS) is None
    assert pacing(face) is Pacing.QUIET
    # The same tick again (a broadcaster that came back sends its resting tick): not due.
    values = face.on_sample(sample(CELL, TICK0), T0 + SILENCE_NS + MS)
    # Stamped now: its tick was published already, and stamps never go back.
    assert values is not None and values.sampled_ns == T0 + SILENCE_NS + MS
    assert pacing(face) is Pacing.FOLLOWING


@row(Pacing.QUIET, PacingEvent.DUE)
def test_a_deadline_while_quiet_is_a_bug() -> None:
    face = into(Pacing.FOLLOWING)
    face.pacing = Pacing.QUIET  # cannot be reached: quiet, no sample is recent
    with pytest.raises(ImpossibleEventError):
        face.on_wake(T0 + HOLD_AFTER_NS)


@row(Pacing.QUIET, PacingEvent.SILENCE)
def test_a_wake_up_while_quiet_publishes_nothing_and_sets_no_deadline() -> None:
    face = into(Pacing.QUIET)
    assert face.on_wake(T0) is None  # the doorbell at stop
    assert (pacing(face), face.wake_ns) == (Pacing.QUIET, None)


@row(Pacing.FOLLOWING, PacingEvent.SAMPLE_DUE)
def test_a_due_sample_is_published_as_it_comes() -> None:
    face = into(Pacing.FOLLOWING)
    values = face.on_sample(sample(CELL, TICK0 + PERIOD_NS, 0.5), T0 + PERIOD_NS)
    assert values is not None and values.positions == (0.5,) * 6
    assert (pacing(face), face.wake_ns) == (Pacing.FOLLOWING, T0 + PERIOD_NS + HOLD_AFTER_NS)


@row(Pacing.FOLLOWING, PacingEvent.SAMPLE_EARLY)
def test_a_sample_before_the_due_time_is_kept_not_published() -> None:
    """A cell whose state period is shorter than the face's (4 ms): the face keeps its own."""
    face = into(Pacing.FOLLOWING)
    wake = face.wake_ns
    assert face.on_sample(sample(CELL, TICK0 + 4 * MS, 0.5), T0 + 4 * MS) is None
    assert (pacing(face), face.wake_ns) == (Pacing.FOLLOWING, wake)
    # What it kept is what the next deadline publishes.
    held = face.on_wake(T0 + HOLD_AFTER_NS)
    assert held is not None and held.positions == (0.5,) * 6


@row(Pacing.FOLLOWING, PacingEvent.DUE)
def test_no_sample_for_a_period_and_a_half_publishes_the_newest_again_stamped_now() -> None:
    face = into(Pacing.FOLLOWING)
    values = face.on_wake(T0 + HOLD_AFTER_NS)
    assert values is not None and values.sampled_ns == T0 + HOLD_AFTER_NS
    assert (pacing(face), face.wake_ns) == (Pacing.HOLDING, T0 + HOLD_AFTER_NS + PERIOD_NS)


@row(Pacing.FOLLOWING, PacingEvent.SILENCE)
def test_a_face_woken_after_the_silence_publishes_nothing() -> None:
    """A face whose process was stopped longer than SILENCE: no stale position goes out."""
    face = into(Pacing.FOLLOWING)
    assert face.on_wake(T0 + SILENCE_NS) is None
    assert (pacing(face), face.wake_ns) == (Pacing.QUIET, None)


@row(Pacing.HOLDING, PacingEvent.SAMPLE_DUE)
def test_a_sample_while_holding_is_published_at_once() -> None:
    face = into(Pacing.HOLDING)
    values = face.on_sample(sample(CELL, T0 + 3 * MS, 0.5), T0 + 4 * MS)
    assert values is not None and values.sampled_ns == T0 + 3 * MS
    assert pacing(face) is Pacing.FOLLOWING


@row(Pacing.HOLDING, PacingEvent.SAMPLE_EARLY)
def test_a_resting_cells_sample_while_holding_is_news_at_once() -> None:
    """At rest the cell sends its resting tick again once a second, with a status that may
    have changed (an E-stop): published at once, though its tick is old."""
    face = into(Pacing.HOLDING)
    values = face.on_sample(sample(CELL, TICK0, 0.5), T0 + 500 * MS)
    assert values is not None and values.positions == (0.5,) * 6
    assert pacing(face) is Pacing.FOLLOWING
    # Its tick is older than what was published while holding: stamped now, never back.
    assert values.sampled_ns == T0 + 500 * MS


@row(Pacing.HOLDING, PacingEvent.DUE)
def test_holding_publishes_every_period_on_its_grid() -> None:
    face = into(Pacing.HOLDING)
    first = face.wake_ns
    assert first == T0 + PERIOD_NS
    late = first + 3 * MS  # woken late: the next deadline stays on the grid
    values = face.on_wake(late)
    assert values is not None and values.sampled_ns == late
    assert (pacing(face), face.wake_ns) == (Pacing.HOLDING, first + PERIOD_NS)


@row(Pacing.HOLDING, PacingEvent.SILENCE)
def test_holding_ends_when_the_cell_has_been_silent_too_long() -> None:
    face = into(Pacing.HOLDING)
    heard = T0 - HOLD_AFTER_NS
    assert face.on_wake(heard + SILENCE_NS) is None
    assert (pacing(face), face.wake_ns) == (Pacing.QUIET, None)


def test_an_early_wake_up_is_no_event() -> None:
    face = into(Pacing.FOLLOWING)
    wake = face.wake_ns
    assert wake is not None
    assert face.on_wake(wake - 1) is None
    assert (pacing(face), face.wake_ns) == (Pacing.FOLLOWING, wake)


def test_every_pacing_and_event_has_a_row() -> None:
    assert set(PACING) == set(itertools.product(Pacing, PacingEvent))


def test_every_row_has_its_test() -> None:
    assert set(PACING) == TESTED
