"""What the gateway tells the rest of the cell about itself: which clients are connected, for
the controller's OT#893-#895 (incremental-motion §4.2, motoros1 §7.4), and its metrics on
``gateway/metrics``."""

from __future__ import annotations

import threading

import zenoh

from services.gateway.metrics import GatewayStats
from services.gateway.state_port import StatePort
from services.gateway.tcp import RequestServer
from shared.bus.keys import CellKeys
from shared.bus.schemas import CommandRequest, encode
from shared.bus.session import publisher

REFRESH_S = 1.0
"""Connections are reported on every change and also this often: state clients leave
silently, and a restarted controller has to learn them again."""


class Reporter:
    def __init__(
        self,
        session: zenoh.Session,
        keys: CellKeys,
        *,
        stats: GatewayStats,
        motion: RequestServer,
        state: StatePort,
        io: RequestServer,
    ) -> None:
        self.session = session
        self.keys = keys
        self.stats = stats
        self.motion = motion
        self.state = state
        self.io = io
        self._metrics = publisher(session, keys.metrics("gateway"), latest=True)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="gateway-reports", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def connections(self) -> tuple[int, int, int]:
        """Motion, state and I/O clients connected now."""
        return int(self.motion.connected()), self.state.client_count(), int(self.io.connected())

    def report_connections(self) -> None:
        request = CommandRequest(args=list(self.connections()))
        self.session.put(self.keys.controller_cmd("connections"), encode(request))

    def _run(self) -> None:
        while True:
            self.report_connections()
            self._metrics.put(encode(self.stats.snapshot(*self.connections())))
            if self._stop.wait(REFRESH_S):
                return

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
