"""What the executor publishes, its ``OutputPort`` over the ``Bus``: each tick, the queue states,
its notices to the controller, the periods its clock missed, its metrics (only while someone
subscribes), and its answers to STOP_MOTION."""

from __future__ import annotations

from collections.abc import Iterable

from motocell.services.executor.bus import Bus, Query
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import (
    CommandReply,
    ExecutorMetrics,
    LateTicks,
    QueueState,
    Tick,
    encode,
)
from motocell.shared.protocol.constants import Result


class Outputs:
    def __init__(self, bus: Bus, keys: CellKeys, groups: int) -> None:
        self._tick = bus.publisher(keys.executor_tick, realtime=True, latest=True)
        self._queues = [
            bus.publisher(keys.group_queue(g), realtime=True, latest=True) for g in range(groups)
        ]
        # Every notice matters (a stall, a broken increment path): it blocks rather than drops.
        self._notices = bus.publisher(keys.controller_cmd("incmove_error"), realtime=True)
        self._metrics = bus.publisher(keys.metrics("executor"), latest=True)
        # At most one a second, so sent whether or not anyone listens; dropped rather than
        # block the clock (the next one carries the total).
        self._late = bus.publisher(keys.executor_late, latest=True)

    def tick(self, tick: Tick) -> None:
        self._tick.put(encode(tick))

    def queues(self, updates: Iterable[tuple[int, QueueState]]) -> None:
        for group, state in updates:
            self._queues[group].put(encode(state))

    def notices(self, replies: Iterable[CommandReply]) -> None:
        for reply in replies:
            self._notices.put(encode(reply))

    def late(self, late: LateTicks) -> None:
        self._late.put(encode(late))

    def metrics_wanted(self) -> bool:
        """Whether anyone subscribes to the metrics: nothing is summarised for nobody."""
        return self._metrics.observed()

    def metrics(self, metrics: ExecutorMetrics) -> None:
        self._metrics.put(encode(metrics))

    @staticmethod
    def stopped(queries: Iterable[Query]) -> None:
        """STOP_MOTION done: the rings were cleared before the next tick."""
        for query in queries:
            query.answer(CommandReply(Result.SUCCESS))
