"""The controller as the broadcaster sees it over Zenoh: its newest status and its token."""

from __future__ import annotations

import zenoh

from motocell.shared.bus.channels import newest
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ControllerStatus, Decoder
from motocell.shared.bus.session import Liveness

_status_decoder = Decoder(ControllerStatus)


class ControllerWatch:
    """A ``core.ControllerView`` fed by Zenoh. Statuses wait in a one-sample ring channel and
    are read when a snapshot is due: only the newest matters, and no Zenoh thread runs Python
    for them."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self._status: ControllerStatus | None = None
        self._token = keys.alive("controller", "0")
        self._liveness = Liveness(session, self._token)
        self._liveness.ask()
        self._subscriber = session.declare_subscriber(
            keys.controller_status, zenoh.handlers.RingChannel(1)
        )

    def status(self) -> ControllerStatus | None:
        status = newest(self._subscriber, _status_decoder)
        if status is not None:
            self._status = status
        return self._status

    def alive(self) -> bool:
        return self._token in self._liveness.present()

    def close(self) -> None:
        self._subscriber.undeclare()
        self._liveness.close()
