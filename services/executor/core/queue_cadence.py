"""When each group's queue state goes out: at once when it says something new, every
``DRAINING_EVERY_TICKS`` while its ring only drains, and all of them at the heartbeat. Pure."""

from __future__ import annotations

from collections.abc import Sequence

from motocell.services.executor.core.rings import GroupRing

DRAINING_EVERY_TICKS = 10
"""While a ring only drains (its depth and the command change, nothing else), its queue state
goes out every this many ticks (40 ms at 4 ms) instead of every tick: its readers act on room
for a batch of entries (the interpolator, which fills the ring in batches of up to 50) or
count entries a fifth of a second deep (the gateway), and a few entries' staleness only errs
towards waiting; epochs, arrivals, readiness and a ring that ran dry still go out at once.
Every 10 rather than 5 ticks: the interpolators wake about a third less, and no figure is worse
(measured: docs/realtime.md, "Zenoh's threads")."""

Content = tuple[int, int, int, list[int], bool, int]
"""What a queue state says, compared before one is built (most ticks build none): the ring's
epoch, what it received, its depth, the commanded pulses, readiness, the heartbeat."""


class QueueCadence:
    """Which of ``rings``' queue states are due, given what each said when it last went out."""

    def __init__(self, rings: Sequence[GroupRing]) -> None:
        self._rings = rings
        self._published: list[Content | None] = [None] * len(rings)
        self._published_at = [0] * len(rings)
        """The tick each group's queue state last went out."""
        self.next_heartbeat_ns = 0
        """When every queue state goes out again, changed or not."""

    def restart_heartbeat(self) -> None:
        """The heartbeat changed (the clock started or stopped resting): every queue state goes
        out at the next look, announcing the new one."""
        self.next_heartbeat_ns = 0

    def due(
        self,
        now_ns: int,
        tick: int,
        command: Sequence[list[int]],
        ready: bool,
        heartbeat_ms: int,
        *,
        force: bool = False,
    ) -> list[int]:
        """The groups whose queue state goes out now (all of them at the heartbeat or when
        ``force``d), taken as published at ``tick``. ``command``: the commanded pulses, one row
        per group, each replaced rather than changed when it moves, so it can be kept to compare
        with."""
        heartbeat = force or now_ns >= self.next_heartbeat_ns
        if heartbeat:
            self.next_heartbeat_ns = now_ns + heartbeat_ms * 1_000_000
        published, published_at = self._published, self._published_at
        due = []
        for group, ring in enumerate(self._rings):
            content = (
                ring.epoch,
                ring.received,
                len(ring.entries),
                command[group],
                ready,
                heartbeat_ms,
            )
            last = published[group]
            if not heartbeat and last is not None:
                if content == last:
                    continue
                draining = (  # only the depth and the command changed, and the ring is not dry
                    content[:2] == last[:2] and content[4:] == last[4:] and content[2] != 0
                )
                if draining and tick - published_at[group] < DRAINING_EVERY_TICKS:
                    continue
            published[group] = content
            published_at[group] = tick
            due.append(group)
        return due
