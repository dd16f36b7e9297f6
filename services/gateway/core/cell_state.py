"""What the gateway knows of the rest of the cell. Pure: the cell adapter feeds it the samples
(controller status, the executor's ring per group, each interpolator's slot) with the instant
it read them, and the handlers answer from it without a round trip (ARCHITECTURE "The reply
path"). Republished state that stops arriving is forgotten (``expire``); a slot the gateway
lacks is asked for (``slots_to_ask``), since interpolators publish theirs only when it
changes."""

from __future__ import annotations

from motocell.services.gateway.core.credits import GroupCredit
from motocell.services.gateway.core.freshness import Freshness
from motocell.services.gateway.core.sources import (
    HOLDER,
    OTHER_HOLDS_SUBCODE,
    MotionSources,
    Source,
)
from motocell.shared.bus.liveness import Asking
from motocell.shared.bus.schemas import ControllerStatus, MotionHolder, QueueState, Slot
from motocell.shared.protocol.constants import NotReadySubcode

EXECUTOR = "executor/0"
INTERPOLATOR = "interpolator"
STATUS_STREAM = "controller/status"


def queue_stream(group: int) -> str:
    return f"group/{group}/queue"


class CellState:
    def __init__(self, groups: int, pending_points: int = 1) -> None:
        self.status: ControllerStatus | None = None
        self.not_ready_count = 0
        """Counts not-ready statuses seen; a trajectory started before a change is over."""
        self.groups = [GroupCredit(pending_points=pending_points) for _ in range(groups)]
        self.freshness = Freshness()
        self._missing: frozenset[int] = frozenset()
        """The groups whose interpolator the last status reported missing."""
        self._doubted: set[int] = set()
        """Groups whose slot may be out of date: their queue stream stopped reaching the
        gateway, and a slot published meanwhile may have been lost the same way."""
        self._asking = [Asking() for _ in range(groups)]
        self._replan = False
        self.sources = MotionSources()
        """Which face holds trajectory mode: decided inside ``CellPort.current`` like the rest."""

    def on_status(self, status: ControllerStatus, now: float) -> None:
        self.freshness.heard(STATUS_STREAM, now, status.heartbeat_ms)
        if not status.motion_ready:
            self.not_ready_count += 1
        self.status = status
        if EXECUTOR in status.missing_services:
            # Its rings and epochs died with it; wait for the next executor's.
            for credit in self.groups:
                credit.queue = None
        missing = self._missing_interpolators(status)
        for group in missing:
            self.groups[group].interpolator_gone()
        for group in self._missing - missing:
            # A new process, whose slot may not be published until it changes: ask now.
            self._asking[group].renew()
            self._replan = True
        self._missing = missing

    def _missing_interpolators(self, status: ControllerStatus) -> frozenset[int]:
        groups = set()
        for service in status.missing_services:
            kind, _, index = service.partition("/")
            if kind == INTERPOLATOR and index.isdigit() and int(index) < len(self.groups):
                groups.add(int(index))
        return frozenset(groups)

    def on_queue(self, group: int, queue: QueueState, now: float) -> None:
        if 0 <= group < len(self.groups):
            self.freshness.heard(queue_stream(group), now, queue.heartbeat_ms)
            self.groups[group].queue = queue

    def on_slot(self, group: int, slot: Slot) -> None:
        if 0 <= group < len(self.groups):
            self.groups[group].on_slot(slot)

    def expire(self, now: float) -> list[str]:
        """Call at ``next_check`` (or sooner). Forget what a stream that stopped last said, as
        if it had never been heard: the status (the controller's readiness may have dropped
        unseen, so a trajectory begun before is over), a group's queue state. Returns the
        streams to subscribe to again now: those that just stopped, and those still stopped a
        while after the last try (see ``Freshness``)."""
        stopped = self.freshness.went_stale(now)
        for stream in stopped:
            if stream == STATUS_STREAM:
                self.status = None
                self.not_ready_count += 1
            for group, credit in enumerate(self.groups):
                if stream == queue_stream(group):
                    credit.queue = None
        again = stopped + self.freshness.retry_due()
        for group in range(len(self.groups)):
            if queue_stream(group) in again:
                self._doubted.add(group)
        return again

    def slots_to_ask(self, now: float) -> list[int]:
        """The groups whose interpolator to ask for its slot now: the gateway has none (none
        heard yet, or forgotten with a missing interpolator) or doubts it, the interpolator is
        not reported missing, and it was not asked too recently (``Asking``)."""
        due = [group for group in self._slots_wanted() if self._asking[group].due(now)]
        for group in due:
            self._asking[group].asked(now)
            self._doubted.discard(group)
        return due

    def slot_answered(self, group: int, now: float) -> None:
        """The question ``slots_to_ask`` gave for ``group`` is finished, answered or not."""
        self._asking[group].finished(now)
        self._replan = True

    def _slots_wanted(self) -> list[int]:
        return [
            group
            for group, credit in enumerate(self.groups)
            if (not credit.known or group in self._doubted) and group not in self._missing
        ]

    def next_check(self) -> float | None:
        """When to call ``expire`` and ``slots_to_ask`` next, if nothing is heard meanwhile:
        the moment a stream could go stale, or a slot is due to be asked for; None when
        nothing is due ever."""
        self._replan = False
        moments = [self._asking[group].next for group in self._slots_wanted()]
        stale = self.freshness.next_check()
        if stale is not None:
            moments.append(stale)
        return min(moments, default=None)

    def sooner(self) -> bool:
        """Whether something since the last ``next_check`` may be due before the moment it
        gave (a shorter heartbeat, an interpolator back, a question finished): ask again."""
        return self._replan or self.freshness.sooner()

    def rings_ready(self) -> bool:
        """Every interpolator heard from, and the executor itself taking increments."""
        return all(group.known and group.ring_ready for group in self.groups)

    def readiness(self, controller_alive: bool, source: Source) -> tuple[bool, int]:
        """Motion-ready for ``source`` and the NOT_READY subcode, from the controller's last
        status. Without a live controller nothing can move: INC_MOVE_ERROR, as for any missing
        service. While the other face holds trajectory mode, not for this one."""
        status = self.status
        if status is None or not controller_alive:
            return False, int(NotReadySubcode.INC_MOVE_ERROR)
        if self.held_by_other(source):
            return False, OTHER_HOLDS_SUBCODE[source]
        if status.motion_ready and not self.rings_ready():
            # An interpolator not heard from yet: its points could not be numbered.
            return False, int(NotReadySubcode.INC_MOVE_ERROR)
        return status.motion_ready, status.not_ready_subcode

    def held_by_other(self, source: Source) -> bool:
        return self.sources.held_by_other(source, self._operating())

    def motion_holder(self) -> MotionHolder:
        holding = self.sources.holding(self._operating())
        return MotionHolder.NOBODY if holding is None else HOLDER[holding]

    def _operating(self) -> bool:
        return self.status is not None and self.status.operating

    def queue_count(self, group: int) -> int | None:
        """CHECK_QUEUE_CNT (motoros1 §2.3): the increment entries in the group's ring, not
        points, nor the pending ones, as the executor last published them (at most a tick old
        while they change). None for a group the cell lacks or a ring not known (no executor
        heard)."""
        if not 0 <= group < len(self.groups):
            return None
        queue = self.groups[group].queue
        return None if queue is None else queue.depth

    def idle(self) -> bool:
        """Every ring known and empty, every slot free: STOP_TRAJ_MODE may end the mode."""
        return self.slots_free() and all(
            self.queue_count(group) == 0 for group in range(len(self.groups))
        )

    def slots_free(self) -> bool:
        return all(group.free for group in self.groups)

    def moving(self) -> bool:
        """Something is queued for the robot (the motion and state ports refuse newcomers)."""
        return any(group.moving for group in self.groups)
