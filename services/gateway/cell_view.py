"""What the gateway knows of the rest of the cell, kept current by Zenoh subscriptions, and the
few things it asks of other services.

Callbacks only store the newest sample; handlers read it. The pending-slot credits live here:
the gateway numbers every point it publishes to a group, the interpolator reports the highest
number it has taken, and the slot is free when the two agree.
"""

from __future__ import annotations

import threading
import time
from collections import deque

import msgspec
import zenoh

from shared.bus.keys import CellKeys, group_of
from shared.bus.schemas import (
    CommandReply,
    CommandRequest,
    ControllerStatus,
    Decoder,
    Point,
    QueueState,
    Slot,
    State,
    encode,
)
from shared.bus.session import Liveness, call, publisher
from shared.config import Cell
from shared.protocol.constants import NotReadySubcode

MAX_AHEAD = 3
"""Points a group may have outstanding when they all fit its ring (see ``pending_fits``)."""
STATUS_WAIT_S = 0.5
"""The controller publishes its status before it replies; this only bounds a lost sample."""

_status_decoder = Decoder(ControllerStatus)
_queue_decoder = Decoder(QueueState)
_slot_decoder = Decoder(Slot)


class CellView:
    def __init__(self, cell: Cell, keys: CellKeys, session: zenoh.Session) -> None:
        self.cell = cell
        self.keys = keys
        self.session = session
        groups = len(cell.groups)
        self.status: ControllerStatus | None = None
        self.queues: list[QueueState | None] = [None] * groups
        self.taken = [0] * groups
        self.published = [0] * groups
        self._instances = [0] * groups
        self._outstanding: list[deque[tuple[int, int]]] = [deque() for _ in range(groups)]
        self.trajectory_ids = [0] * groups
        self.not_ready_count = 0
        """Counts not-ready statuses seen; a trajectory started before a change is over."""
        self._slots_changed = threading.Condition()
        self._status_changed = threading.Condition()
        self._controller_key = keys.alive("controller", "0")
        self._alive = Liveness(session, self._controller_key)
        self._point_pubs = [
            publisher(session, keys.group_point(g), realtime=True) for g in range(groups)
        ]
        self._entities = [
            session.declare_subscriber(keys.controller_status, self._on_status),
            session.declare_subscriber(keys.group_queue_all, self._on_queue),
            session.declare_subscriber(keys.group_slot_all, self._on_slot),
        ]

    def _on_status(self, sample: zenoh.Sample) -> None:
        status = _status_decoder.decode(sample.payload.to_bytes())
        with self._status_changed:
            if not status.motion_ready:
                self.not_ready_count += 1
            self.status = status
            self._status_changed.notify_all()
        with self._slots_changed:
            if "executor/0" in status.missing_services:
                # Its rings and epochs died with it; wait for the next executor's.
                self.queues = [None] * len(self.queues)
            for service in status.missing_services:
                kind, _, group = service.partition("/")
                if kind == "interpolator" and group.isdigit() and int(group) < len(self.taken):
                    # Its points died with it; whichever process comes next is a new instance
                    # that numbering must wait for.
                    self._instances[int(group)] = 0

    def _on_queue(self, sample: zenoh.Sample) -> None:
        group = group_of(str(sample.key_expr))
        if 0 <= group < len(self.queues):
            queue = _queue_decoder.decode(sample.payload.to_bytes())
            with self._slots_changed:
                self.queues[group] = queue
                self._slots_changed.notify_all()

    def _on_slot(self, sample: zenoh.Sample) -> None:
        group = group_of(str(sample.key_expr))
        if 0 <= group < len(self.taken):
            slot = _slot_decoder.decode(sample.payload.to_bytes())
            with self._slots_changed:
                if slot.instance != self._instances[group]:
                    # A (re)started interpolator, or a restarted gateway: points numbered for
                    # another process are gone, so continue from what this one has taken.
                    self._instances[group] = slot.instance
                    self.published[group] = slot.taken_id
                    self._outstanding[group].clear()
                self.taken[group] = slot.taken_id
                self.trajectory_ids[group] = slot.trajectory_id
                self._slots_changed.notify_all()

    def readiness(self) -> tuple[bool, int]:
        """Motion-ready and the NOT_READY subcode, from the controller's last status. Without a
        live controller nothing can move: INC_MOVE_ERROR, as for any missing service."""
        status = self.status
        if status is None or self._controller_key not in self._alive.present():
            return False, int(NotReadySubcode.INC_MOVE_ERROR)
        if status.motion_ready and not self._executor_and_interpolators_ready():
            # An interpolator not heard from yet: its points could not be numbered.
            return False, int(NotReadySubcode.INC_MOVE_ERROR)
        return status.motion_ready, status.not_ready_subcode

    def wait_slots_known(self, timeout: float) -> bool:
        with self._slots_changed:
            return self._slots_changed.wait_for(self._executor_and_interpolators_ready, timeout)

    def _executor_and_interpolators_ready(self) -> bool:
        """Every interpolator heard from, and the executor itself taking increments (it learns
        of readiness a little after the controller decides it)."""
        return all(self._instances) and all(q is not None and q.ready for q in self.queues)

    def slot_free(self, group: int) -> bool:
        return self.taken[group] >= self.published[group]

    def command_pulses(self, group: int) -> list[int] | None:
        queue = self.queues[group]
        return None if queue is None else queue.command_pulses

    def moving(self) -> bool:
        """Something is queued for the robot (the motion and state ports refuse newcomers)."""
        return any(q is not None and q.depth > 0 for q in self.queues) or not all(
            self.slot_free(g) for g in range(len(self.taken))
        )

    def number_point(self, group: int, point: Point, entries: int) -> Point:
        """Give ``point`` the group's next id and the ring epoch it was checked against; from
        now on the slot counts it as pending, with the ``entries`` its segment will take in
        the ring. Send it with ``send_point``."""
        self.published[group] += 1
        self._outstanding[group].append((self.published[group], entries))
        queue = self.queues[group]
        return msgspec.structs.replace(
            point, point_id=self.published[group], epoch=queue.epoch if queue else 0
        )

    def send_point(self, group: int, point: Point) -> None:
        self._point_pubs[group].put(encode(point))

    def pending_fits(self, group: int) -> bool:
        """Every outstanding point's segment fits the executor's ring together: the
        interpolator takes each the moment it arrives, so the slot is as good as free.
        Accepting the next point then skips a Zenoh round trip that would otherwise turn most
        points of a fast stream into BUSY plus a 5 ms retry. A wrong guess (the ring state is
        a tick old) only keeps a point waiting in the interpolator, which checks room itself:
        nothing can overflow. At most MAX_AHEAD points are ever outstanding."""
        queue = self.queues[group]
        ahead = self._outstanding[group]
        while ahead and ahead[0][0] <= self.taken[group]:
            ahead.popleft()
        return (
            queue is not None
            and len(ahead) < MAX_AHEAD
            and len(ahead) == self.published[group] - self.taken[group]
            and queue.depth + sum(entries for _, entries in ahead) <= queue.capacity
        )

    def slot_known(self, group: int) -> bool:
        """Whether the group's interpolator has been heard from. Until then the point numbering
        cannot be matched to it (a restarted gateway starts at 0), so nothing is accepted."""
        return self._instances[group] != 0

    def trajectory_lost(self, group: int, start_id: int) -> bool:
        """The interpolator has taken the sequence-0 point ``start_id`` and no longer runs the
        trajectory it began (its ring was cleared, e.g. the executor lost the controller)."""
        return self.taken[group] >= start_id and self.trajectory_ids[group] != start_id

    def wait_slots_free(self, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        with self._slots_changed:
            while not all(self.slot_free(g) for g in range(len(self.taken))):
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                self._slots_changed.wait(remaining)
        return True

    def controller(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 2.0
    ) -> CommandReply | None:
        """A controller command; returns once this view has the status that follows it."""
        reply = call(self.session, self.keys.controller_cmd(verb), request, timeout)
        if reply is not None:
            with self._status_changed:
                self._status_changed.wait_for(
                    lambda: self.status is not None and self.status.seq >= reply.status_seq,
                    timeout=STATUS_WAIT_S,
                )
        return reply

    def executor(
        self, verb: str, request: CommandRequest | None = None, timeout: float = 1.0
    ) -> CommandReply | None:
        return call(self.session, self.keys.executor_cmd(verb), request, timeout)


_state_decoder = Decoder(State)


def decode_state(payload: bytes) -> State:
    return _state_decoder.decode(payload)
