"""The executor: the controller's interpolation clock.

Every period (4 ms by default) on an absolute CLOCK_MONOTONIC deadline it takes one increment
per group from the rings and applies them together, then publishes the tick and each group's
queue state. SCHED_FIFO where permitted: on a 2-core machine ordinary scheduling misses 4 ms
deadlines even idle, FIFO missed none in measurements (zenoh-facts §5).
"""

from __future__ import annotations

import logging
import os
import sys
import time
from collections.abc import Sequence
from typing import Any

import msgspec
import zenoh

from motocell.services.executor.controller_token import ControllerToken
from motocell.services.executor.core import (
    SOFT_LIMIT_ALARM,
    STALL_ALARM,
    BatchOutcome,
    ExecutorCore,
    heartbeat_ticks,
    pulse_ranges,
    stalled,
    starting_pulses,
)
from motocell.shared.bus.schemas import (
    CommandReply,
    ControllerStatus,
    Decoder,
    ExecutorMetrics,
    IncrementBatch,
    Point,
    encode,
)
from motocell.shared.bus.session import ENCODING, answer, call, publisher
from motocell.shared.config import Cell
from motocell.shared.metrics import Window
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.motion.servo import Servos
from motocell.shared.protocol.constants import Result
from motocell.shared.realtime import RT_PRIORITY, clock_cpus, fix_command, tighten_timer_slack
from motocell.shared.service import ServiceContext, argument_parser, running_service

log = logging.getLogger("executor")

CHANNEL_DEPTH = 10_000
"""Zenoh-side queue per key. A full channel would stall Zenoh's network thread; four groups
at 250 Hz never come near it, since every tick drains them all."""


_status = Decoder(ControllerStatus)
_batch = Decoder(IncrementBatch)
_point = Decoder(Point)


def _channel() -> zenoh.handlers.FifoChannel[Any]:
    return zenoh.handlers.FifoChannel(CHANNEL_DEPTH)


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
        log.warning(
            "running WITHOUT real-time priority (SCHED_FIFO %d refused: %s); expect missed "
            "periods under load. To allow it: %s",
            RT_PRIORITY,
            exc,
            fix_command(),
        )
        return False
    log.info("clock thread runs SCHED_FIFO priority %d", RT_PRIORITY)
    return True


class Executor:
    """The clock thread does everything: no Python runs on Zenoh's threads in this process.

    Samples, liveliness events and queries wait in Zenoh's own (Rust) channels and are drained
    at the start of each tick. A Python callback would take the GIL on a thread without
    real-time priority; the clock thread would then wait for it, up to the interpreter's 5 ms
    switch interval, and miss its deadline (seen as 7 ms lateness spikes when a trajectory
    started, with batches arriving in callbacks).
    """

    def __init__(self, ctx: ServiceContext) -> None:
        self.ctx = ctx
        cell: Cell = ctx.cell
        self.period_ns = cell.period_ns
        self.max_lateness_periods = cell.max_lateness_periods
        remembered = call(ctx.session, ctx.keys.controller_cmd("positions"), timeout=1.0)
        start = starting_pulses(cell, remembered)
        self.core = ExecutorCore(
            start,
            first_epoch=time.time_ns() // 1000,
            max_increments=[AxisMap(group).max_increments(cell.period_s) for group in cell.groups],
            heartbeat_ticks=heartbeat_ticks(cell.period_ns),
            ranges=pulse_ranges(cell),
            servos=Servos([group.servo for group in cell.groups], cell.period_s, start),
            max_starved_ticks=cell.max_lateness_periods,
        )
        session = ctx.session
        keys = ctx.keys
        self.tick_pub = publisher(session, keys.executor_tick, realtime=True, latest=True)
        self.queue_pubs = [
            publisher(session, keys.group_queue(g.index), realtime=True, latest=True)
            for g in cell.groups
        ]
        self.batches = [
            session.declare_subscriber(keys.group_increments(g.index), _channel())
            for g in cell.groups
        ]
        self.points = [
            session.declare_subscriber(keys.group_point(g.index), _channel()) for g in cell.groups
        ]
        self.statuses = session.declare_subscriber(keys.controller_status, _channel())
        self.ticks_per_second = max(1, round(1e9 / cell.period_ns))
        self.controller = ControllerToken(
            session, keys.alive("controller", "0"), ask_every=self.ticks_per_second
        )
        self.stop_queries = session.declare_queryable(keys.executor_cmd("stop"), _channel())
        self.missed = 0
        self.lateness = Window(self.ticks_per_second)
        self.metrics_pub = publisher(session, keys.metrics("executor"), latest=True)

    def _publish_queues(self, force: bool = False) -> None:
        for group, state in self.core.queue_updates(force):
            self.queue_pubs[group].put(encode(state))

    def drain(self) -> None:
        """Everything that arrived since the last tick, in an order that keeps the invariants:
        readiness first (a not-ready status clears the rings before any batch is queued),
        then what is owed and what came, then commands."""
        core = self.core
        core.controller_present = self.controller.present(core.tick)
        while (sample := self.statuses.try_recv()) is not None:
            # Every status is applied in order, so a not-ready blip between two ticks still
            # clears the rings.
            try:
                status = _status.decode(sample.payload.to_bytes())
            except msgspec.DecodeError:
                log.warning("undecodable controller status ignored")
                continue
            core.on_status(status.motion_ready, status.servo_on and not status.eco)
        core.update_ready()
        self._drain_points()
        for group, channel in enumerate(self.batches):
            while (sample := channel.try_recv()) is not None:
                try:
                    outcome = core.accept(group, _batch.decode(sample.payload.to_bytes()))
                except msgspec.DecodeError:
                    outcome = BatchOutcome.MALFORMED
                if outcome.breaks_increment_path:
                    self._increment_path_broken(group, f"increment batch {outcome.value}")
        while (query := self.stop_queries.try_recv()) is not None:
            # STOP_MOTION: cleared before this tick applies anything.
            core.clear_all()
            self._publish_queues(force=True)
            answer(query, CommandReply(Result.SUCCESS))

    def _drain_points(self) -> None:
        """The points the gateway published: what each ring is owed. One that does not
        decode is not owed either: the interpolator cannot decode it."""
        for group, channel in enumerate(self.points):
            while (sample := channel.try_recv()) is not None:
                try:
                    self.core.on_point(group, _point.decode(sample.payload.to_bytes()))
                except msgspec.DecodeError:
                    log.warning("group %d: undecodable point ignored", group)

    def _increment_path_broken(self, group: int, reason: str, alarm: int = 0) -> None:
        """Stop everything and have the controller raise the IncMove error (NOT_READY 5012
        until START_TRAJ_MODE), as MotoROS 1.9.5 does when an increment is rejected, or
        ``alarm`` when it is not 0."""
        log.error("group %d: %s; stopping motion", group, reason)
        self.core.clear_all()
        self.ctx.session.put(
            self.ctx.keys.controller_cmd("incmove_error"),
            encode(CommandReply(Result.FAILURE, group, value=alarm, detail=reason)),
            encoding=ENCODING,
        )

    def _stall(self, reason: str) -> None:
        """Stop motion for a stall (nothing queued is applied late) and have the controller
        raise ``STALL_ALARM``: NOT_READY until START_TRAJ_MODE."""
        if not self.core.awaiting_not_ready:
            log.error("%s; stopping motion (alarm %d)", reason, STALL_ALARM)
        self.core.stop_for_stall()
        self._publish_queues(force=True)
        self.ctx.session.put(
            self.ctx.keys.controller_cmd("incmove_error"),
            encode(CommandReply(Result.FAILURE, value=STALL_ALARM, detail=reason)),
            encoding=ENCODING,
        )

    def _check_stalls(self, lateness: int) -> bool:
        """After draining, before applying: a tick later than the bound, or a controller
        unheard for too long, stops motion. Returns whether the clock must restart from now
        (no catching up on the missed periods)."""
        core = self.core
        if stalled(lateness, self.period_ns, self.max_lateness_periods):
            self._stall(f"tick {lateness / 1e6:.1f} ms late")
            return True
        if core.controller_silent():
            self._stall("no controller status heard")
        elif core.stall_notice_due(self.ticks_per_second):
            self._stall("stall not yet confirmed by the controller")
        return False

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
        # Warm up before the clock starts: numpy's percentile and msgspec's encoders set
        # themselves up on first use, which cost a 4 ms late tick when it happened in the loop.
        self.lateness.add(0.0)
        self._publish_metrics(realtime, [0] * len(self.queue_pubs))
        self.lateness.clear()
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
                self.missed += 1
            self.drain()
            if self._check_stalls(lateness):
                deadline = now
            for group in self.core.step():
                if group in self.core.beyond_range:
                    reason = self.core.beyond_range[group]
                    self._increment_path_broken(group, reason, SOFT_LIMIT_ALARM)
                elif group in self.core.starved:
                    self._increment_path_broken(group, "increments stopped mid-trajectory")
                else:
                    self._increment_path_broken(group, "refused by the motion system")
            tick = self.core.tick_report(deadline, lateness, self.missed)
            self.tick_pub.put(encode(tick))
            self._publish_queues()
            self.lateness.add(lateness / 1000)
            if self.core.tick % self.ticks_per_second == 0:
                self._publish_metrics(realtime, [g.depth for g in tick.groups])
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
