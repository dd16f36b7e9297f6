"""The executor's clock thread: ticks on absolute CLOCK_MONOTONIC deadlines while anything may
move, rests while the core says nothing can. It drains the inputs (``bus.InputPort``), hands
them to ``core.executor.ExecutorCore``, which decides, and publishes what the core says
(``bus.OutputPort``); it decides nothing itself but when to sleep.

SCHED_FIFO where permitted: ordinary scheduling misses 4 ms deadlines (measured:
docs/realtime.md, "Why SCHED_FIFO").
"""

from __future__ import annotations

import logging
import os
import sys
import time
from collections.abc import Callable

from motocell.services.executor.bus import InputPort, OutputPort
from motocell.services.executor.core.executor import ExecutorCore
from motocell.services.executor.core.late_ticks import LateTickTally
from motocell.services.executor.core.resting import next_on_grid
from motocell.shared.bus.channels import StopSignal
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.bus.schemas import ExecutorMetrics, LateTicks
from motocell.shared.launcher_names import PARENT_PID_ENV
from motocell.shared.metrics import Window
from motocell.shared.realtime import RT_PRIORITY, clock_cpus, fix_command, tighten_timer_slack

log = logging.getLogger("executor")

METRICS_EVERY_NS = 1_000_000_000
REST_TICK_EVERY_NS = round(AT_REST_HEARTBEAT_S * 1e9)


def enter_realtime() -> bool:
    """Make the calling thread, the clock, as punctual as this machine allows: a timer slack of
    1 ns, the CPUs ``clock_cpus`` gives, SCHED_FIFO. Each applies to this thread only; Zenoh's
    threads, started with the session, keep ordinary scheduling. Whether SCHED_FIFO was granted
    is published in every ``ExecutorMetrics``."""
    tighten_timer_slack()
    if sys.platform.startswith("linux"):
        cpus = clock_cpus(os.sched_getaffinity(0))
        if cpus is not None:
            os.sched_setaffinity(0, cpus)
            log.info("clock thread runs on CPUs %s", ",".join(map(str, sorted(cpus))))
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(RT_PRIORITY))
    except (PermissionError, OSError) as exc:
        # Under `motocell up` the launcher says it once for the whole cell.
        quiet = PARENT_PID_ENV in os.environ
        log.log(
            logging.DEBUG if quiet else logging.WARNING,
            "running WITHOUT real-time priority (SCHED_FIFO %d refused: %s); expect missed "
            "periods under load. To allow it: %s",
            RT_PRIORITY,
            exc,
            fix_command(),
        )
        return False
    log.info("clock thread runs SCHED_FIFO priority %d", RT_PRIORITY)
    return True


class Clock:
    """The clock thread's loop: ticks and rests as the core says, draining ``inputs`` before
    each tick and publishing to ``outputs`` after. The clock (``monotonic_ns``, ``sleep``) and
    the scheduling it asks for (``enter_realtime``) are parameters, so a test runs the loop on a
    clock of its own."""

    def __init__(
        self,
        core: ExecutorCore,
        inputs: InputPort,
        outputs: OutputPort,
        stop: StopSignal,
        *,
        monotonic_ns: Callable[[], int] = time.monotonic_ns,
        sleep: Callable[[float], None] = time.sleep,
        enter_realtime: Callable[[], bool] = enter_realtime,
    ) -> None:
        self.core = core
        self.inputs = inputs
        self.outputs = outputs
        self.stop = stop
        self.period_ns = core.period_ns
        self.missed = 0
        self.late_ticks = LateTickTally()
        self.lateness = Window(max(1, round(1e9 / core.period_ns)))
        self.realtime = False
        self._next_metrics_ns = 0
        self._last_deadline = 0
        self._next_rest_tick_ns = 0
        self._monotonic_ns = monotonic_ns
        self._sleep = sleep
        self._enter_realtime = enter_realtime

    def run(self) -> None:
        self.realtime = self._enter_realtime()
        self._warm_up()
        period = self.period_ns
        rest = self.core.rest
        origin = deadline = self._monotonic_ns() + period
        last = deadline - period
        while not self.stop.is_set():
            if rest.resting:
                self._rest()
                if rest.resting or self.stop.is_set():
                    continue
                self.inputs.awake()
                deadline = next_on_grid(origin, period, self._monotonic_ns())
            now = self._sleep_until(deadline)
            lateness = now - deadline
            if lateness >= period:
                self.missed += 1
            self._drain(now)
            if self.core.on_tick(deadline, lateness, (deadline - last) // period):
                origin = deadline = now  # a stall: restart from now, never catch up
            last = deadline
            self._report(deadline, lateness, now)
            deadline += period
        log.info(
            "stopped after %d ticks, %d missed, realtime=%s",
            self.core.tick,
            self.missed,
            self.realtime,
        )

    def _warm_up(self) -> None:
        """numpy's sort and msgspec set themselves up on first use, long enough to make a
        tick late: here, before the first deadline."""
        self.lateness.add(0.0)
        self.lateness.summary()
        self.lateness.clear()

    def _sleep_until(self, deadline: int) -> int:
        now = self._monotonic_ns()
        if deadline > now:
            self._sleep((deadline - now) / 1e9)
            now = self._monotonic_ns()
        return now

    def _drain(self, now: int) -> None:
        """Everything that arrived, in an order that keeps the invariants: readiness first (a
        not-ready status clears the rings before any batch is queued), then what is owed and
        what came, then STOP_MOTION (cleared before this tick applies anything)."""
        core, inputs = self.core, self.inputs
        for present in inputs.controller.looks(now):
            core.on_controller(present, now)
        for arrived, status in inputs.statuses():
            core.on_status(status, arrived)
        for group, point in inputs.points():
            core.on_point(group, point)
        for group in range(len(core.rings)):
            for batch in inputs.batches(group):
                core.accept(group, batch)
        inputs.executor_ready = core.ready
        stops = list(inputs.stop_queries())
        for _ in stops:
            core.on_stop()
        self.outputs.notices(core.take_notices())
        if stops:
            self.outputs.queues(core.queue_updates(now, force=True))
            self.outputs.stopped(stops)

    def _report(self, deadline: int, lateness: int, now: int) -> None:
        core, outputs = self.core, self.outputs
        outputs.notices(core.take_notices())
        outputs.tick(core.tick_report(deadline, lateness, self.missed))
        self._last_deadline = deadline
        self._next_rest_tick_ns = now + REST_TICK_EVERY_NS
        outputs.queues(core.queue_updates(now))
        if lateness >= self.period_ns:  # said after what the cell needs from this tick
            self._announce(self.late_ticks.count(core.tick, deadline, lateness, self.missed, now))
        self.lateness.add(lateness / 1000)
        self._metrics_if_due(now)

    def _rest(self) -> None:
        """Sleep until an input or the core's deadline; serve what came. Returns with the core
        still resting unless motion was asked for."""
        core = self.core
        wake_ns = min(core.rest_deadline(), self._next_metrics_ns, self._next_rest_tick_ns)
        self.inputs.rest(wake_ns / 1e9)
        now = self._monotonic_ns()
        self._drain(now)
        core.notice_if_due(now)
        self.outputs.notices(core.take_notices())
        self.outputs.queues(core.queue_updates(now))
        self._rest_tick_if_due(now)
        self._metrics_if_due(now)

    def _rest_tick_if_due(self, now: int) -> None:
        """The tick the clock rests after, again at the rest heartbeat, with the readiness as it
        is now: whoever missed it (a broadcaster or observer that joined since, or lost it to a
        router that restarted) learns that the cell rests, and where."""
        if now >= self._next_rest_tick_ns:
            self.outputs.tick(self.core.tick_report(self._last_deadline, 0, self.missed))
            self._next_rest_tick_ns = now + REST_TICK_EVERY_NS

    def _announce(self, late: LateTicks | None) -> None:
        """Missed periods, as they happen: on the bus and in the log."""
        if late is None:
            return
        self.outputs.late(late)
        log.warning(
            "the clock missed %d period(s) (%d since start): tick %d came %.1f ms after its "
            "deadline (docs/realtime.md, Missed periods that remain)",
            late.periods,
            late.missed_total,
            late.tick,
            late.lateness_ns / 1e6,
        )

    def _metrics_if_due(self, now: int) -> None:
        """Once a second, the late ticks not yet announced, and the lateness of the ticks since
        the last report if anyone reads it."""
        if now < self._next_metrics_ns:
            return
        self._next_metrics_ns = now + METRICS_EVERY_NS
        self._announce(self.late_ticks.due(self.missed, now))
        if self.outputs.metrics_wanted():
            self.outputs.metrics(
                ExecutorMetrics(
                    tick=self.core.tick,
                    lateness=self.lateness.summary(),
                    missed_total=self.missed,
                    queue_depths=[len(ring.entries) for ring in self.core.rings],
                    realtime=self.realtime,
                )
            )
        self.lateness.clear()
