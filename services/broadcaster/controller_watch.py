"""The controller as the broadcaster sees it on the bus: its newest status and its token."""

from __future__ import annotations

from motocell.services.broadcaster.bus import Bus
from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ControllerStatus, Decoder

_status_decoder = Decoder(ControllerStatus)


class ControllerWatch:
    """A ``core.broadcaster.ControllerView`` over a ``Bus``. Statuses wait in a latest-value
    channel and are read when a snapshot is due: only the newest matters, and no Zenoh thread
    runs Python for them."""

    def __init__(self, bus: Bus, keys: CellKeys) -> None:
        self._status: ControllerStatus | None = None
        self._token = keys.alive("controller", "0")
        self._tokens = bus.tokens(self._token)
        self._tokens.ask()
        self._status_key = keys.controller_status
        self._statuses = bus.latest(keys.controller_status)

    def status(self) -> ControllerStatus | None:
        """The newest status that decoded; a bad one is logged and the one before kept."""
        newer = decoded_payload(self._statuses.take(), _status_decoder, self._status_key)
        if newer is not None:
            self._status = newer
        return self._status

    def alive(self) -> bool:
        return self._token in self._tokens.present()

    def close(self) -> None:
        self._statuses.undeclare()
        self._tokens.close()
