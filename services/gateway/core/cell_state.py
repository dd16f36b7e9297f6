"""What the gateway knows of the rest of the cell. Pure: the cell adapter feeds it the samples
(controller status, the executor's ring per group, each interpolator's slot), and the handlers
answer from it without a round trip (ARCHITECTURE "The reply path"). Republished state that
stops arriving is forgotten (``expire``)."""

from __future__ import annotations

from motocell.services.gateway.core.credits import GroupCredit
from motocell.services.gateway.core.freshness import Freshness
from motocell.shared.bus.schemas import ControllerStatus, QueueState, Slot
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

    def on_status(self, status: ControllerStatus) -> None:
        self.freshness.heard(STATUS_STREAM)
        if not status.motion_ready:
            self.not_ready_count += 1
        self.status = status
        if EXECUTOR in status.missing_services:
            # Its rings and epochs died with it; wait for the next executor's.
            for group in self.groups:
                group.queue = None
        for service in status.missing_services:
            kind, _, index = service.partition("/")
            if kind == INTERPOLATOR and index.isdigit() and int(index) < len(self.groups):
                self.groups[int(index)].interpolator_gone()

    def on_queue(self, group: int, queue: QueueState) -> None:
        if 0 <= group < len(self.groups):
            self.freshness.heard(queue_stream(group))
            self.groups[group].queue = queue

    def on_slot(self, group: int, slot: Slot) -> None:
        if 0 <= group < len(self.groups):
            self.groups[group].on_slot(slot)

    def expire(self, now: float) -> list[str]:
        """Call every HEARTBEAT_S. Forget what a stream that stopped last said, as if it had
        never been heard: the status (the controller's readiness may have dropped unseen, so a
        trajectory begun before is over), a group's queue state. Returns the streams to
        subscribe to again now: those that just stopped, and those still stopped a while after
        the last try (see ``Freshness``)."""
        stopped = self.freshness.went_stale(now)
        for stream in stopped:
            if stream == STATUS_STREAM:
                self.status = None
                self.not_ready_count += 1
            for group, credit in enumerate(self.groups):
                if stream == queue_stream(group):
                    credit.queue = None
        return stopped + self.freshness.retry_due()

    def rings_ready(self) -> bool:
        """Every interpolator heard from, and the executor itself taking increments."""
        return all(group.known and group.ring_ready for group in self.groups)

    def readiness(self, controller_alive: bool) -> tuple[bool, int]:
        """Motion-ready and the NOT_READY subcode, from the controller's last status. Without a
        live controller nothing can move: INC_MOVE_ERROR, as for any missing service."""
        status = self.status
        if status is None or not controller_alive:
            return False, int(NotReadySubcode.INC_MOVE_ERROR)
        if status.motion_ready and not self.rings_ready():
            # An interpolator not heard from yet: its points could not be numbered.
            return False, int(NotReadySubcode.INC_MOVE_ERROR)
        return status.motion_ready, status.not_ready_subcode

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
