"""The one line ``motocell up`` prints when the cell is ready, for people and for scripts that
wait for it: every service present (the controller's status names none missing) and every
Simple Message port this launcher's services serve listening.

The controller's status is read from a one-sample channel each time the launcher looks after
its children, so no Python runs on Zenoh's threads for it.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

import zenoh

from motocell.services.launcher.core.tcp_ports import TcpPort
from motocell.services.launcher.ports import listening
from motocell.shared.bus.channels import newest
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ControllerStatus, Decoder

log = logging.getLogger("motocell")

_status = Decoder(ControllerStatus)


class ReadyNotice:
    def __init__(
        self,
        session: zenoh.Session,
        keys: CellKeys,
        host: str,
        ports: Sequence[TcpPort],
        line: str,
    ) -> None:
        """``ports``: those this launcher's services listen on, at ``host``; ``line``: what
        to say once ready."""
        self._samples: zenoh.Subscriber[Any] = session.declare_subscriber(
            keys.controller_status, zenoh.handlers.RingChannel(1)
        )
        self._host = host
        self._ports = ports
        self._line = line
        self._whole = False
        self.told = False

    def check(self) -> bool:
        """Say it once, the first time the cell is ready; never waits. Whether it was said."""
        if self.told:
            return True
        status = newest(self._samples, _status)
        if status is not None:
            self._whole = not status.missing_services
        if self._whole and listening(self._host, self._ports):
            self.told = True
            log.info("%s", self._line)
            self._samples.undeclare()  # nothing more to look for
        return self.told

    def close(self) -> None:
        if not self.told:
            self._samples.undeclare()
