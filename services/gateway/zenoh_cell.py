"""The gateway's ``CellPort`` over the bus: the subscriptions ``CellState`` is read from, and the
few things the gateway asks of other services.

The high-rate streams are read on demand, not as they arrive: each group's queue state (every
tick while its ring changes) and slot wait in latest-value channels (``Bus.latest``), and
whoever decides on the state first drains them (``current``). A Python callback per sample
would wake the gateway thousands of times a second, every wake-up competing for the GIL with
the motion port's thread, for state read a few hundred times a second at most. The
newest sample is all a reader needs: a queue state replaces the last, and a slot's ``taken_id``
only grows within an interpolator instance (``GroupCredit.on_slot``).

The controller status keeps its callback: it is rare (on change and every heartbeat) and every
one counts, since a not-ready blip between two requests must still end the trajectory
(``CellState.on_status``); a latest-value channel would lose it.

One lock covers every change of the state and every decision on it: the status callback, a
drain and the decision after it, a slot's answer, and the watchdog. No bus call is made while
holding it (a subscription's undeclare waits for its callbacks, which take the lock): the
watchdog decides under the lock what to do, and does it after.

The watchdog sleeps until something could be due: a stream could go stale or a slot is to be
asked for (``CellState.next_check``), the controller's liveliness token is to be asked for
again while it is missing, or a stop. A sample that changes that (a shorter heartbeat, an
interpolator back) wakes it to plan again. An idle cell's gateway thus wakes about once per
at-rest heartbeat, not ten times a second.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from motocell.services.gateway.bus import Bus
from motocell.services.gateway.core.cell_state import (
    STATUS_STREAM,
    CellState,
    queue_stream,
)
from motocell.shared.bus.ignored import decoded_payload
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.liveness import QUERY_TIMEOUT_S, Asking
from motocell.shared.bus.schemas import (
    CommandReply,
    CommandRequest,
    ControllerStatus,
    Decoder,
    MotionHolder,
    Point,
    QueueState,
    Slot,
    encode,
)
from motocell.shared.config import Cell

log = logging.getLogger("gateway")

STATUS_WAIT_S = 0.5
"""The controller publishes its status before it replies; this only bounds a lost sample."""
WAIT_POLL_S = 0.001
"""How often ``wait_for`` reads the channels again: nothing notifies a waiter of a queue state
or a slot (no callback runs for them), so a condition on them is polled. Waits are rare
(START_TRAJ_MODE, STOP_MOTION), and 1 ms is short next to what they wait for."""
STOP_JOIN_S = 5.0
"""How long ``close`` waits for the watchdog, which never blocks on anything but its wait."""

_status_decoder = Decoder(ControllerStatus)
_queue_decoder = Decoder(QueueState)
_slot_decoder = Decoder(Slot)
_reply_decoder = Decoder(CommandReply)


class _CommandQuery:
    """One command query in flight: its reply, filled in on the bus's threads."""

    def __init__(self, key: str) -> None:
        self.key = key
        self.reply: CommandReply | None = None
        self.done = threading.Event()

    def on_reply(self, payload: bytes) -> None:
        reply = decoded_payload(payload, _reply_decoder, self.key)
        if reply is not None and self.reply is None:
            self.reply = reply
            self.done.set()

    def on_done(self) -> None:
        self.done.set()


@dataclass
class _BusChores:
    """What one watchdog pass found to do on the bus, done once the lock is released."""

    again: list[str]
    """Streams to subscribe to again."""
    slots: list[int]
    """Groups whose slot to ask for."""
    tokens: bool
    """Ask for the controller's liveliness token."""


class ZenohCell:
    def __init__(
        self, cell: Cell, keys: CellKeys, bus: Bus, clock: Callable[[], float] = time.monotonic
    ) -> None:
        """Declares the subscriptions; no thread runs and nothing is asked until ``start``.
        ``clock`` gives the instants the state is aged by (tests pass their own)."""
        self.keys = keys
        self.bus = bus
        self._clock = clock
        groups = range(len(cell.groups))
        self.state = CellState(len(cell.groups), cell.pending_points)
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        """Notified on every status, for ``wait_for``."""
        self._watch_wake = threading.Condition(self._lock)
        """Notified when the watchdog must plan again, or stop."""
        self._woken = False
        self._stopping = False
        self.wake_at: float | None = None
        """When the watchdog checks next (None: only when woken), by ``clock``."""
        self._watchdog: threading.Thread | None = None
        self._token_asking = Asking()
        self._queue_keys = [keys.group_queue(g) for g in groups]
        self._slot_keys = [keys.group_slot(g) for g in groups]
        self._queue_groups = {queue_stream(g): g for g in groups}
        self._controller_key = keys.alive("controller", "0")
        self._point_pubs = [bus.publisher(keys.group_point(g), realtime=True) for g in groups]
        self._queues = [bus.latest(key) for key in self._queue_keys]
        self._slots = [bus.latest(key) for key in self._slot_keys]
        self._alive = bus.tokens(self._controller_key, self._wake_watchdog)
        self._status = bus.subscribe(keys.controller_status, self._on_status)

    def start(self) -> None:
        """Start the watchdog: its first pass asks for the controller's token and every slot."""
        self._watchdog = threading.Thread(target=self._watch, name="gateway-watchdog", daemon=True)
        self._watchdog.start()

    def close(self) -> None:
        """Stop and join the watchdog, then undeclare every subscription."""
        with self._lock:
            self._stopping = True
        self._wake_watchdog()
        if self._watchdog is not None:
            self._watchdog.join(STOP_JOIN_S)
            if self._watchdog.is_alive():
                log.warning("the watchdog did not stop within %.0f s", STOP_JOIN_S)
        self._status.undeclare()
        self._alive.close()
        for channel in (*self._queues, *self._slots):
            channel.undeclare()

    @contextmanager
    def current(self) -> Iterator[CellState]:
        with self._lock:
            self._drain(self._clock())
            self._plan_again_if_sooner()
            yield self.state

    def motion_holder(self) -> MotionHolder:
        """Which face holds trajectory mode now (``CellState.motion_holder``)."""
        with self.current() as state:
            return state.motion_holder()

    def moving(self) -> bool:
        """Whether a newcomer on a port must be refused (``CellState.moving``), read now."""
        with self.current() as state:
            return state.moving()

    def _drain(self, now: float) -> None:
        """Apply each group's newest queue state and slot; with the lock held."""
        for group, (queue_channel, slot_channel) in enumerate(
            zip(self._queues, self._slots, strict=True)
        ):
            queue = decoded_payload(queue_channel.take(), _queue_decoder, self._queue_keys[group])
            if queue is not None:
                self.state.on_queue(group, queue, now)
            slot = decoded_payload(slot_channel.take(), _slot_decoder, self._slot_keys[group])
            if slot is not None:
                self.state.on_slot(group, slot)

    def _plan_again_if_sooner(self) -> None:
        """With the lock held: wake the watchdog when something may be due before it wakes."""
        if self.state.sooner():
            self._woken = True
            self._watch_wake.notify()

    def _wake_watchdog(self) -> None:
        with self._lock:
            self._woken = True
            self._watch_wake.notify()

    # -- the watchdog ----------------------------------------------------------------------
    def _watch(self) -> None:
        while True:
            with self._lock:
                if self._stopping:
                    return
                self._woken = False
            wake_at = self.check()
            with self._lock:
                if self._woken or self._stopping:
                    continue  # woken while it checked: what woke it may be due sooner
                self.wake_at = wake_at
                timeout = None if wake_at is None else max(0.0, wake_at - self._clock())
                self._watch_wake.wait(timeout)

    def check(self) -> float | None:
        """One pass of the watchdog: read what arrived, forget what stopped arriving and
        subscribe to it again, ask for what is missing. Returns when the next pass is due (by
        ``clock``), None when nothing can be due before something wakes the watchdog."""
        with self._lock:
            chores = self._due(self._clock())
        self._do(chores)
        with self._lock:
            return self._next_wake()

    def _due(self, now: float) -> _BusChores:
        self._drain(now)
        again = self.state.expire(now)
        slots = self.state.slots_to_ask(now)
        tokens = not self.controller_alive() and self._token_asking.due(now)
        if tokens:
            self._token_asking.asked(now)
        return _BusChores(again, slots, tokens)

    def _do(self, chores: _BusChores) -> None:
        for stream in chores.again:
            if stream == STATUS_STREAM:
                self._subscribe_status_again()
            elif stream in self._queue_groups:
                self._subscribe_group_again(self._queue_groups[stream])
        for group in chores.slots:
            self._ask_slot(group)
        if chores.tokens:
            self._alive.ask()

    def _next_wake(self) -> float | None:
        moments = [self.state.next_check()]
        if not self.controller_alive():
            moments.append(self._token_asking.next)
        return min((moment for moment in moments if moment is not None), default=None)

    def _subscribe_group_again(self, group: int) -> None:
        """The group's queue state and slot: the new subscriptions first, so no sample falls
        between the two, and what the old ones still hold is applied."""
        queue_channel = self.bus.latest(self._queue_keys[group])
        slot_channel = self.bus.latest(self._slot_keys[group])
        with self._lock:
            old = (self._queues[group], self._slots[group])
            self._queues[group], self._slots[group] = queue_channel, slot_channel
            queue = decoded_payload(old[0].take(), _queue_decoder, self._queue_keys[group])
            if queue is not None:
                self.state.on_queue(group, queue, self._clock())
            slot = decoded_payload(old[1].take(), _slot_decoder, self._slot_keys[group])
            if slot is not None:
                self.state.on_slot(group, slot)
        for channel in old:
            channel.undeclare()

    def _subscribe_status_again(self) -> None:
        subscription = self.bus.subscribe(self.keys.controller_status, self._on_status)
        with self._lock:
            old, self._status = self._status, subscription
        old.undeclare()

    def _ask_slot(self, group: int) -> None:
        """Ask the group's interpolator for its slot; the answer is applied as a published
        slot would be."""
        key = self._slot_keys[group]

        def on_reply(payload: bytes) -> None:
            slot = decoded_payload(payload, _slot_decoder, key)
            if slot is not None:
                with self._lock:
                    self.state.on_slot(group, slot)

        def on_done() -> None:
            with self._lock:
                self.state.slot_answered(group, self._clock())
                self._plan_again_if_sooner()

        self.bus.query(key, None, on_reply, on_done, QUERY_TIMEOUT_S)

    def _on_status(self, payload: bytes) -> None:
        status = decoded_payload(payload, _status_decoder, self.keys.controller_status)
        if status is None:
            return
        with self._lock:
            self.state.on_status(status, self._clock())
            self._changed.notify_all()
            self._plan_again_if_sooner()

    # -- CellPort --------------------------------------------------------------------------
    def controller_alive(self) -> bool:
        return self._controller_key in self._alive.present()

    def send_point(self, group: int, point: Point) -> None:
        self._point_pubs[group].put(encode(point))

    def wait_for(self, condition: Callable[[], bool], timeout: float) -> bool:
        """A status wakes the wait at once; queue states and slots are read every
        WAIT_POLL_S. The deadline is on the real clock: this waits for real."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while True:
                self._drain(self._clock())
                self._plan_again_if_sooner()
                if condition():
                    return True
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._changed.wait(min(left, WAIT_POLL_S))

    def controller(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 2.0
    ) -> CommandReply | None:
        reply = self._command(self.keys.controller_cmd(verb), request, timeout)
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
        return self._command(self.keys.executor_cmd(verb), request, timeout)

    def _command(
        self, key: str, request: CommandRequest | None, timeout: float
    ) -> CommandReply | None:
        """One command query; None when nobody answered within ``timeout``. The wait is
        bounded here too, so a query the bus never ends cannot hang a port."""
        query = _CommandQuery(key)
        payload = encode(request or CommandRequest())
        self.bus.query(key, payload, query.on_reply, query.on_done, timeout)
        query.done.wait(timeout)
        return query.reply
