"""``QueueCadence``: a queue state goes out at once when it says something new, every
``DRAINING_EVERY_TICKS`` while its ring only drains, at once when the ring runs dry, and every
group's at the heartbeat or when forced. How the core uses it:
tests/services/executor/core/test_executor.py ("what the adapter sends")."""

from __future__ import annotations

from motocell.services.executor.core.queue_cadence import DRAINING_EVERY_TICKS, QueueCadence
from motocell.services.executor.core.rings import ZERO, Entry, GroupRing

MS = 1_000_000
HEARTBEAT_MS = 100
COMMAND = [[0] * 8, [5] * 8]


class Cell:
    """Two rings, their commanded pulses and the cadence, looked at once per tick."""

    def __init__(self) -> None:
        self.rings = [GroupRing(10), GroupRing(11)]
        self.command = [list(row) for row in COMMAND]
        self.cadence = QueueCadence(self.rings)
        self.tick = 0
        self.ready = True
        self.heartbeat_ms = HEARTBEAT_MS

    def due(self, now_ns: int = 0, *, force: bool = False) -> list[int]:
        return self.cadence.due(
            now_ns, self.tick, self.command, self.ready, self.heartbeat_ms, force=force
        )

    def fill(self, group: int, entries: int) -> None:
        ring = self.rings[group]
        ring.entries.extend(Entry(ZERO, partial=False, tool=0) for _ in range(entries))
        ring.received += entries

    def drain(self, group: int) -> None:
        """One tick moves ``group`` by one entry: its depth and its command change."""
        self.rings[group].entries.popleft()
        self.command[group] = [pulse + 1 for pulse in self.command[group]]


def test_every_group_goes_out_at_the_first_look() -> None:
    assert Cell().due() == [0, 1]


def test_nothing_unchanged_goes_out_before_the_heartbeat() -> None:
    cell = Cell()
    cell.due(0)
    assert cell.cadence.next_heartbeat_ns == HEARTBEAT_MS * MS
    assert [cell.due(now) for now in range(MS, HEARTBEAT_MS * MS, 10 * MS)] == [[]] * 10
    assert cell.due(HEARTBEAT_MS * MS) == [0, 1]
    assert cell.cadence.next_heartbeat_ns == 2 * HEARTBEAT_MS * MS


def test_the_heartbeat_is_the_one_announced_when_it_went_out() -> None:
    cell = Cell()
    cell.heartbeat_ms = 1000
    cell.due(0)
    assert cell.cadence.next_heartbeat_ns == 1000 * MS


def test_an_arrival_goes_out_at_once_for_its_group_only() -> None:
    cell = Cell()
    cell.due(0)
    cell.fill(1, 3)
    assert cell.due(MS) == [1]
    assert cell.due(2 * MS) == []


def test_readiness_an_epoch_or_a_new_heartbeat_goes_out_at_once() -> None:
    cell = Cell()
    cell.due(0)
    cell.ready = False
    assert cell.due(MS) == [0, 1]
    cell.rings[0].clear(12)
    assert cell.due(2 * MS) == [0]
    cell.heartbeat_ms = 1000
    assert cell.due(3 * MS) == [0, 1]


def test_a_draining_ring_goes_out_every_few_ticks_and_at_once_when_dry() -> None:
    cell = Cell()
    cell.fill(0, 25)
    cell.due(0)
    published = []
    for tick in range(1, 28):
        cell.tick = tick
        if cell.rings[0].entries:
            cell.drain(0)
        if cell.due(tick * MS) == [0]:
            published.append((tick, len(cell.rings[0].entries)))
    assert published == [(DRAINING_EVERY_TICKS, 15), (2 * DRAINING_EVERY_TICKS, 5), (25, 0)]


def test_a_command_that_moves_with_an_empty_ring_goes_out_at_once() -> None:
    """A dry ring is not draining: what the servo brake sets goes out at the next look."""
    cell = Cell()
    cell.due(0)
    cell.command[1] = [6] * 8
    assert cell.due(MS) == [1]


def test_forced_or_restarted_every_group_goes_out() -> None:
    cell = Cell()
    cell.due(0)
    assert cell.due(MS, force=True) == [0, 1]
    cell.cadence.restart_heartbeat()
    assert cell.cadence.next_heartbeat_ns == 0
    assert cell.due(2 * MS) == [0, 1]
    assert cell.due(3 * MS) == []
