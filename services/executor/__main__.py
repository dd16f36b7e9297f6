"""The executor: the controller's interpolation clock.

Every period (4 ms by default) on an absolute CLOCK_MONOTONIC deadline it takes one increment
per group from the rings and applies them together, then publishes the tick and each group's
queue state. SCHED_FIFO where permitted: on a 2-core machine ordinary scheduling misses 4 ms
deadlines even idle, FIFO missed none in measurements (zenoh-facts §5).
"""

from __future__ import annotations

import gc
import logging
import os
import threading
import time
from collections.abc import Sequence

import numpy as np
import zenoh

from services.executor.core import BatchOutcome, ExecutorCore
from shared.bus.schemas import (
    CommandReply,
    ControllerStatus,
    Decoder,
    ExecutorMetrics,
    IncrementBatch,
    QueueState,
    Tick,
    encode,
)
from shared.bus.session import Inbox, Liveness, answer, call, command_of, payload_of, publisher
from shared.config import Cell
from shared.metrics import Window
from shared.motion.kinematics import AxisMap
from shared.protocol.constants import Result
from shared.service import ServiceContext, argument_parser, running_service

log = logging.getLogger("executor")

RT_PRIORITY = 50


def enter_realtime() -> bool:
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(RT_PRIORITY))
    except (PermissionError, OSError) as exc:
        log.warning(
            "running WITHOUT real-time priority (SCHED_FIFO %d refused: %s); expect missed "
            "periods under load. Run as root or grant CAP_SYS_NICE and an rtprio limit.",
            RT_PRIORITY,
            exc,
        )
        return False
    log.info("clock thread runs SCHED_FIFO priority %d", RT_PRIORITY)
    return True


def initial_pulses(ctx: ServiceContext) -> list[list[int]]:
    """Where the robot is: the controller remembers the last commanded pulses across an
    executor restart; without it, the cell file's initial positions."""
    reply = call(ctx.session, ctx.keys.controller_cmd("positions"), timeout=1.0)
    if (
        reply is not None
        and reply.result == Result.SUCCESS
        and len(reply.pulses) == len(ctx.cell.groups)
    ):
        log.info("resuming from the controller's last commanded position")
        return reply.pulses
    pulses = []
    for group in ctx.cell.groups:
        axis_map = AxisMap(group)
        pulses.append(axis_map.pad_moto(axis_map.ros_to_pulses(np.array(group.initial_position))))
    return pulses


class Executor:
    def __init__(self, ctx: ServiceContext) -> None:
        self.ctx = ctx
        cell: Cell = ctx.cell
        self.period_ns = cell.period_ns
        self.core = ExecutorCore(initial_pulses(ctx), first_epoch=time.time_ns() // 1000)
        self.lock = threading.Lock()
        self.inbox = Inbox()
        session = ctx.session
        keys = ctx.keys
        self.tick_pub = publisher(session, keys.executor_tick, realtime=True)
        self.queue_pubs = [
            publisher(session, keys.group_queue(g.index), realtime=True) for g in cell.groups
        ]
        batch_decoder = Decoder(IncrementBatch)
        self.subscribers = [
            session.declare_subscriber(
                keys.group_increments(g.index),
                self.inbox.feed(f"batch/{g.index}", payload_of(batch_decoder)),
            )
            for g in cell.groups
        ]
        self.subscribers.append(
            session.declare_subscriber(
                keys.controller_status,
                self.inbox.feed("status", payload_of(Decoder(ControllerStatus))),
            )
        )
        self.controller_alive = Liveness(session, keys.alive("controller", "0"))
        self.controller_key = keys.alive("controller", "0")
        self.queryables = [
            session.declare_queryable(keys.executor_cmd("stop"), self.on_stop),
            session.declare_queryable(keys.executor_cmd("queue_count"), self.on_queue_count),
        ]
        self.missed = 0
        self.status_ready = False
        self.ticks_per_second = max(1, round(1e9 / cell.period_ns))
        self.lateness = Window(self.ticks_per_second)
        self.metrics_pub = publisher(session, keys.metrics("executor"))

    # Queries are answered on Zenoh's thread under the lock: a STOP_MOTION must clear the
    # rings at once, not a tick later.
    def on_stop(self, query: zenoh.Query) -> None:
        with self.lock:
            self.core.clear_all()
            states = [self.core.queue_state(g) for g in range(len(self.queue_pubs))]
        self._publish_queues(states)
        answer(query, CommandReply(Result.SUCCESS))

    def on_queue_count(self, query: zenoh.Query) -> None:
        group = command_of(query).group
        with self.lock:
            if 0 <= group < len(self.core.rings):
                reply = CommandReply(Result.SUCCESS, self.core.queue_count(group))
            else:
                reply = CommandReply(Result.FAILURE, -1)
        answer(query, reply)

    def _publish_queues(self, states: Sequence[QueueState]) -> None:
        for pub, state in zip(self.queue_pubs, states, strict=True):
            pub.put(encode(state))

    def drain_inbox(self) -> None:
        while (item := self.inbox.get_nowait()) is not None:
            tag, payload = item
            if tag == "status":
                assert isinstance(payload, ControllerStatus)
                # Every status is applied in order, so a not-ready blip between two ticks
                # still clears the rings.
                self.status_ready = payload.motion_ready
                self.core.set_ready(self._ready())
                continue
            group = int(tag.split("/")[1])
            outcome = self.core.accept(group, payload)
            if outcome in (BatchOutcome.GAP, BatchOutcome.OVERFLOW):
                self._increment_path_broken(group, outcome)

    def _ready(self) -> bool:
        return self.status_ready and self.controller_key in self.controller_alive.present()

    def _increment_path_broken(self, group: int, outcome: BatchOutcome) -> None:
        log.error("group %d: increment batch %s; stopping motion", group, outcome.value)
        self.core.clear_all()
        self.ctx.session.put(
            self.ctx.keys.controller_cmd("incmove_error"),
            encode(CommandReply(Result.FAILURE, group, detail=outcome.value)),
        )

    def _publish_metrics(self, realtime: bool, depths: list[int]) -> None:
        """Once a second, the lateness of the ticks of the last second (issue: metrics)."""
        metrics = ExecutorMetrics(
            tick=self.core.tick,
            lateness=self.lateness.summary(),
            missed_total=self.missed,
            queue_depths=depths,
            realtime=realtime,
        )
        self.metrics_pub.put(encode(metrics))

    def run(self) -> None:
        realtime = enter_realtime()
        gc.collect()
        gc.freeze()
        period = self.period_ns
        deadline = time.monotonic_ns() + period
        stop = self.ctx.stop
        while not stop.is_set():
            now = time.monotonic_ns()
            if deadline > now:
                time.sleep((deadline - now) / 1e9)
                now = time.monotonic_ns()
            lateness = now - deadline
            if lateness >= period:
                # Catch up instead of skipping: simulated motion never slips, the miss is counted.
                self.missed += 1
            with self.lock:
                self.drain_inbox()
                self.core.set_ready(self._ready())
                self.core.step()
                tick = Tick(
                    tick=self.core.tick,
                    deadline_ns=deadline,
                    lateness_ns=lateness,
                    missed=self.missed,
                    motion_ready=self.core.ready,
                    groups=self.core.group_ticks(),
                )
                states = [self.core.queue_state(g) for g in range(len(self.queue_pubs))]
            self.tick_pub.put(encode(tick))
            self._publish_queues(states)
            self.lateness.add(lateness / 1000)
            if self.core.tick % self.ticks_per_second == 0:
                self._publish_metrics(realtime, [state.depth for state in states])
            deadline += period
        log.info(
            "stopped after %d ticks, %d missed, realtime=%s", self.core.tick, self.missed, realtime
        )


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("executor", "The interpolation clock of one controller.").parse_args(
        argv
    )
    with running_service("executor", "0", args) as ctx:
        Executor(ctx).run()


if __name__ == "__main__":
    main()
