"""The reporter on a scripted bus: the connections notice every round and on change, the
metrics only while someone subscribes to them, and its one thread."""

from __future__ import annotations

import threading
from dataclasses import dataclass

from motocell.services.gateway.metrics import GatewayStats
from motocell.services.gateway.reporter import NOT_SERVED, Reporter
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import CommandRequest, Decoder, GatewayMetrics, MotionHolder
from motocell.shared.protocol.constants import MsgType
from tests.services.fakes import FakePublication
from tests.services.gateway.fake_bus import FakeBus

KEYS = CellKeys("cell1")


@dataclass
class Port:
    clients: int = 0

    def connected(self) -> bool:
        return self.clients > 0


class Harness:
    def __init__(self) -> None:
        self.bus = FakeBus()
        self.stats = GatewayStats(groups=1)
        self.motion, self.io = Port(), Port()
        self.holder = MotionHolder.NOBODY
        self.reporter = Reporter(
            self.bus,
            KEYS,
            stats=self.stats,
            motion=self.motion,
            io=self.io,
            holder=lambda: self.holder,
        )
        self.metrics: FakePublication = self.bus.publications[KEYS.metrics("gateway")]
        self.notices: FakePublication = self.bus.publications[KEYS.controller_cmd("connections")]

    def connections(self) -> list[list[int]]:
        decoder = Decoder(CommandRequest)
        return [decoder.decode(payload).args for payload in self.notices.payloads]


def test_unobserved_metrics_are_not_made_and_their_latencies_dropped() -> None:
    harness = Harness()
    harness.stats.observe(MsgType.PING, None, 5_000)
    harness.reporter.report()
    assert harness.metrics.payloads == []

    harness.metrics.subscribed = True
    harness.stats.observe(MsgType.PING, None, 1_000)
    harness.reporter.report()
    [payload] = harness.metrics.payloads
    [requests] = Decoder(GatewayMetrics).decode(payload).requests
    assert requests.count == 2  # counted all along
    assert (requests.reply.count, requests.reply.max_us) == (1, 1.0)  # timed since observed


def test_connections_are_told_every_round_and_on_every_change() -> None:
    harness = Harness()
    harness.reporter.report()
    harness.motion.clients = 1
    harness.reporter.report_connections()
    harness.io.clients = 1
    harness.holder = MotionHolder.ROS2_FACE
    harness.reporter.report()
    assert harness.connections() == [
        [0, NOT_SERVED, 0, MotionHolder.NOBODY],
        [1, NOT_SERVED, 0, MotionHolder.NOBODY],
        [1, NOT_SERVED, 1, MotionHolder.ROS2_FACE],
    ]


def test_the_thread_is_started_by_start_named_and_joined_by_close() -> None:
    before = set(threading.enumerate())
    harness = Harness()
    assert set(threading.enumerate()) == before
    harness.reporter.start()
    [thread] = [t for t in threading.enumerate() if t.name == "gateway-reports"]
    harness.reporter.close()
    assert not thread.is_alive()
    assert harness.connections()[0] == [0, NOT_SERVED, 0, MotionHolder.NOBODY]
