"""Which missed periods the clock announces, and when: the first at once, the rest gathered.

A tick that comes a whole period or more after its deadline has missed a period (the clock
catches up, so the simulated motion never slips; docs/realtime.md says why this machine's timers
come late). Whoever watches the cell learns of it as it happens: the first late tick is
announced at once, and later ones within ``QUIET_NS`` of an announcement are gathered into the
next, so a machine that makes every tick late costs one sample and one log line a second, not
one per tick.
"""

from __future__ import annotations

from motocell.shared.bus.schemas import LateTicks

QUIET_NS = 1_000_000_000
"""At most one announcement per this long."""


class LateTickTally:
    """Late ticks not yet announced, and when the next announcement may go."""

    def __init__(self) -> None:
        self._periods = 0
        self._worst: tuple[int, int, int] = (0, 0, 0)
        """(lateness_ns, tick, deadline_ns) of the latest tick of the worst lateness."""
        self._quiet_until_ns = 0

    def count(
        self, tick: int, deadline_ns: int, lateness_ns: int, missed_total: int, now_ns: int
    ) -> LateTicks | None:
        """A tick ``lateness_ns`` late (a period or more): the announcement to make now, if
        the last one was at least ``QUIET_NS`` ago."""
        self._periods += 1
        if lateness_ns >= self._worst[0]:
            self._worst = (lateness_ns, tick, deadline_ns)
        return self.due(missed_total, now_ns)

    def due(self, missed_total: int, now_ns: int) -> LateTicks | None:
        """The gathered late ticks, if any and the quiet time has passed."""
        if self._periods == 0 or now_ns < self._quiet_until_ns:
            return None
        lateness_ns, tick, deadline_ns = self._worst
        announcement = LateTicks(
            tick=tick,
            deadline_ns=deadline_ns,
            lateness_ns=lateness_ns,
            periods=self._periods,
            missed_total=missed_total,
        )
        self._periods = 0
        self._worst = (0, 0, 0)
        self._quiet_until_ns = now_ns + QUIET_NS
        return announcement
