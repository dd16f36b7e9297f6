"""The clock's loop (``Clock``) on a clock of the test's own, with scripted inputs and recorded
outputs (``InputPort``, ``OutputPort``) around the real core: what it drains before each tick and
in which order, what that order decides, and how it rests, wakes and recovers from a stall."""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TypeVar

import pytest

from motocell.services.executor.bus import Query
from motocell.services.executor.core.executor import STALL_ALARM, ExecutorCore
from motocell.services.executor.core.resting import REST_AFTER_NS
from motocell.services.executor.loop import METRICS_EVERY_NS, REST_TICK_EVERY_NS, Clock
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.bus.schemas import (
    CommandReply,
    ControllerStatus,
    ExecutorMetrics,
    IncrementBatch,
    LateTicks,
    Point,
    QueueState,
    Tick,
)
from motocell.shared.config import DEFAULT_MAX_LATENESS_PERIODS
from motocell.shared.protocol.constants import Result
from tests.services.executor.core.test_executor import (
    FIRST_EPOCH,
    PERIOD_NS,
    START,
    batch,
    status,
    unit,
)
from tests.services.executor.fake_bus import FakeQuery

T = TypeVar("T")

T0 = 10_000_000_000
"""The test clock's start: CLOCK_MONOTONIC of a machine up for 10 s."""
MS = 1_000_000
STATUS_EVERY_NS = 100 * MS
"""The controller's heartbeat while motion is possible."""
DRAIN = ["controller", "statuses", "points", "batches 0", "batches 1", "ready", "stop_queries"]
"""What the loop reads before every tick, in the order the core needs it."""


class LoopTime:
    """CLOCK_MONOTONIC as the loop sees it: a sleep passes exactly the time asked, plus
    ``oversleep_ns`` once (a tick made late)."""

    def __init__(self) -> None:
        self.now_ns = T0
        self.oversleep_ns = 0

    def monotonic_ns(self) -> int:
        return self.now_ns

    def sleep(self, seconds: float) -> None:
        self.now_ns += round(seconds * 1e9) + self.oversleep_ns
        self.oversleep_ns = 0


class Stop:
    """Set once the test clock reaches ``at_ns``."""

    def __init__(self, time: LoopTime, at_ns: int) -> None:
        self._time = time
        self.at_ns = at_ns

    def is_set(self) -> bool:
        return self._time.now_ns >= self.at_ns

    def fileno(self) -> int:
        raise AssertionError("the loop never waits on the stop flag itself")


@dataclass
class Controller:
    time: LoopTime
    log: list[str]
    changes: list[tuple[int, bool]] = field(default_factory=lambda: [(0, True)])
    """When the controller's token is present from (True) or gone from (False)."""
    looked_ns: int = -1

    def looks(self, now_ns: int) -> tuple[bool, ...]:
        self.log.append("controller")
        assert now_ns == self.time.now_ns
        since = [present for at, present in self.changes if self.looked_ns < at <= now_ns]
        self.looked_ns = now_ns
        present = [present for at, present in self.changes if at <= now_ns][-1]
        return (False, present) if False in since else (present,)


class ScriptedInputs:
    """``InputPort`` with what arrives, and when, set by the test; ``rest`` returns when the
    real one would: at a point, STOP_MOTION, a status whose readiness is not the executor's, its
    deadline, or the stop. The controller sends a status every ``STATUS_EVERY_NS`` from ``T0``
    and one at each change of its readiness (``readiness``)."""

    def __init__(self, time: LoopTime, stop: Stop, log: list[str]) -> None:
        self._time = time
        self._stop = stop
        self.log = log
        self.controller = Controller(time, log)
        self._readiness = [(T0, True)]
        self._next_heartbeat_ns = T0
        self._changes: deque[int] = deque()
        self._points: deque[tuple[int, int, Point]] = deque()
        self._batches: list[deque[tuple[int, IncrementBatch | None]]] = [deque(), deque()]
        self._stops: deque[tuple[int, Query]] = deque()
        self._ready = False
        self.rests: list[tuple[int, int]] = []
        """(when, until when) of each rest."""

    @property
    def executor_ready(self) -> bool:
        return self._ready

    @executor_ready.setter
    def executor_ready(self, ready: bool) -> None:
        self.log.append("ready")
        self._ready = ready

    # -- what the test scripts -----------------------------------------------------------
    def readiness(self, at_ns: int, ready: bool) -> None:
        """The controller's motion-ready changes at ``at_ns``."""
        self._readiness.append((at_ns, ready))
        self._changes.append(at_ns)

    def _ready_at(self, at_ns: int) -> bool:
        return [ready for at, ready in self._readiness if at <= at_ns][-1]

    def point(self, at_ns: int, group: int = 0, epoch: int = FIRST_EPOCH) -> None:
        self._points.append((at_ns, group, Point(1, 0, 0.0, [], [], epoch=epoch)))

    def batch(self, at_ns: int, group: int, sent: IncrementBatch | None) -> None:
        self._batches[group].append((at_ns, sent))

    def stop_motion(self, at_ns: int) -> FakeQuery:
        query = FakeQuery("stop")
        self._stops.append((at_ns, query))
        return query

    # -- InputPort -------------------------------------------------------------------------
    def _arrived(self, queue: deque[tuple[int, T]]) -> list[T]:
        now = self._time.now_ns
        arrived = []
        while queue and queue[0][0] <= now:
            arrived.append(queue.popleft()[1])
        return arrived

    def rest(self, deadline_s: float) -> None:
        self.log.append("rest")
        start = self._time.now_ns
        wakes = [
            round(deadline_s * 1e9),
            self._stop.at_ns,
            *(at for at, _, _ in self._points),
            *(at for at, _ in self._stops),
            *(at for at in self._changes if self._ready_at(at) != self._ready),
        ]
        self._time.now_ns = max(start, min(wakes))
        self.rests.append((start, self._time.now_ns))

    def awake(self) -> None:
        self.log.append("awake")

    def statuses(self) -> list[tuple[int, ControllerStatus]]:
        self.log.append("statuses")
        now = self._time.now_ns
        sent = []
        while self._next_heartbeat_ns <= now or (self._changes and self._changes[0] <= now):
            if self._changes and self._changes[0] <= self._next_heartbeat_ns:
                at = self._changes.popleft()
            else:
                at = self._next_heartbeat_ns
                self._next_heartbeat_ns += STATUS_EVERY_NS
            sent.append((at, status(self._ready_at(at))))
        return sent

    def points(self) -> list[tuple[int, Point]]:
        self.log.append("points")
        return [(group, point) for group, point in self._arrived_points()]

    def _arrived_points(self) -> list[tuple[int, Point]]:
        now = self._time.now_ns
        arrived = []
        while self._points and self._points[0][0] <= now:
            _, group, point = self._points.popleft()
            arrived.append((group, point))
        return arrived

    def batches(self, group: int) -> list[IncrementBatch | None]:
        self.log.append(f"batches {group}")
        return self._arrived(self._batches[group])

    def stop_queries(self) -> list[Query]:
        self.log.append("stop_queries")
        return self._arrived(self._stops)


class RecordedOutputs:
    """``OutputPort`` keeping what was published, and when."""

    def __init__(self, time: LoopTime, log: list[str]) -> None:
        self._time = time
        self.log = log
        self.ticks: list[tuple[int, Tick]] = []
        self.queue_states: list[tuple[int, int, QueueState]] = []
        self.sent_notices: list[tuple[int, CommandReply]] = []
        """With the number of ticks published before each."""
        self.sent_metrics: list[tuple[int, ExecutorMetrics]] = []
        self.sent_late: list[tuple[int, LateTicks]] = []
        self.answered: list[Query] = []
        self.wanted_from_ns = T0
        """From when someone subscribes to the metrics."""

    def tick(self, tick: Tick) -> None:
        self.log.append("tick")
        self.ticks.append((self._time.now_ns, tick))

    def queues(self, updates: Iterable[tuple[int, QueueState]]) -> None:
        self.log.append("queues")
        self.queue_states += [(self._time.now_ns, group, state) for group, state in updates]

    def notices(self, replies: Iterable[CommandReply]) -> None:
        self.log.append("notices")
        self.sent_notices += [(len(self.ticks), reply) for reply in replies]

    def late(self, late: LateTicks) -> None:
        self.sent_late.append((self._time.now_ns, late))

    def metrics_wanted(self) -> bool:
        return self._time.now_ns >= self.wanted_from_ns

    def metrics(self, metrics: ExecutorMetrics) -> None:
        self.sent_metrics.append((self._time.now_ns, metrics))

    def stopped(self, queries: Iterable[Query]) -> None:
        self.log.append("stopped")
        for query in queries:
            query.answer(CommandReply(Result.SUCCESS))
        self.answered += list(queries)


class Run:
    """A two-group executor's loop from ``T0``, the controller present and ready, its first
    status arriving with the first drain."""

    def __init__(self) -> None:
        self.time = LoopTime()
        self.stop = Stop(self.time, T0 + 20 * PERIOD_NS)
        self.log: list[str] = []
        self.inputs = ScriptedInputs(self.time, self.stop, self.log)
        self.outputs = RecordedOutputs(self.time, self.log)
        self.core = ExecutorCore(START, FIRST_EPOCH)
        self.clock = Clock(
            self.core,
            self.inputs,
            self.outputs,
            self.stop,
            monotonic_ns=self.time.monotonic_ns,
            sleep=self.time.sleep,
            enter_realtime=lambda: False,
        )

    def until(self, at_ns: int) -> Run:
        self.stop.at_ns = at_ns
        self.clock.run()
        return self

    def tick_times(self) -> list[int]:
        return [at for at, tick in self.outputs.ticks if not tick.resting]

    def applied(self, group: int = 0) -> list[int]:
        """Axis 0's increment of ``group`` in every tick."""
        return [tick.groups[group].increment[0] for _, tick in self.outputs.ticks]


FIRST_DEADLINE = T0 + PERIOD_NS


# -- what is drained before each tick, in which order --------------------------------------


def test_every_tick_follows_a_drain_of_every_input_in_order() -> None:
    run = Run().until(FIRST_DEADLINE + 4 * PERIOD_NS)
    ticks = [index for index, entry in enumerate(run.log) if entry == "tick"]
    assert len(ticks) == 5
    start = 0
    for index in ticks:
        assert run.log[start:index] == [*DRAIN, "notices", "notices"]
        start = index + 2  # the tick, then its queue states
        assert run.log[index + 1] == "queues"


def test_the_inputs_learn_the_readiness_the_drain_left() -> None:
    run = Run()
    run.inputs.readiness(FIRST_DEADLINE + 2 * PERIOD_NS, False)
    run.until(FIRST_DEADLINE + 2 * PERIOD_NS)
    assert not run.inputs.executor_ready
    assert [tick.motion_ready for _, tick in run.outputs.ticks] == [True, True, False]


def test_the_controllers_token_counts_before_the_status_that_came_with_it() -> None:
    """The token's presence is drained first: a ready status arriving with it is taken, where
    drained the other way round it would be one from an absent controller."""
    run = Run()
    assert run.core.ready is False
    run.until(FIRST_DEADLINE + PERIOD_NS)
    assert all(tick.motion_ready for _, tick in run.outputs.ticks)


def test_a_controller_gone_and_back_between_two_ticks_clears_the_rings() -> None:
    """Its DELETE and PUT in one drain (the executor's link broke and came back within a
    period): a not-ready status sent meanwhile is lost, so nothing queued before moves."""
    run = Run()
    run.inputs.batch(FIRST_DEADLINE, 0, batch(FIRST_EPOCH, 0, [unit(3)] * 5))
    run.inputs.controller.changes += [
        (FIRST_DEADLINE + PERIOD_NS // 3, False),
        (FIRST_DEADLINE + 2 * PERIOD_NS // 3, True),
    ]
    run.until(FIRST_DEADLINE + 3 * PERIOD_NS)
    assert run.applied() == [3, 0, 0, 0]


def test_a_ready_status_counts_before_the_batch_that_came_with_it() -> None:
    """Readiness is drained before the batches: the first batch of a trajectory, arriving
    with the status that made the controller ready, is taken rather than refused."""
    run = Run()
    run.inputs.batch(0, 0, batch(FIRST_EPOCH, 0, [unit(3)] * 2))
    run.until(FIRST_DEADLINE + 3 * PERIOD_NS)
    assert run.applied()[:3] == [3, 3, 0]


def test_stop_motion_clears_what_came_with_it_before_the_tick_and_is_answered_after() -> None:
    """A batch and STOP_MOTION in one drain: the batch is queued, then every ring cleared
    before the tick applies anything; every queue state goes out (new epochs), then the
    answer."""
    run = Run()
    run.inputs.batch(FIRST_DEADLINE, 0, batch(FIRST_EPOCH, 0, [unit(3)] * 5))
    stop = run.inputs.stop_motion(FIRST_DEADLINE + PERIOD_NS)
    run.until(FIRST_DEADLINE + 2 * PERIOD_NS)
    assert run.applied() == [3, 0, 0]
    assert stop.replies == [CommandReply(Result.SUCCESS)]
    drain = run.log.index("stopped")
    assert run.log[drain - 3 : drain + 1] == ["stop_queries", "notices", "queues", "stopped"]
    stopped_at = FIRST_DEADLINE + PERIOD_NS
    forced = [(g, state.epoch) for at, g, state in run.outputs.queue_states if at == stopped_at]
    assert forced == [(0, FIRST_EPOCH + 2), (1, FIRST_EPOCH + 3)]


def test_a_batch_that_breaks_the_increment_path_is_told_before_the_tick() -> None:
    run = Run()
    run.inputs.batch(FIRST_DEADLINE + PERIOD_NS, 0, None)
    run.until(FIRST_DEADLINE + 2 * PERIOD_NS)
    assert [(ticks, notice.result) for ticks, notice in run.outputs.sent_notices] == [
        (1, Result.FAILURE)
    ]


# -- ticks, stalls and metrics ----------------------------------------------------------------


def test_ticks_keep_their_grid() -> None:
    run = Run().until(FIRST_DEADLINE + 9 * PERIOD_NS)
    assert run.tick_times() == [FIRST_DEADLINE + n * PERIOD_NS for n in range(10)]
    assert [tick.tick for _, tick in run.outputs.ticks] == list(range(1, 11))
    assert {tick.lateness_ns for _, tick in run.outputs.ticks} == {0}


def test_a_late_tick_is_counted_and_reported() -> None:
    run = Run()
    run.time.oversleep_ns = PERIOD_NS + 1
    run.until(FIRST_DEADLINE + 2 * PERIOD_NS)
    (_, first), *_ = run.outputs.ticks
    assert (first.lateness_ns, first.missed) == (PERIOD_NS + 1, 1)
    assert run.clock.missed == 1


def test_a_late_tick_is_said_on_the_bus_and_in_the_log_as_it_happens(
    caplog: pytest.LogCaptureFixture,
) -> None:
    run = Run()
    run.time.oversleep_ns = 2 * PERIOD_NS
    with caplog.at_level(logging.WARNING, logger="executor"):
        run.until(FIRST_DEADLINE + 3 * PERIOD_NS)
    [(at, late)] = run.outputs.sent_late
    assert at == FIRST_DEADLINE + 2 * PERIOD_NS, "with the late tick, not at a later report"
    # Said at once; the tick caught up after it (one period late) waits for the next second.
    assert late == LateTicks(
        tick=1, deadline_ns=FIRST_DEADLINE, lateness_ns=2 * PERIOD_NS, periods=1, missed_total=1
    )
    assert run.clock.missed == 2
    [record] = caplog.records
    assert "missed 1 period(s) (1 since start)" in record.getMessage()
    assert "tick 1 came 8.0 ms after its deadline" in record.getMessage()


def test_late_ticks_soon_after_one_said_are_said_within_a_second() -> None:
    run = Run()
    run.inputs.batch(0, 0, batch(FIRST_EPOCH, 0, [unit(3)] * 400))
    run.time.oversleep_ns = PERIOD_NS
    run.until(FIRST_DEADLINE + 10 * PERIOD_NS)
    run.time.oversleep_ns = PERIOD_NS
    run.until(FIRST_DEADLINE + METRICS_EVERY_NS + 2 * PERIOD_NS)
    [(first_at, first), (second_at, second)] = run.outputs.sent_late
    assert (first.periods, second.periods, second.missed_total) == (1, 1, 2)
    assert second_at - first_at <= METRICS_EVERY_NS + PERIOD_NS


def test_a_stall_restarts_the_clock_from_now_without_catching_up() -> None:
    late = DEFAULT_MAX_LATENESS_PERIODS * PERIOD_NS + 1
    run = Run()
    run.inputs.batch(0, 0, batch(FIRST_EPOCH, 0, [unit(3)] * 50))
    run.time.oversleep_ns = late
    run.until(FIRST_DEADLINE + late + 3 * PERIOD_NS)
    stalled_at = FIRST_DEADLINE + late
    assert run.tick_times() == [stalled_at + n * PERIOD_NS for n in range(4)]
    assert run.applied() == [0] * 4
    assert [(notice.result, notice.value) for _, notice in run.outputs.sent_notices] == [
        (Result.FAILURE, STALL_ALARM)
    ]


def test_metrics_go_out_once_a_second_only_while_wanted() -> None:
    run = Run()
    run.outputs.wanted_from_ns = FIRST_DEADLINE + METRICS_EVERY_NS // 2
    run.until(FIRST_DEADLINE + METRICS_EVERY_NS + PERIOD_NS)
    [(at, metrics)] = run.outputs.sent_metrics
    assert at == FIRST_DEADLINE + METRICS_EVERY_NS
    assert metrics.lateness.count == METRICS_EVERY_NS // PERIOD_NS
    assert (metrics.missed_total, metrics.realtime) == (0, False)


# -- at rest ---------------------------------------------------------------------------------


REST_FROM = FIRST_DEADLINE + REST_AFTER_NS
"""When a run with nothing to do comes to rest: its first tick is quiet, its clock rests after
that tick plus ``REST_AFTER_NS``."""


def test_the_clock_rests_after_a_quiet_second_and_says_so() -> None:
    run = Run().until(REST_FROM + PERIOD_NS)
    assert run.tick_times()[-1] == REST_FROM - PERIOD_NS
    at, last = run.outputs.ticks[-1]
    assert (at, last.resting) == (REST_FROM, True), "the tick it rests after says so"
    assert run.inputs.rests[0] == (REST_FROM, REST_FROM + PERIOD_NS)


def test_a_resting_clock_ticks_for_nobody_and_wakes_for_its_heartbeats() -> None:
    run = Run().until(REST_FROM + 3 * REST_TICK_EVERY_NS + MS)
    assert run.tick_times()[-1] == REST_FROM - PERIOD_NS
    again = [at for at, tick in run.outputs.ticks if at > REST_FROM]
    assert again == [REST_FROM + n * REST_TICK_EVERY_NS for n in (1, 2, 3)]
    assert all(tick.resting for at, tick in run.outputs.ticks if at >= REST_FROM)
    heartbeat_ms = round(AT_REST_HEARTBEAT_S * 1000)
    rested_states = [state for at, _, state in run.outputs.queue_states if at > REST_FROM]
    assert {state.heartbeat_ms for state in rested_states} == {heartbeat_ms}
    assert [end for _, end in run.inputs.rests] == [
        *(REST_FROM + n * REST_TICK_EVERY_NS for n in (1, 2, 3)),
        REST_FROM + 3 * REST_TICK_EVERY_NS + MS,
    ]


def test_a_point_wakes_a_resting_clock_on_its_grid() -> None:
    arrives = REST_FROM + 300 * MS + 1
    run = Run()
    run.inputs.point(arrives)
    run.until(arrives + 3 * PERIOD_NS)
    woken = [at for at in run.tick_times() if at > REST_FROM]
    grid = FIRST_DEADLINE + -(-(arrives - FIRST_DEADLINE) // PERIOD_NS) * PERIOD_NS
    assert woken == [grid + n * PERIOD_NS for n in range(4)]
    assert 0 < woken[0] - arrives < PERIOD_NS
    first = next(tick for at, tick in run.outputs.ticks if at == woken[0])
    assert first.tick == (woken[0] - FIRST_DEADLINE) // PERIOD_NS + 1, "numbered on the grid too"
    rested = len(run.log) - 1 - run.log[::-1].index("rest")
    assert run.log[rested + 1 :].count("awake") == 1, "the inputs are told the rest is over"
    assert "awake" not in run.log[:rested]


def test_a_status_that_changes_readiness_is_served_at_rest_without_ticking() -> None:
    changed = REST_FROM + 10 * MS
    run = Run()
    run.inputs.readiness(changed, False)
    run.until(changed + 10 * MS)
    assert run.inputs.rests[0] == (REST_FROM, changed)
    assert not run.inputs.executor_ready
    assert [at for at, _ in run.outputs.ticks if at > REST_FROM] == []
    served = [state.ready for at, _, state in run.outputs.queue_states if at == changed]
    assert served == [False, False]


def test_stop_motion_is_answered_at_rest() -> None:
    asked = REST_FROM + 10 * MS
    run = Run()
    stop = run.inputs.stop_motion(asked)
    run.until(asked + 10 * MS)
    assert run.inputs.rests[0] == (REST_FROM, asked)
    assert stop.replies == [CommandReply(Result.SUCCESS)]
    assert [at for at, _ in run.outputs.ticks if at > REST_FROM] == []
