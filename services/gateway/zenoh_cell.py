"""The gateway's ``CellPort`` over Zenoh: the subscriptions ``CellState`` is read from, and the
few things the gateway asks of other services.

The high-rate streams are read on demand, not as they arrive: each group's queue state (every
tick while its ring changes) and slot wait in Zenoh latest-value channels (``RingChannel(1)``),
and whoever decides on the state first drains them (``current``). Delivering each sample to a
Python callback woke the gateway thousands of times a second, every wake-up competing for the
GIL with the motion port's thread, for state read a few hundred times a second at most. The
newest sample is all a reader needs: a queue state replaces the last, and a slot's ``taken_id``
only grows within an interpolator instance (``GroupCredit.on_slot``).

The controller status keeps its callback: it is rare (on change and 10 Hz) and every one
counts, since a not-ready blip between two requests must still end the trajectory
(``CellState.on_status``); a latest-value channel would lose it.

One lock (a condition) covers every change of the state and every decision on it: the status
callback, a drain and the decision after it, and the watchdog, which drains and ages the state
every heartbeat (``CellState.expire``) and subscribes again to a stream that stopped arriving,
so freshness holds even while no request comes.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import zenoh

from motocell.services.gateway.core.cell_state import STATUS_STREAM, CellState, queue_stream
from motocell.shared.bus.channels import Channel, decoded, newest
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.liveness import HEARTBEAT_S
from motocell.shared.bus.schemas import (
    CommandReply,
    CommandRequest,
    ControllerStatus,
    Decoder,
    Point,
    QueueState,
    Slot,
    encode,
)
from motocell.shared.bus.session import Liveness, call, publisher
from motocell.shared.config import Cell

STATUS_WAIT_S = 0.5
"""The controller publishes its status before it replies; this only bounds a lost sample."""
WAIT_POLL_S = 0.001
"""How often ``wait_for`` reads the channels again: nothing notifies a waiter of a queue state
or a slot (no callback runs for them), so a condition on them is polled. Waits are rare
(START_TRAJ_MODE, STOP_MOTION), and 1 ms is short next to what they wait for."""

_status_decoder = Decoder(ControllerStatus)
_queue_decoder = Decoder(QueueState)
_slot_decoder = Decoder(Slot)


def _latest(session: zenoh.Session, key: str) -> Channel:
    return session.declare_subscriber(key, zenoh.handlers.RingChannel(1))


class ZenohCell:
    def __init__(self, cell: Cell, keys: CellKeys, session: zenoh.Session) -> None:
        self.keys = keys
        self.session = session
        groups = range(len(cell.groups))
        self.state = CellState(len(cell.groups), cell.pending_points)
        self._changed = threading.Condition()
        self._controller_key = keys.alive("controller", "0")
        self._alive = Liveness(session, self._controller_key)
        self._point_pubs = [publisher(session, keys.group_point(g), realtime=True) for g in groups]
        self._queues = [_latest(session, keys.group_queue(g)) for g in groups]
        self._slots = [_latest(session, keys.group_slot(g)) for g in groups]
        self._queue_groups = {queue_stream(g): g for g in groups}
        self._status = session.declare_subscriber(keys.controller_status, self._on_status)
        self._stop = threading.Event()
        self._watchdog = threading.Thread(target=self._watch, name="gateway-ages", daemon=True)

    def start(self) -> None:
        self._watchdog.start()

    def close(self) -> None:
        self._stop.set()
        self._watchdog.join(timeout=1.0)

    @contextmanager
    def current(self) -> Iterator[CellState]:
        with self._changed:
            self._drain()
            yield self.state

    def moving(self) -> bool:
        """Whether a newcomer on a port must be refused (``CellState.moving``), read now."""
        with self.current() as state:
            return state.moving()

    def _drain(self) -> None:
        """Apply each group's newest queue state and slot; with the lock held."""
        for group, (queue_channel, slot_channel) in enumerate(
            zip(self._queues, self._slots, strict=True)
        ):
            queue = newest(queue_channel, _queue_decoder)
            if queue is not None:
                self.state.on_queue(group, queue)
            slot = newest(slot_channel, _slot_decoder)
            if slot is not None:
                self.state.on_slot(group, slot)

    def _watch(self) -> None:
        """Every heartbeat: read what arrived, forget what stopped arriving, and subscribe again
        to its stream."""
        while not self._stop.wait(HEARTBEAT_S):
            with self._changed:
                self._drain()
                stopped = set(self.state.expire(time.monotonic()))
                for stream in stopped & self._queue_groups.keys():
                    self._subscribe_queue_again(self._queue_groups[stream])
                if stopped:
                    self._changed.notify_all()
            if STATUS_STREAM in stopped:
                # Outside the lock: undeclaring waits for a callback that may wait for it.
                self._subscribe_status_again()

    def _subscribe_queue_again(self, group: int) -> None:
        """The new subscriber first, so no sample falls between the two; with the lock held."""
        old = self._queues[group]
        self._queues[group] = _latest(self.session, self.keys.group_queue(group))
        queue = newest(old, _queue_decoder)
        if queue is not None:
            self.state.on_queue(group, queue)
        old.undeclare()

    def _subscribe_status_again(self) -> None:
        old = self._status
        self._status = self.session.declare_subscriber(self.keys.controller_status, self._on_status)
        old.undeclare()

    def _on_status(self, sample: zenoh.Sample) -> None:
        status = decoded(sample, _status_decoder)
        if status is None:
            return
        with self._changed:
            self.state.on_status(status)
            self._changed.notify_all()

    def controller_alive(self) -> bool:
        return self._controller_key in self._alive.present()

    def send_point(self, group: int, point: Point) -> None:
        self._point_pubs[group].put(encode(point))

    def wait_for(self, condition: Callable[[], bool], timeout: float) -> bool:
        """A status wakes the wait at once; queue states and slots are read every
        WAIT_POLL_S."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while True:
                self._drain()
                if condition():
                    return True
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._changed.wait(min(left, WAIT_POLL_S))

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
