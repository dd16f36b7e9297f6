"""A rate on another clock's instants: the first instant at or after each due time.

The broadcaster sends state on the executor's ticks and the ROS 2 face publishes on the state's
samples, each at its own period: a sample leaves the moment it arrives (no wait for a second
clock), and the rate is exact on average even when the period is not a whole number of the
other clock's steps (10 ms on 4 ms ticks: 8 and 12 ms alternately).
"""

from __future__ import annotations


class Schedule:
    """Whether an instant (CLOCK_MONOTONIC ns of the other clock) is due: the first at or after
    each due time, every ``period_ns``; one that falls behind restarts the grid rather than
    bursting to catch up."""

    def __init__(self, period_ns: int) -> None:
        self.period_ns = period_ns
        self.next_due: int | None = None

    def due(self, tick_ns: int) -> bool:
        if self.next_due is None:
            self.next_due = tick_ns
        if tick_ns < self.next_due:
            return False
        self.next_due += self.period_ns
        if self.next_due <= tick_ns:
            self.next_due = tick_ns + self.period_ns  # fell behind: no burst to catch up
        return True
