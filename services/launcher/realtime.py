"""One line in ``motocell up``'s output when the cell's clock runs without real-time priority,
with the command that lets it: the executor's own warning scrolls by among every service's
start-up lines, and without SCHED_FIFO the clock misses periods under load (docs/realtime.md).

The executor says in every ``ExecutorMetrics`` whether it got SCHED_FIFO; the launcher reads the
first from a one-sample channel while it looks after its starting cell, so no Python runs on
Zenoh's threads for it, then unsubscribes.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import zenoh

from motocell.shared.bus.channels import newest
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, ExecutorMetrics
from motocell.shared.realtime import ELSEWHERE, RT_PRIORITY, fix_command

log = logging.getLogger("motocell")

_metrics = Decoder(ExecutorMetrics)


class RealtimeNotice:
    def __init__(
        self, session: zenoh.Session, keys: CellKeys, executor_pid: Callable[[], int | None]
    ) -> None:
        """``executor_pid``: the executor this launcher runs, None if it runs none (--skip)."""
        self._samples: zenoh.Subscriber[Any] = session.declare_subscriber(
            keys.metrics("executor"), zenoh.handlers.RingChannel(1)
        )
        self._executor_pid = executor_pid
        self.heard = False
        """The executor's first metrics arrived: whether it runs SCHED_FIFO is known."""

    def check(self) -> bool:
        """Tell once, if the executor's first report says it runs without SCHED_FIFO; never
        waits. Whether the report came (then the subscription ends: the executor publishes
        metrics only while someone subscribes)."""
        if self.heard:
            return True
        metrics = newest(self._samples, _metrics)
        if metrics is None:
            return False
        self.heard = True
        self._samples.undeclare()
        if not metrics.realtime:
            pid = self._executor_pid()
            log.warning(
                "the executor runs WITHOUT real-time priority (SCHED_FIFO %d refused) and will "
                "miss periods under load; to allow it: %s; then start the cell again",
                RT_PRIORITY,
                ELSEWHERE if pid is None else fix_command(pid),
            )
        return True

    def close(self) -> None:
        if not self.heard:
            self._samples.undeclare()
