"""What the gateway tells the rest of the cell about itself: which clients are connected, for
the controller's OT#893 and OT#895 (incremental-motion §4.2, motoros1 §7.4; OT#894, the state
port's, is the broadcaster's to report) and, for observers (``motocell watch``), which face
holds trajectory mode; and its metrics on ``gateway/metrics``, made only while a subscriber on
the bus matches them."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

from motocell.services.gateway.bus import Bus
from motocell.services.gateway.metrics import GatewayStats
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.bus.schemas import CommandRequest, MotionHolder, encode

REFRESH_S = AT_REST_HEARTBEAT_S
"""Connections are reported on every change and also this often: a restarted controller has
to learn them again; a change of the face holding trajectory mode shows within it. The metrics
go out as often, when observed."""
NOT_SERVED = -1
"""In a ``connections`` notice, the state port: the broadcaster serves it and reports it."""
STOP_JOIN_S = 5.0


class Port(Protocol):
    def connected(self) -> bool: ...


class Reporter:
    def __init__(
        self,
        bus: Bus,
        keys: CellKeys,
        *,
        stats: GatewayStats,
        motion: Port,
        io: Port,
        holder: Callable[[], MotionHolder],
    ) -> None:
        self.stats = stats
        self.motion = motion
        self.io = io
        self.holder = holder
        self._metrics = bus.publisher(keys.metrics("gateway"), latest=True)
        # Called from the port threads on every change and from this one each REFRESH_S: a
        # lost notice is made good within that, so it never blocks a port thread.
        self._connections = bus.publisher(keys.controller_cmd("connections"), latest=True)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="gateway-reports", daemon=True)
        self._thread.start()

    def connections(self) -> tuple[int, int]:
        """Motion and I/O clients connected now."""
        return int(self.motion.connected()), int(self.io.connected())

    def report_connections(self) -> None:
        motion, io = self.connections()
        request = CommandRequest(args=[motion, NOT_SERVED, io, int(self.holder())])
        self._connections.put(encode(request))

    def report(self) -> None:
        """One round: the connections, and the metrics if anyone subscribes to them (else the
        latencies measured meanwhile are dropped, so the next metrics cover one round)."""
        self.report_connections()
        if self._metrics.observed():
            self._metrics.put(encode(self.stats.snapshot(*self.connections())))
        else:
            self.stats.drop_latencies()

    def _run(self) -> None:
        while True:
            self.report()
            if self._stop.wait(REFRESH_S):
                return

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=STOP_JOIN_S)
