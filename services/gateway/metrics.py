"""What the gateway measures: requests and reply latency by message type (the known types, and
one bucket for all others), BUSY, INVALID and NOT_READY answers. Published once a second on
``gateway/metrics`` while anyone subscribes; otherwise only the counts are kept and the
latencies dropped each second (``drop_latencies``), and no percentile is computed."""

from __future__ import annotations

import threading

from motocell.shared.bus.schemas import GatewayMetrics, RequestStats
from motocell.shared.metrics import Window
from motocell.shared.protocol.constants import MsgType, Result
from motocell.shared.protocol.messages import Message, MotoMotionReply

WINDOW = 4096
"""Replies kept per type between two publications (a point stream is a few hundred a second)."""
OTHER_TYPES = 0
"""The one bucket for every type ``MsgType`` does not name, and for frames too broken to have
a type (``PeerProtocolError.msg_type`` 0): a client choosing types freely must not choose how
many windows the gateway keeps, nor how long its metrics message grows."""
_KNOWN_TYPES = frozenset(int(t) for t in MsgType)


def bucket(msg_type: int) -> int:
    """Where a request of ``msg_type`` is counted."""
    return msg_type if msg_type in _KNOWN_TYPES else OTHER_TYPES


class GatewayStats:
    def __init__(self, groups: int) -> None:
        self._lock = threading.Lock()
        self._latency: dict[int, Window] = {}
        self._counts: dict[int, int] = {}
        self.busy = 0
        self.invalid = 0
        self.not_ready = 0
        self.busy_by_group = [0] * groups

    def observe(self, msg_type: int, reply: Message | None, elapsed_ns: int) -> None:
        """One request answered (``reply`` None when none is sent) in ``elapsed_ns``."""
        msg_type = bucket(msg_type)
        with self._lock:
            self._counts[msg_type] = self._counts.get(msg_type, 0) + 1
            window = self._latency.get(msg_type)
            if window is None:
                window = self._latency[msg_type] = Window(WINDOW)
            window.add(elapsed_ns / 1000)
            body = reply.body if reply is not None else None
            if not isinstance(body, MotoMotionReply):
                return
            if body.result == Result.BUSY:
                self.busy += 1
                if 0 <= body.group_no < len(self.busy_by_group):
                    self.busy_by_group[body.group_no] += 1
            elif body.result == Result.INVALID:
                self.invalid += 1
            elif body.result == Result.NOT_READY:
                self.not_ready += 1

    def drop_latencies(self) -> None:
        """Forget the latencies measured since the last snapshot: nobody took that one."""
        with self._lock:
            for window in self._latency.values():
                window.clear()

    def snapshot(self, motion: int, io: int) -> GatewayMetrics:
        """Counts since start; latencies of the replies since the last snapshot."""
        with self._lock:
            requests = [
                RequestStats(msg_type, self._counts[msg_type], window.summary())
                for msg_type, window in sorted(self._latency.items())
            ]
            for window in self._latency.values():
                window.clear()
            return GatewayMetrics(
                motion_clients=motion,
                io_clients=io,
                requests=requests,
                busy_total=self.busy,
                invalid_total=self.invalid,
                not_ready_total=self.not_ready,
                busy_by_group=list(self.busy_by_group),
            )
