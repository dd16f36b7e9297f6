"""The feeder's phases, one test per transition, each stating its rule independently of the
table it checks, and the phases a real feeder goes through."""

from __future__ import annotations

import pytest

from motocell.services.interpolator.core import TRANSITIONS, Event, Phase
from tests.services.interpolator.test_core import Harness, X, Y, point, state

ROWS = [
    (Phase.IDLE, Event.FIRST_POINT, Phase.STARTED, "a sequence-0 point starts a trajectory"),
    (Phase.IDLE, Event.NEXT_POINT, Phase.IDLE, "nothing to extend: the point is dropped"),
    (Phase.IDLE, Event.RING_CLEARED, Phase.IDLE, "nothing to drop"),
    (Phase.STARTED, Event.FIRST_POINT, Phase.STARTED, "a new start replaces one that never moved"),
    (Phase.STARTED, Event.NEXT_POINT, Phase.SENDING, "the first segment, with the start buffer"),
    (Phase.STARTED, Event.RING_CLEARED, Phase.IDLE, "a cleared ring ends the trajectory"),
    (Phase.SENDING, Event.SEGMENT_SENT, Phase.BETWEEN, "the segment is all in the ring"),
    (Phase.SENDING, Event.RING_CLEARED, Phase.IDLE, "stopped mid-segment: the rest is dropped"),
    (Phase.BETWEEN, Event.FIRST_POINT, Phase.STARTED, "a new trajectory"),
    (Phase.BETWEEN, Event.NEXT_POINT, Phase.SENDING, "the trajectory goes on"),
    (Phase.BETWEEN, Event.RING_CLEARED, Phase.IDLE, "a cleared ring ends the trajectory"),
]


@pytest.mark.parametrize(("phase", "event", "after", "why"), ROWS, ids=[row[3] for row in ROWS])
def test_each_transition(phase: Phase, event: Event, after: Phase, why: str) -> None:
    assert TRANSITIONS[(phase, event)] is after, why


def test_a_sending_feeder_takes_no_point_so_the_table_has_no_such_row() -> None:
    assert set(TRANSITIONS) == {(phase, event) for phase, event, _, _ in ROWS}
    assert not any(
        phase is Phase.SENDING and event in (Event.FIRST_POINT, Event.NEXT_POINT)
        for phase, event in TRANSITIONS
    )


def test_a_feeder_goes_through_the_phases() -> None:
    h = Harness()
    seen = [h.feeder.phase]
    h.queue(state(depth=150))
    h.feed(point(1, 0, 0.0))
    seen.append(h.feeder.phase)
    h.feed(point(2, 1, 0.4, X))  # 100 entries, room for 50
    seen.append(h.feeder.phase)
    h.queue(state(received=50, depth=0))
    seen.append(h.feeder.phase)
    h.feed(point(3, 1, 0.5, Y))  # 25 entries fit at once
    seen.append(h.feeder.phase)
    h.queue(state(epoch=2))
    seen.append(h.feeder.phase)
    assert seen == [
        Phase.IDLE,
        Phase.STARTED,
        Phase.SENDING,
        Phase.BETWEEN,
        Phase.BETWEEN,
        Phase.IDLE,
    ]
