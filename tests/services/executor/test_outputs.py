"""``Outputs`` on a scripted bus: what it declares (which streams may drop and which must block),
what it publishes where, metrics only for a subscriber, and STOP_MOTION's answer."""

from __future__ import annotations

from motocell.services.executor.outputs import Outputs
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import (
    CommandReply,
    Decoder,
    ExecutorMetrics,
    GroupTick,
    LateTicks,
    Percentiles,
    QueueState,
    Tick,
    encode,
)
from motocell.shared.protocol.constants import Result
from tests.services.executor.fake_bus import FakeBus, FakeQuery

KEYS = CellKeys("cell1")
TICK = Tick(7, 28_000_000, 120, 0, True, [GroupTick([1] * 8, [1] * 8, [0] * 8, 0, [0.0] * 8)])


def outputs(groups: int = 2) -> tuple[FakeBus, Outputs]:
    bus = FakeBus()
    return bus, Outputs(bus, KEYS, groups)


def test_what_it_declares() -> None:
    """(realtime, latest): a tick or queue state is superseded within a period and may drop;
    a notice (a stall, a broken increment path) must arrive, so it blocks."""
    bus, _ = outputs()
    assert {key: (p.realtime, p.latest) for key, p in bus.publications.items()} == {
        KEYS.executor_tick: (True, True),
        KEYS.group_queue(0): (True, True),
        KEYS.group_queue(1): (True, True),
        KEYS.controller_cmd("incmove_error"): (True, False),
        KEYS.metrics("executor"): (False, True),
        KEYS.executor_late: (False, True),
    }


def test_a_tick_goes_out_encoded() -> None:
    bus, out = outputs()
    out.tick(TICK)
    assert [Decoder(Tick).decode(p) for p in bus.publications[KEYS.executor_tick].payloads] == [
        TICK
    ]


def test_each_queue_state_goes_to_its_group() -> None:
    bus, out = outputs()
    state = QueueState(epoch=5, received=3, depth=1, capacity=200, command_pulses=[0] * 8, tick=9)
    out.queues([(1, state)])
    assert bus.publications[KEYS.group_queue(0)].payloads == []
    assert bus.publications[KEYS.group_queue(1)].payloads == [encode(state)]


def test_every_notice_goes_out_in_order() -> None:
    bus, out = outputs()
    notices = [CommandReply(Result.FAILURE, 0, value=4200), CommandReply(Result.FAILURE, 1)]
    out.notices(notices)
    key = KEYS.controller_cmd("incmove_error")
    assert bus.publications[key].payloads == [encode(notice) for notice in notices]


def test_metrics_are_wanted_only_while_someone_subscribes() -> None:
    bus, out = outputs()
    assert not out.metrics_wanted()
    bus.publications[KEYS.metrics("executor")].subscribed = True
    assert out.metrics_wanted()
    metrics = ExecutorMetrics(3, Percentiles(1, 1.0, 1.0, 1.0), 0, [0, 0], True)
    out.metrics(metrics)
    assert bus.publications[KEYS.metrics("executor")].payloads == [encode(metrics)]


def test_late_ticks_go_out_whether_or_not_anyone_subscribes() -> None:
    bus, out = outputs()
    late = LateTicks(
        tick=9, deadline_ns=36_000_000, lateness_ns=5_000_000, periods=1, missed_total=3
    )
    out.late(late)
    assert bus.publications[KEYS.executor_late].payloads == [encode(late)]


def test_stop_motion_is_answered_success() -> None:
    _, out = outputs()
    queries = [FakeQuery("stop"), FakeQuery("stop")]
    out.stopped(queries)
    assert [query.replies for query in queries] == [[CommandReply(Result.SUCCESS)]] * 2
