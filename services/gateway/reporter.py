"""What the gateway tells the rest of the cell about itself: which clients are connected, for
the controller's OT#893 and OT#895 (incremental-motion §4.2, motoros1 §7.4; OT#894, the state
port's, is the broadcaster's to report), and its metrics on ``gateway/metrics``."""

from __future__ import annotations

import threading

import zenoh

from motocell.services.gateway.metrics import GatewayStats
from motocell.services.gateway.tcp import RequestServer
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import CommandRequest, encode
from motocell.shared.bus.session import publisher

REFRESH_S = 1.0
"""Connections are reported on every change and also this often: a restarted controller has
to learn them again."""
NOT_SERVED = -1
"""In a ``connections`` notice, the state port: the broadcaster serves it and reports it."""


class Reporter:
    def __init__(
        self,
        session: zenoh.Session,
        keys: CellKeys,
        *,
        stats: GatewayStats,
        motion: RequestServer,
        io: RequestServer,
    ) -> None:
        self.stats = stats
        self.motion = motion
        self.io = io
        self._metrics = publisher(session, keys.metrics("gateway"), latest=True)
        # Called from the port threads on every change and from this one each second: a lost
        # notice is made good within a second, so it never blocks a port thread.
        self._connections = publisher(session, keys.controller_cmd("connections"), latest=True)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="gateway-reports", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def connections(self) -> tuple[int, int]:
        """Motion and I/O clients connected now."""
        return int(self.motion.connected()), int(self.io.connected())

    def report_connections(self) -> None:
        motion, io = self.connections()
        request = CommandRequest(args=[motion, NOT_SERVED, io])
        self._connections.put(encode(request))

    def _run(self) -> None:
        while True:
            self.report_connections()
            self._metrics.put(encode(self.stats.snapshot(*self.connections())))
            if self._stop.wait(REFRESH_S):
                return

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
