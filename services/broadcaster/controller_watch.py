"""The controller as the broadcaster sees it over Zenoh: its newest status and its token."""

from __future__ import annotations

import zenoh

from shared.bus.keys import CellKeys
from shared.bus.schemas import ControllerStatus, Decoder
from shared.bus.session import Liveness

_status_decoder = Decoder(ControllerStatus)


class ControllerWatch:
    """A ``core.ControllerView`` fed by Zenoh. The status callback only stores the newest
    sample: statuses are few, and the broadcaster needs only the latest when a snapshot is due."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self._status: ControllerStatus | None = None
        self._token = keys.alive("controller", "0")
        self._liveness = Liveness(session, self._token)
        self._subscriber = session.declare_subscriber(keys.controller_status, self._store)

    def _store(self, sample: zenoh.Sample) -> None:
        self._status = _status_decoder.decode(sample.payload.to_bytes())

    def status(self) -> ControllerStatus | None:
        return self._status

    def alive(self) -> bool:
        return self._token in self._liveness.present()
