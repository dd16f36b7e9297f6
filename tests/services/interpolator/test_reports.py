"""The interpolator's reports on a scripted bus, with a real feeder and a clock the test turns:
the slot published on each change and only then, a query answered with the slot last
published, the metrics once a second only while observed, and the time the slot was full."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from motocell.services.interpolator.reports import METRICS_S, Reports
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, InterpolatorMetrics, Slot
from tests.services.interpolator.core.test_feeder import Harness, X, point, state
from tests.services.interpolator.fake_bus import FakeBus

KEYS = CellKeys("cell1")
GROUP = 0
SLOT_KEY = KEYS.group_slot(GROUP)
METRICS_KEY = KEYS.group_metrics(GROUP)

_slot = Decoder(Slot)
_metrics = Decoder(InterpolatorMetrics)


class Reporting:
    def __init__(self) -> None:
        self.now = 100.0
        self.bus = FakeBus()
        self.h = Harness()
        self.reports = Reports(self.bus, KEYS, GROUP, self.h.feeder, clock=lambda: self.now)

    def slots(self) -> list[Slot]:
        return [_slot.decode(data) for data in self.bus.published(SLOT_KEY)]

    def metrics(self) -> list[InterpolatorMetrics]:
        return [_metrics.decode(data) for data in self.bus.published(METRICS_KEY)]

    def sending(self) -> None:
        """Into a segment waiting for room."""
        self.h.queue(state(depth=190))
        self.h.feed(point(1, 0, 0.0), point(2, 1, 0.4, X))

    def room(self) -> None:
        self.h.queue(state(depth=0))

    def a_pass(self, at: float, progress: Callable[[], None] = lambda: None) -> None:
        """A pass of the loop at ``at``, in which the feeder does ``progress``."""
        self.now = at
        self.reports.before_progress()
        progress()
        self.reports.after_progress()


@pytest.fixture
def r() -> Reporting:
    return Reporting()


def test_the_slots_and_metrics_publishers(r: Reporting) -> None:
    slot, metrics = r.bus.publications[SLOT_KEY], r.bus.publications[METRICS_KEY]
    assert (slot.realtime, slot.latest) == (True, False)  # every slot matters
    assert (metrics.realtime, metrics.latest) == (False, True)


def test_the_slot_is_published_when_it_changes_and_only_then(r: Reporting) -> None:
    r.a_pass(100.0)
    assert r.slots() == [Slot(0, 0)]
    r.a_pass(100.1)
    assert r.slots() == [Slot(0, 0)]
    r.h.queue(state(epoch=3))
    r.h.feed(point(1, 0, 0.0))
    r.a_pass(100.2)
    assert r.slots() == [Slot(0, 0), Slot(1, 3, 1, 0, trajectory_id=1)]


def test_a_query_is_answered_with_the_slot_last_published(r: Reporting) -> None:
    assert _slot.decode(r.bus.query(SLOT_KEY)) == Slot(0, 0)  # before the first pass
    r.h.queue(state(epoch=3))
    assert _slot.decode(r.bus.query(SLOT_KEY)) == Slot(0, 0)  # changed, not yet published
    r.a_pass(100.1)
    assert _slot.decode(r.bus.query(SLOT_KEY)) == Slot(0, 3)


def test_metrics_are_sent_every_metrics_s_while_observed(r: Reporting) -> None:
    r.a_pass(100.0 + METRICS_S / 2)
    r.bus.publications[METRICS_KEY].subscribed = True
    assert r.metrics() == []  # not due yet
    r.a_pass(100.0 + METRICS_S)
    assert r.metrics() == [InterpolatorMetrics(0, 0, 0.0, 0)]
    r.a_pass(100.0 + METRICS_S * 1.5)
    assert len(r.metrics()) == 1
    r.bus.publications[METRICS_KEY].subscribed = False
    r.a_pass(100.0 + METRICS_S * 2)
    assert len(r.metrics()) == 1  # nobody listens: nothing made
    r.bus.publications[METRICS_KEY].subscribed = True
    r.a_pass(100.0 + METRICS_S * 2.5)
    assert len(r.metrics()) == 1  # due again only a METRICS_S after the last
    r.a_pass(100.0 + METRICS_S * 3)
    assert len(r.metrics()) == 2


def test_the_time_the_slot_was_full_is_counted_while_a_segment_is_being_sent(
    r: Reporting,
) -> None:
    r.a_pass(100.25, r.sending)
    r.a_pass(100.5)  # full since the pass before
    r.a_pass(100.75, r.room)  # full until this pass sent the rest
    r.a_pass(101.0)
    r.a_pass(101.5)
    r.bus.publications[METRICS_KEY].subscribed = True
    r.a_pass(102.0)
    [metrics] = r.metrics()
    assert metrics.slot_busy_s == pytest.approx(0.5)
    assert metrics.busy_episodes == 1
    assert (metrics.points_accepted, metrics.increments_sent) == (2, 100)


def test_close_stops_answering(r: Reporting) -> None:
    r.reports.close()
    assert r.bus.answers[SLOT_KEY].undeclared
