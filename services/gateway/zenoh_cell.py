"""The gateway's ``CellPort`` over Zenoh: subscriptions that keep ``CellState`` current, and the
few things the gateway asks of other services.

Callbacks only decode a sample and hand it to ``CellState`` under one lock, whose condition
wakes whoever waits on the cell (``wait_for``); the handlers decide from the state. A watchdog
thread ages that state every heartbeat (``CellState.expire``) and subscribes again to a stream
that stopped arriving, so the gateway recovers without waiting for some other event.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import zenoh

from services.gateway.core.cell_state import STATUS_STREAM, CellState
from shared.bus.keys import CellKeys, group_of
from shared.bus.liveness import HEARTBEAT_S
from shared.bus.schemas import (
    CommandReply,
    CommandRequest,
    ControllerStatus,
    Decoder,
    Point,
    QueueState,
    Slot,
    encode,
)
from shared.bus.session import Liveness, call, publisher
from shared.config import Cell

STATUS_WAIT_S = 0.5
"""The controller publishes its status before it replies; this only bounds a lost sample."""

_status_decoder = Decoder(ControllerStatus)
_queue_decoder = Decoder(QueueState)
_slot_decoder = Decoder(Slot)


class ZenohCell:
    def __init__(self, cell: Cell, keys: CellKeys, session: zenoh.Session) -> None:
        self.keys = keys
        self.session = session
        self.state = CellState(len(cell.groups))
        self._changed = threading.Condition()
        self._controller_key = keys.alive("controller", "0")
        self._alive = Liveness(session, self._controller_key)
        self._point_pubs = [
            publisher(session, keys.group_point(g), realtime=True) for g in range(len(cell.groups))
        ]
        self._streams: dict[str, tuple[str, Callable[[zenoh.Sample], None]]] = {
            "status": (keys.controller_status, self._on_status),
            "queue": (keys.group_queue_all, self._on_queue),
            "slot": (keys.group_slot_all, self._on_slot),
        }
        self._subscribers = {
            name: session.declare_subscriber(key, callback)
            for name, (key, callback) in self._streams.items()
        }
        self._stop = threading.Event()
        self._watchdog = threading.Thread(target=self._watch, name="gateway-ages", daemon=True)

    def start(self) -> None:
        self._watchdog.start()

    def close(self) -> None:
        self._stop.set()
        self._watchdog.join(timeout=1.0)

    def _watch(self) -> None:
        """Every heartbeat: forget what stopped arriving, and subscribe again to its stream."""
        while not self._stop.wait(HEARTBEAT_S):
            with self._changed:
                stopped = self.state.expire(time.monotonic())
                if stopped:
                    self._changed.notify_all()
            for name in sorted({"status" if s == STATUS_STREAM else "queue" for s in stopped}):
                self._subscribe_again(name)

    def _subscribe_again(self, name: str) -> None:
        """The new subscriber first, so no sample falls between the two."""
        key, callback = self._streams[name]
        old = self._subscribers[name]
        self._subscribers[name] = self.session.declare_subscriber(key, callback)
        old.undeclare()

    def _on_status(self, sample: zenoh.Sample) -> None:
        status = _status_decoder.decode(sample.payload.to_bytes())
        with self._changed:
            self.state.on_status(status)
            self._changed.notify_all()

    def _on_queue(self, sample: zenoh.Sample) -> None:
        group = group_of(str(sample.key_expr))
        queue = _queue_decoder.decode(sample.payload.to_bytes())
        with self._changed:
            self.state.on_queue(group, queue)
            self._changed.notify_all()

    def _on_slot(self, sample: zenoh.Sample) -> None:
        group = group_of(str(sample.key_expr))
        slot = _slot_decoder.decode(sample.payload.to_bytes())
        with self._changed:
            self.state.on_slot(group, slot)
            self._changed.notify_all()

    def controller_alive(self) -> bool:
        return self._controller_key in self._alive.present()

    def send_point(self, group: int, point: Point) -> None:
        self._point_pubs[group].put(encode(point))

    def wait_for(self, condition: Callable[[], bool], timeout: float) -> bool:
        with self._changed:
            return self._changed.wait_for(condition, timeout)

    def controller(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 2.0
    ) -> CommandReply | None:
        reply = call(self.session, self.keys.controller_cmd(verb), request, timeout)
        if reply is not None:
            status_seq = reply.status_seq
            self.wait_for(lambda: self._status_seq() >= status_seq, STATUS_WAIT_S)
        return reply

    def _status_seq(self) -> int:
        status = self.state.status
        return -1 if status is None else status.seq

    def executor(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 1.0
    ) -> CommandReply | None:
        return call(self.session, self.keys.executor_cmd(verb), request, timeout)
