"""Whether each cell's clock runs SCHED_FIFO, for ``motocell ps`` and ``motocell watch``: a clock
without it misses periods under load (docs/realtime.md, Why SCHED_FIFO), so the tools say so
loudly, with the command that lets it (docs/realtime.md).

The executor reports it in its metrics, once a second; ``ps`` waits that long at most for the
executors it found alive.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterable

import msgspec
import zenoh

from motocell.shared.bus.keys import ROOT
from motocell.shared.bus.schemas import Decoder, ExecutorMetrics, ServiceInfo
from motocell.shared.realtime import ELSEWHERE, fix_command

METRICS_WAIT_S = 1.5
"""The executor publishes its metrics every second."""
NOT_REALTIME = "WITHOUT real-time priority (SCHED_FIFO refused): it misses periods under load"

_metrics = Decoder(ExecutorMetrics)


class ClockModes:
    """The newest ``ExecutorMetrics.realtime`` of every cell that ``follow`` covers."""

    def __init__(self) -> None:
        self.realtime: dict[str, bool] = {}
        self._changed = threading.Condition()
        self._subscribers: list[zenoh.Subscriber[None]] = []

    def follow(self, session: zenoh.Session, names: Iterable[str]) -> None:
        """``names``: cell names, or ``*`` for every cell on an open bus."""
        self._subscribers += [
            session.declare_subscriber(f"{ROOT}/{name}/executor/metrics", self._on_sample)
            for name in names
        ]

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            realtime = _metrics.decode(sample.payload.to_bytes()).realtime
        except msgspec.DecodeError:
            return
        with self._changed:
            self.realtime[str(sample.key_expr).split("/")[1]] = realtime
            self._changed.notify_all()

    def wait_for(self, cells: set[str], timeout: float = METRICS_WAIT_S) -> dict[str, bool]:
        """What is known of ``cells`` once all have reported, or after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while not cells <= self.realtime.keys():
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._changed.wait(left)
            return {cell: self.realtime[cell] for cell in cells if cell in self.realtime}

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()


def fix_for(info: ServiceInfo | None) -> str:
    """The command that lets the executor ``info`` describes run SCHED_FIFO, if it runs on this
    machine."""
    if info is not None and info.host == socket.gethostname():
        return fix_command(info.pid)
    return ELSEWHERE
