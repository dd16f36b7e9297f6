"""What the broadcaster tells the cell about its state port, from its own thread: the client
count for the controller's OT#894 (motoros1 §6, incremental-motion §4.2) on every change and
every second, and ``broadcaster/metrics`` every second while anyone subscribes to them."""

from __future__ import annotations

from motocell.services.broadcaster.bus import Bus
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import BroadcasterMetrics, CommandRequest, encode
from motocell.shared.metrics import Window

REFRESH_S = 1.0
"""Also this often: a restarted controller has to learn the clients again, and a notice that
was dropped is made good."""
NOT_SERVED = -1
"""In a ``connections`` notice, a port this process does not serve (motion and I/O are the
gateway's): the controller keeps what the gateway said about them."""
AGE_WINDOW = 1024
"""Ages kept per second: 250 cycles at the fastest state period, with room."""


class StatePortReports:
    """A ``bus.StateReports`` over a ``Bus``."""

    def __init__(self, bus: Bus, keys: CellKeys) -> None:
        # Dropped rather than blocking under congestion: this runs on the state loop, and the
        # next second's notice makes a lost one good.
        self._connections = bus.publisher(keys.controller_cmd("connections"), latest=True)
        self._metrics = bus.publisher(keys.metrics("broadcaster"), latest=True)
        self._ages = Window(AGE_WINDOW)
        self._reported_clients: int | None = None
        self._next_s = 0.0

    def written(self, age_ns: int) -> None:
        """A tick's frames were handed to the clients ``age_ns`` after its wake-up."""
        self._ages.add(age_ns / 1000)

    def report(self, now: float, clients: int, replaced: int, stuck_closed: int) -> None:
        """Publish what changed, and everything once a second (``now``: time.monotonic())."""
        due = now >= self._next_s
        if due or clients != self._reported_clients:
            request = CommandRequest(args=[NOT_SERVED, clients, NOT_SERVED])
            self._connections.put(encode(request))
            self._reported_clients = clients
        if due:
            self._next_s = now + REFRESH_S
            if self._metrics.observed():
                metrics = BroadcasterMetrics(clients, self._ages.summary(), replaced, stuck_closed)
                self._metrics.put(encode(metrics))
            self._ages.clear()

    @property
    def next_due(self) -> float:
        """When ``report`` must run again at the latest (time.monotonic())."""
        return self._next_s

    def close(self) -> None:
        self._connections.undeclare()
        self._metrics.undeclare()
