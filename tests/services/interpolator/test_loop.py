"""The interpolator's pass, without Zenoh: inputs scripted pass by pass, a real feeder, the real
reports on a scripted bus. What a pass must do in order: the newest queue state before the
points of the same pass, the points kept up to the limit, the slot published in the pass that
took a point, and a wait for the ring only when only a queue state can let the feeder go on."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass, field

import pytest

from motocell.services.interpolator.core.feeder import MAX_BATCH
from motocell.services.interpolator.core.states import Phase
from motocell.services.interpolator.loop import FeederLoop
from motocell.services.interpolator.reports import Reports
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import (
    ControllerStatus,
    Decoder,
    IncrementBatch,
    Point,
    QueueState,
    Slot,
)
from motocell.shared.service import StopFlag
from motocell.testing.statuses import ready_status
from tests.services.interpolator.core.test_feeder import (
    Harness,
    X,
    Y,
    point,
    pulses,
    state,
    total,
)
from tests.services.interpolator.fake_bus import FakeBus

KEYS = CellKeys("cell1")
GROUP = 0
LIMIT = 3
"""Points that may wait for the feeder (``Cell.points_outstanding``)."""

_slot = Decoder(Slot)


@dataclass
class Pass:
    """What one wait returns with."""

    status: ControllerStatus | None = None
    queue: QueueState | None = None
    points: list[Point] = field(default_factory=list)


class ScriptedInputs:
    """An ``InputFeed`` that gives one scripted pass per wait, and records each wait."""

    def __init__(self) -> None:
        self.passes: list[Pass] = []
        self.waits: list[tuple[bool, float]] = []
        self.stop_after = -1
        """Set ``stop`` once this many waits have returned."""
        self.stop = StopFlag()
        self._now = Pass()

    def wait(self, for_ring: bool, deadline: float) -> None:
        self.waits.append((for_ring, deadline))
        self._now = self.passes.pop(0)
        if len(self.waits) == self.stop_after:
            self.stop.set()

    def status(self) -> ControllerStatus | None:
        return self._now.status

    def queue(self) -> QueueState | None:
        return self._now.queue

    def points(self) -> Iterator[Point]:
        yield from self._now.points


class Looping:
    def __init__(self) -> None:
        self.bus = FakeBus()
        self.h = Harness()
        self.inputs = ScriptedInputs()
        self.reports = Reports(self.bus, KEYS, GROUP, self.h.feeder, clock=lambda: 0.0)
        self.loop = FeederLoop(self.h.feeder, self.inputs, self.reports, LIMIT)

    @property
    def sent(self) -> list[IncrementBatch]:
        return self.h.sent

    def step(
        self,
        status: ControllerStatus | None = None,
        queue: QueueState | None = None,
        *points: Point,
    ) -> None:
        self.inputs.passes.append(Pass(status, queue, list(points)))
        self.loop.step()

    def slots(self) -> list[Slot]:
        return [_slot.decode(data) for data in self.bus.published(KEYS.group_slot(GROUP))]


@pytest.fixture
def looping() -> Looping:
    return Looping()


def test_the_slot_is_published_in_the_pass_that_took_the_point(looping: Looping) -> None:
    looping.step(None, state(epoch=4))
    assert looping.slots() == [Slot(0, 4)]
    looping.step(None, None, point(1, 0, 0.0))
    assert looping.slots()[-1] == Slot(1, 4, 1, 0, trajectory_id=1)
    looping.step(None, None, point(2, 1, 0.1, X))
    assert looping.slots()[-1] == Slot(2, 4, 2, 25, trajectory_id=1)
    assert [b.through for b in looping.sent] == [2]


def test_a_cleared_ring_is_applied_before_the_points_of_the_same_pass(looping: Looping) -> None:
    looping.step(None, state(epoch=1, depth=150), point(1, 0, 0.0), point(2, 1, 0.4, X))
    assert [(b.epoch, b.first_seq, b.count) for b in looping.sent] == [(1, 0, MAX_BATCH)]
    stopped_at = [1000, 2000, 3000, 4000, 5000, 6000, 0, 0]
    # The gateway checked the new trajectory against the new ring: the points carry its epoch.
    new_start = Point(3, 0, 10.0, X, [0.0] * 6, epoch=2)
    new_next = Point(4, 1, 10.1, Y, [0.0] * 6, epoch=2)
    looping.step(None, state(epoch=2, command=stopped_at), new_start, new_next)
    assert [(b.epoch, b.first_seq, b.count) for b in looping.sent[1:]] == [(2, 0, 25)]
    assert total(looping.sent[1:]) == [y - s for y, s in zip(pulses(Y), stopped_at, strict=True)]
    assert looping.slots()[-1] == Slot(4, 2, 4, MAX_BATCH + 25, trajectory_id=3)


def test_a_point_beyond_the_limit_is_dropped_and_logged(
    looping: Looping, caplog: pytest.LogCaptureFixture
) -> None:
    looping.step(None, state(depth=190), point(1, 0, 0.0), point(2, 1, 0.4, X))
    assert looping.h.feeder.phase is Phase.SENDING  # no room: the slot stays full
    # Type-14 sequence-0 points never get BUSY: a client may send more than may wait.
    starts = [point(n, 0, float(n)) for n in range(3, 3 + LIMIT + 1)]
    looping.step(None, None, *starts)
    assert list(looping.loop.points) == starts[:LIMIT]
    assert [r.levelno for r in caplog.records] == [logging.ERROR]
    assert f"more than {LIMIT} points pending; dropping {starts[-1]}" in caplog.text


def test_it_waits_for_the_ring_only_when_only_a_queue_state_can_help(looping: Looping) -> None:
    looping.step()  # nothing yet: a point may come
    looping.step(None, None, point(1, 0, 0.0))  # no queue state to check it against
    looping.step(None, state(depth=190))  # taken
    looping.step(None, None, point(2, 1, 0.4, X))  # no room
    looping.step(None, state(depth=0))  # room: all sent
    looping.step(None, None, Point(3, 0, 5.0, X, [0.0] * 6, epoch=2))  # checked against epoch 2
    looping.step()
    assert [for_ring for for_ring, _ in looping.inputs.waits] == [
        False,
        False,
        True,
        False,
        True,
        False,
        True,
    ]
    assert {deadline for _, deadline in looping.inputs.waits} == {looping.reports.next_metrics}


def test_a_status_sets_the_tool_of_the_segments_to_come(looping: Looping) -> None:
    looping.step(ready_status(seq=0, tools=[6]), state(), point(1, 0, 0.0), point(2, 1, 0.1, X))
    assert [b.tool for b in looping.sent] == [6]


def test_it_runs_until_stopped(looping: Looping) -> None:
    looping.inputs.passes = [Pass(queue=state()), Pass(points=[point(1, 0, 0.0)]), Pass()]
    looping.inputs.stop_after = 2
    looping.loop.run(looping.inputs.stop)
    assert len(looping.inputs.waits) == 2
    assert looping.slots()[-1].taken_id == 1
