"""One group's pending-point credit: MotoROS's ``hasDataToProcess`` flag (motoros1 §2.4
step 6), held across two processes, and motocell's deeper pending-point FIFO. Pure.

The gateway numbers every point it publishes to a group (``Point.point_id``); the group's
interpolator reports the highest number it has taken (``Slot.taken_id``); the points between
are outstanding. ``accepts_point`` is the one rule for whether another may join them.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import msgspec

from motocell.shared.bus.schemas import Point, QueueState, Slot
from motocell.shared.config import LOOK_AHEAD_POINTS


@dataclass
class GroupCredit:
    queue: QueueState | None = None
    """The executor's last report of the group's ring; None while no executor is known."""
    instance: int = 0
    """The interpolator process the numbering is matched to; 0 until one is heard from."""
    heard: bool = False
    """A slot came from ``instance`` since it was last reported missing."""
    taken: int = 0
    published: int = 0
    trajectory_id: int = 0
    """The point id of the sequence-0 point behind the trajectory the interpolator runs."""
    outstanding: deque[tuple[int, int]] = field(default_factory=deque)
    """(point id, ring entries of its segment) of every point published and not yet taken;
    bounded by what the interpolator has not taken yet."""
    pending_points: int = 1
    """The pending-point FIFO's depth (the cell file's ``pending_points``; 1 as MotoROS)."""

    def on_slot(self, slot: Slot) -> None:
        if slot.instance != self.instance or not self.heard:
            # A (re)started interpolator, a restarted gateway, or one that was missing (its
            # ring was cleared meanwhile, and points published then may be lost): what was
            # numbered before is over. Numbering goes on above every id used so far, so no
            # new point takes the id of an old one the interpolator may have seen.
            self.instance = slot.instance
            self.heard = True
            self.published = max(self.published, slot.taken_id)
            self.taken = self.published
            self.outstanding.clear()
            self.trajectory_id = slot.trajectory_id
            return
        if slot.taken_id < self.taken:
            # Older news: an interpolator's taken_id only grows, and its answer to the
            # gateway's question can arrive after a slot it published later.
            return
        self.taken = slot.taken_id
        self.trajectory_id = slot.trajectory_id
        # Forget the taken points here, where taken advances: a client sending only type-14
        # sequence-0 points never asks pending_fits, and the deque would grow with each.
        while self.outstanding and self.outstanding[0][0] <= self.taken:
            self.outstanding.popleft()

    def interpolator_gone(self) -> None:
        """Its points died with it (or, if it comes back, were dropped with its ring): numbering
        waits for the next slot heard."""
        self.heard = False

    @property
    def known(self) -> bool:
        """Whether the group's interpolator has been heard from. Until then the point numbering
        cannot be matched to it (a restarted gateway starts at 0), so nothing is accepted."""
        return self.heard

    @property
    def ring_ready(self) -> bool:
        """The executor takes increments for this group (it learns of readiness a little after
        the controller decides it)."""
        return self.queue is not None and self.queue.ready

    @property
    def free(self) -> bool:
        return self.taken >= self.published

    @property
    def moving(self) -> bool:
        """Something is queued for the robot in this group, or on its way to the ring."""
        return (self.queue is not None and self.queue.depth > 0) or not self.free

    def accepts_point(self) -> bool:
        """Whether another point (sequence > 0) may be accepted now, or BUSY: fewer than
        ``pending_points`` are outstanding (with 1, MotoROS's free slot), or the look-ahead
        allows it (``pending_fits``). Either way the interpolator holds at most
        ``Cell.points_outstanding`` of them."""
        return self.published - self.taken < self.pending_points or self.pending_fits()

    def pending_fits(self) -> bool:
        """Every outstanding point's segment fits the executor's ring together: the
        interpolator takes each the moment it arrives, so the slot is as good as free.
        Accepting the next point then skips a Zenoh round trip that would otherwise turn most
        points of a fast stream into BUSY plus a 5 ms retry. A wrong guess (the ring state is
        a tick old) only keeps a point waiting in the interpolator, which checks room itself:
        nothing can overflow. At most LOOK_AHEAD_POINTS points are outstanding this way."""
        queue = self.queue
        ahead = self.outstanding
        return (
            queue is not None
            and len(ahead) < LOOK_AHEAD_POINTS
            and len(ahead) == self.published - self.taken
            and queue.depth + sum(entries for _, entries in ahead) <= queue.capacity
        )

    def number(self, point: Point, entries: int) -> Point:
        """Give ``point`` the group's next id and the ring epoch it was checked against; from
        now on the slot counts it as pending, with the ``entries`` its segment will take in
        the ring."""
        self.published += 1
        self.outstanding.append((self.published, entries))
        epoch = self.queue.epoch if self.queue is not None else 0
        return msgspec.structs.replace(point, point_id=self.published, epoch=epoch)

    def trajectory_lost(self, start_id: int) -> bool:
        """The interpolator has taken the sequence-0 point ``start_id`` and no longer runs the
        trajectory it began (its ring was cleared, e.g. the executor lost the controller)."""
        return self.taken >= start_id and self.trajectory_id != start_id
