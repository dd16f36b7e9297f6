"""One line in ``motocell up``'s output when the cell runs without the priorities it asks for,
with the command that allows them: the executor's clock without SCHED_FIFO misses periods under
load, and the other threads without SCHED_RR can be starved by ordinary load into stopping
motion (docs/realtime.md). The services' own warnings would be eight lines scrolling by among
every service's start-up lines; under a launcher they keep quiet and this says it once.

The launcher asks for the services' priority first, for itself (its router's threads, and the
children it starts inherit it; each asks again, the same way, in ``shared.service``): what it
gets, they get. The executor says in every ``ExecutorMetrics`` whether its clock got SCHED_FIFO;
the launcher reads the first from a one-sample channel while it looks after its starting cell,
so no Python runs on Zenoh's threads for it, then unsubscribes, and says both in one line.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import zenoh

from motocell.shared.bus.channels import newest
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, ExecutorMetrics
from motocell.shared.realtime import ELSEWHERE, RT_PRIORITY, SERVICE_PRIORITY, fix_command

log = logging.getLogger("motocell")

_metrics = Decoder(ExecutorMetrics)


def refused_line(*, clock: bool, services: bool, command: str) -> str | None:
    """What ``motocell up`` says when the executor's ``clock`` or the cell's ``services`` (their
    every thread, the launcher's router too) were refused their priority; None when neither."""
    then = f"to allow it: {command}; then start the cell again"
    starved = "ordinary load can starve them into stopping motion"
    if clock and services:
        return (
            f"the executor runs WITHOUT real-time priority (SCHED_FIFO {RT_PRIORITY} refused) "
            "and will miss periods under load, and the cell's services without theirs "
            f"(SCHED_RR {SERVICE_PRIORITY} refused): {starved}; {then}"
        )
    if clock:
        return (
            f"the executor runs WITHOUT real-time priority (SCHED_FIFO {RT_PRIORITY} refused) "
            f"and will miss periods under load; {then}"
        )
    if services:
        return (
            "the cell's services run WITHOUT real-time priority "
            f"(SCHED_RR {SERVICE_PRIORITY} refused): {starved}; {then}"
        )
    return None


class RealtimeNotice:
    def __init__(
        self,
        session: zenoh.Session,
        keys: CellKeys,
        executor_pid: Callable[[], int | None],
        *,
        services_realtime: bool,
        executor_here: bool,
    ) -> None:
        """``executor_pid``: the executor this launcher runs, None if it runs none (--skip);
        ``services_realtime``: whether this launcher got SCHED_RR, and so its services.
        Without an executor here there is no report to wait for: a refusal is said now."""
        self._samples: zenoh.Subscriber[Any] = session.declare_subscriber(
            keys.metrics("executor"), zenoh.handlers.RingChannel(1)
        )
        self._executor_pid = executor_pid
        self._services_refused = not services_realtime
        if not executor_here:
            self._say(clock=False)
        self.heard = False
        """The executor's first metrics arrived: whether it runs SCHED_FIFO is known."""

    def check(self) -> bool:
        """Tell once, if the executor's first report says it runs without SCHED_FIFO or the
        services run without SCHED_RR; never waits. Whether the report came (then the
        subscription ends: the executor publishes metrics only while someone subscribes)."""
        if self.heard:
            return True
        metrics = newest(self._samples, _metrics)
        if metrics is None:
            return False
        self.heard = True
        self._samples.undeclare()
        self._say(clock=not metrics.realtime)
        return True

    def _say(self, *, clock: bool) -> None:
        pid = self._executor_pid() if clock else None
        command = fix_command(pid or "self")
        if clock and pid is None:  # an executor elsewhere: its process is not ours to look at
            command = ELSEWHERE
        line = refused_line(clock=clock, services=self._services_refused, command=command)
        self._services_refused = False  # said, or about to be said with the clock's
        if line is not None:
            log.warning(line)

    def close(self) -> None:
        if not self.heard:
            self._samples.undeclare()
