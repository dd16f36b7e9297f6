"""One group's ring of increments, as the executor keeps it. Pure.

Each group has a 200-entry ring (MotoROS Q_SIZE, motoros1 §3.1). Entries arrive in numbered
batches; the ring's *epoch* changes whenever it is cleared, so batches produced for a cleared
trajectory are recognised and dropped instead of moving the robot.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from motocell.shared.bus.schemas import IncrementBatch
from motocell.shared.protocol.constants import MAX_AXES

RING_CAPACITY = 200
ZERO = (0,) * MAX_AXES


@dataclass(frozen=True)
class Entry:
    increments: tuple[int, ...]
    partial: bool
    tool: int
    sync_id: int = 0
    """Non-zero on the first entry of a trajectory that starts together with ``sync_groups``."""
    sync_groups: tuple[int, ...] = ()


class BatchOutcome(Enum):
    ACCEPTED = "accepted"
    STALE = "stale"
    """For an older epoch: the trajectory it belongs to was cleared."""
    DUPLICATE = "duplicate"
    GAP = "gap"
    """Entries are missing before this batch."""
    OVERFLOW = "overflow"
    NOT_READY = "not ready"
    MALFORMED = "malformed"
    """Sizes that do not add up (or a payload that does not decode): treated like a gap,
    never allowed to crash the clock."""

    @property
    def breaks_increment_path(self) -> bool:
        """Entries were lost or cannot be taken: motion must stop, since what follows them
        would move the robot along a path nobody commanded."""
        return self in (BatchOutcome.GAP, BatchOutcome.OVERFLOW, BatchOutcome.MALFORMED)


def malformed(batch: IncrementBatch) -> bool:
    return (
        batch.count < 0
        or batch.first_seq < 0
        or len(batch.increments) != batch.count * MAX_AXES * 4
        or len(batch.times_ns) not in (0, batch.count)
        or any(not 0 <= index < batch.count for index in batch.partial)
    )


@dataclass
class GroupRing:
    epoch: int
    received: int = 0
    entries: deque[Entry] = field(default_factory=deque)
    promised: int = 0
    """The highest point (``Point.point_id``, sequence > 0) the gateway published for this
    epoch: its entries are owed to this ring."""
    through: int = 0
    """The highest point whose entries have all arrived (``IncrementBatch.through``)."""
    starved_ticks: int = 0
    """Ticks in a row this ring was empty while owed."""

    @property
    def owed(self) -> bool:
        return self.promised > self.through

    def clear(self, epoch: int) -> None:
        """Empty, forgetting what was owed, under a new epoch."""
        self.entries.clear()
        self.epoch = epoch
        self.received = 0
        self.promised = self.through = 0
        self.starved_ticks = 0

    def check(self, batch: IncrementBatch) -> BatchOutcome:
        """Whether ``batch`` (for this epoch, while ready) continues the ring exactly."""
        if malformed(batch):
            return BatchOutcome.MALFORMED
        if batch.first_seq + batch.count <= self.received:
            return BatchOutcome.DUPLICATE
        if batch.first_seq != self.received:
            return BatchOutcome.GAP
        if len(self.entries) + batch.count > RING_CAPACITY:
            return BatchOutcome.OVERFLOW
        return BatchOutcome.ACCEPTED

    def append(self, batch: IncrementBatch) -> None:
        """Queue a batch that ``check`` accepted."""
        rows = np.frombuffer(batch.increments, dtype="<i4").reshape(batch.count, MAX_AXES)
        partial = set(batch.partial)
        for index, row in enumerate(rows.tolist()):
            if index == 0 and batch.sync_id:
                entry = Entry(
                    tuple(row),
                    index in partial,
                    batch.tool,
                    batch.sync_id,
                    tuple(batch.sync_groups),
                )
            else:
                entry = Entry(tuple(row), index in partial, batch.tool)
            self.entries.append(entry)
        self.received += batch.count
        self.through = max(self.through, batch.through)

    def pop_period(self) -> tuple[int, ...]:
        """Pop the head entry and, while the last popped is a partial period (an off-grid
        waypoint), the next one too, so every tick moves one full period (motoros1 §5.3
        merge)."""
        if not self.entries:
            return ZERO
        entry = self.entries.popleft()
        total = list(entry.increments)
        while (
            entry.partial
            and self.entries
            and self.entries[0].tool == entry.tool
            and not self.entries[0].sync_id
        ):
            entry = self.entries.popleft()
            for axis in range(MAX_AXES):
                total[axis] += entry.increments[axis]
        return tuple(total)
