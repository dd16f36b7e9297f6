"""GroupRing: ordered batch acceptance within an epoch, a bound of 200 entries, partial periods
merged. Batches are built by hand (``test_core.batch``)."""

from __future__ import annotations

import msgspec
import pytest

from motocell.services.executor.core.rings import RING_CAPACITY, BatchOutcome, GroupRing
from motocell.shared.bus.schemas import IncrementBatch
from tests.services.executor.core.test_executor import batch, unit


def offer(ring: GroupRing, b: IncrementBatch) -> BatchOutcome:
    """What the core does with a batch for the ring's epoch while ready."""
    outcome = ring.check(b)
    if outcome is BatchOutcome.ACCEPTED:
        ring.append(b)
    return outcome


def popped(ring: GroupRing) -> list[int]:
    """Axis 0 of each period until the ring is empty."""
    moves = []
    while ring.entries:
        moves.append(ring.pop_period()[0])
    return moves


def test_batches_are_accepted_only_in_order() -> None:
    ring = GroupRing(100)
    first = batch(100, 0, [unit(1), unit(2), unit(3)])
    assert offer(ring, first) is BatchOutcome.ACCEPTED
    assert offer(ring, first) is BatchOutcome.DUPLICATE
    assert offer(ring, batch(100, 1, [unit(2), unit(3)])) is BatchOutcome.DUPLICATE
    assert offer(ring, batch(100, 4, [unit(5)])) is BatchOutcome.GAP
    assert (ring.received, len(ring.entries)) == (3, 3)
    assert offer(ring, batch(100, 3, [unit(4)])) is BatchOutcome.ACCEPTED
    assert offer(ring, batch(100, 4, [unit(5)])) is BatchOutcome.ACCEPTED
    assert popped(ring) == [1, 2, 3, 4, 5]


def test_refused_batches_leave_the_ring_as_it_was() -> None:
    ring = GroupRing(100)
    offer(ring, batch(100, 0, [unit(7)] * 4))
    for b in (batch(100, 0, [unit(9)] * 2), batch(100, 5, [unit(9)])):
        assert offer(ring, b) is not BatchOutcome.ACCEPTED
        assert (ring.received, len(ring.entries)) == (4, 4)
    assert popped(ring) == [7, 7, 7, 7]


def test_ring_holds_exactly_200_entries() -> None:
    ring = GroupRing(100)
    for i in range(4):
        assert offer(ring, batch(100, 50 * i, [unit(1)] * 50)) is BatchOutcome.ACCEPTED
    assert len(ring.entries) == RING_CAPACITY
    assert offer(ring, batch(100, 200, [unit(1)])) is BatchOutcome.OVERFLOW
    assert (ring.received, len(ring.entries)) == (200, 200)
    ring.pop_period()
    assert offer(ring, batch(100, 200, [unit(1)] * 2)) is BatchOutcome.OVERFLOW
    assert offer(ring, batch(100, 200, [unit(1)])) is BatchOutcome.ACCEPTED
    assert len(ring.entries) == RING_CAPACITY


def test_single_batch_larger_than_the_ring_overflows() -> None:
    ring = GroupRing(100)
    assert offer(ring, batch(100, 0, [unit(1)] * 201)) is BatchOutcome.OVERFLOW
    assert ring.received == 0
    assert offer(ring, batch(100, 0, [unit(1)] * 200)) is BatchOutcome.ACCEPTED


@pytest.mark.parametrize(
    "change",
    [
        {"count": 3},
        {"count": -1},
        {"first_seq": -5},
        {"partial": [7]},
        {"increments": b"\x00" * 31},
        {"times_ns": [1, 2, 3]},
    ],
)
def test_malformed_batches_are_refused_not_crashed_on(change: dict[str, object]) -> None:
    ring = GroupRing(100)
    good = batch(100, 0, [unit(1), unit(2)])
    assert offer(ring, msgspec.structs.replace(good, **change)) is BatchOutcome.MALFORMED
    assert not ring.entries
    assert offer(ring, good) is BatchOutcome.ACCEPTED


@pytest.mark.parametrize("outcome", list(BatchOutcome))
def test_only_lost_or_unusable_entries_break_the_increment_path(outcome: BatchOutcome) -> None:
    breaking = {BatchOutcome.GAP, BatchOutcome.OVERFLOW, BatchOutcome.MALFORMED}
    assert outcome.breaks_increment_path is (outcome in breaking)


def test_clearing_starts_a_new_epoch_with_nothing_owed() -> None:
    ring = GroupRing(100)
    offer(ring, msgspec.structs.replace(batch(100, 0, [unit(1)] * 3), through=2))
    ring.promised = 5
    ring.clear(101)
    assert (ring.epoch, ring.received, len(ring.entries), ring.owed) == (101, 0, 0, False)
