"""The executor's state as a function of (state, input): rings, epochs, one tick. No clock, no I/O.

Each group has a 200-entry ring (MotoROS Q_SIZE, motoros1 §3.1). Entries arrive in
numbered batches; the ring's *epoch* changes whenever it is cleared, so batches produced for a
cleared trajectory are recognised and dropped instead of moving the robot.
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from motocell.shared.bus.liveness import HEARTBEAT_S
from motocell.shared.bus.schemas import (
    CommandReply,
    GroupTick,
    IncrementBatch,
    Point,
    QueueState,
    Tick,
)
from motocell.shared.config import DEFAULT_MAX_LATENESS_PERIODS, Cell, IdealServo
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.motion.servo import Servos
from motocell.shared.protocol.constants import MAX_AXES, Result

log = logging.getLogger("executor")

RING_CAPACITY = 200
QUEUE_HEARTBEAT_TICKS = 25
"""An unchanged queue state is still published every 100 ms at the default 4 ms period, for
late joiners and for the gateway, which ages what it holds (``heartbeat_ticks``)."""

ZERO = (0,) * MAX_AXES

SOFT_LIMIT_ALARM = 4416
"""The alarm the controller raises when an increment would take an axis past its motion range
(soft limit): Yaskawa's PULSE LIMIT alarm, whose limits are pulse counts in the controller's
parameters (docs/behaviour.md, "Joint limits"). Sent as ``CommandReply.value`` of the
increment-path notice, with the group as its subcode."""


@dataclass(frozen=True)
class Entry:
    increments: tuple[int, ...]
    partial: bool
    tool: int
    sync_id: int = 0
    """Non-zero on the first entry of a trajectory that starts together with ``sync_groups``."""
    sync_groups: tuple[int, ...] = ()


class BatchOutcome(Enum):
    ACCEPTED = "accepted"
    STALE = "stale"
    """For an older epoch: the trajectory it belongs to was cleared."""
    DUPLICATE = "duplicate"
    GAP = "gap"
    """Entries are missing before this batch: motion must stop (DESIGN invariant)."""
    OVERFLOW = "overflow"
    NOT_READY = "not ready"
    MALFORMED = "malformed"
    """Sizes that do not add up: treated like a gap, never allowed to crash the clock."""

    @property
    def breaks_increment_path(self) -> bool:
        """Entries were lost or cannot be taken: motion must stop (DESIGN invariant)."""
        return self in (BatchOutcome.GAP, BatchOutcome.OVERFLOW, BatchOutcome.MALFORMED)


BARRIER_TIMEOUT_TICKS = 250
"""How long a synchronized start waits for a partner group (1 s at 4 ms). Longer means the
partner's increments are not coming: the increment path is broken."""


STALL_ALARM = 4200
"""The alarm the controller raises when the motion system missed its clock (the executor
stalled past its lateness bound, or went without a controller status): a real controller's
motion system stops the servo with a system alarm when its interpolation clock overruns, it
never replays the missed periods. Sent as ``CommandReply.value`` of the increment-path
notice; 0 there means the IncMove error."""
STATUS_SILENCE_HEARTBEATS = 4
"""How many controller heartbeats may go unheard before motion stops: fewer than the
gateway's 5 (``STALE_AFTER_S``), so motion has stopped before a client can be told NOT_READY."""


def stalled(lateness_ns: int, period_ns: int, max_lateness_periods: int) -> bool:
    """Whether a tick this late is a stall: its increments, and all queued behind them, would
    move the robot later than the cell file allows (``max_lateness_periods``)."""
    return lateness_ns > max_lateness_periods * period_ns


def heartbeat_ticks(period_ns: int) -> int:
    """The ticks between heartbeats that keep a queue state at least HEARTBEAT_S fresh."""
    return max(1, int(HEARTBEAT_S * 1e9) // period_ns)


def pulse_ranges(cell: Cell) -> list[tuple[list[int], list[int]]]:
    """Each group's motion range as (lower, upper) pulses in Motoman order (unused axes 0),
    converted as positions are, so a point exactly at a limit lands exactly on it."""
    ranges = []
    for group in cell.groups:
        axis_map = AxisMap(group)
        lower, upper = np.array(group.joint_limits, dtype=np.float64).T
        ranges.append(
            (
                axis_map.pad_moto(axis_map.ros_to_pulses(lower)),
                axis_map.pad_moto(axis_map.ros_to_pulses(upper)),
            )
        )
    return ranges


def starting_pulses(cell: Cell, remembered: CommandReply | None) -> list[list[int]]:
    """Where the robot is: the controller remembers the last commanded pulses across an
    executor restart (``remembered``, its reply to ``positions``); without it, the cell file's
    initial positions."""
    if (
        remembered is not None
        and remembered.result == Result.SUCCESS
        and len(remembered.pulses) == len(cell.groups)
    ):
        log.info("resuming from the controller's last commanded position")
        return remembered.pulses
    pulses = []
    for group in cell.groups:
        axis_map = AxisMap(group)
        pulses.append(axis_map.pad_moto(axis_map.ros_to_pulses(np.array(group.initial_position))))
    return pulses


@dataclass
class GroupRing:
    epoch: int
    received: int = 0
    entries: deque[Entry] = field(default_factory=deque)
    promised: int = 0
    """The highest point (``Point.point_id``, sequence > 0) the gateway published for this
    epoch: its entries are owed to this ring."""
    through: int = 0
    """The highest point whose entries have all arrived (``IncrementBatch.through``)."""
    starved_ticks: int = 0
    """Ticks in a row this ring was empty while owed."""

    @property
    def owed(self) -> bool:
        return self.promised > self.through


class ExecutorCore:
    def __init__(
        self,
        command_pulses: list[list[int]],
        first_epoch: int,
        max_increments: list[list[int]] | None = None,
        heartbeat_ticks: int = QUEUE_HEARTBEAT_TICKS,
        ranges: list[tuple[list[int], list[int]]] | None = None,
        *,
        servos: Servos | None = None,
        max_starved_ticks: int = DEFAULT_MAX_LATENESS_PERIODS,
    ) -> None:
        """``max_increments``: per group and Motoman axis, the most pulses the motion system
        takes in one period (None: no limit). ``heartbeat_ticks``: how often an unchanged queue
        state is published all the same, and the controller's status arrives at least.
        ``servos``: how the feedback follows the command, resting at ``command_pulses``
        (None: ideal, feedback = command). ``max_starved_ticks``: how long a ring may stay
        empty while its interpolator owes it increments (``starved``)."""
        self.command = [list(p) for p in command_pulses]
        self.servos = servos or Servos([IdealServo()] * len(command_pulses), 1.0, command_pulses)
        self.servo_powered = True
        """The controller's last status had the servo on (and not in eco mode); assumed until
        the first status, which changes nothing at rest."""
        self.heartbeat_ticks = heartbeat_ticks
        self.max_increments = max_increments
        self.ranges = ranges
        """Per group, the (lower, upper) pulses of each Motoman axis (None: no limits)."""
        self.beyond_range: dict[int, str] = {}
        """The groups the last tick refused because an axis would pass its range, and why."""
        self.max_starved_ticks = max_starved_ticks
        self.starved: set[int] = set()
        """The groups the last tick stopped because the increments of points the gateway had
        published stopped coming (``GroupRing.owed``) for longer than ``max_starved_ticks``:
        the interpolator, or the network to it, stalled; what it sends late must not move."""
        self._held_ticks = [0] * len(command_pulses)
        self.rings = [GroupRing(first_epoch + g) for g in range(len(command_pulses))]
        self._next_epoch = first_epoch + len(command_pulses)
        self.ready = False
        self.status_ready = False
        """The controller's last status said motion-ready."""
        self.controller_present = False
        """The controller's liveliness token is present."""
        self.awaiting_not_ready = False
        """Motion stopped for a stall: ready statuses are older news until a not-ready one."""
        self._unconfirmed_status = False
        """A ready status arrived while the stall is unconfirmed: the controller is heard again
        (after a router restart, say) and has not had the notice, so it is due at once."""
        self._silent_ticks = 0
        self.tick = 0
        self.last_increment: list[tuple[int, ...]] = [ZERO] * len(command_pulses)
        self._published_queues: list[tuple[object, ...] | None] = [None] * len(command_pulses)

    def accept(self, group: int, batch: IncrementBatch) -> BatchOutcome:
        ring = self.rings[group]
        if batch.epoch != ring.epoch:
            return BatchOutcome.STALE
        if not self.ready:
            # Nothing may be queued while motion is not ready (motoros1 §3.3); renewing the
            # epoch makes the interpolator drop the rest of this trajectory instead of leaving
            # a gap.
            self._clear(ring)
            return BatchOutcome.NOT_READY
        if (
            batch.count < 0
            or batch.first_seq < 0
            or len(batch.increments) != batch.count * MAX_AXES * 4
            or len(batch.times_ns) not in (0, batch.count)
            or any(not 0 <= index < batch.count for index in batch.partial)
        ):
            return BatchOutcome.MALFORMED
        if batch.first_seq + batch.count <= ring.received:
            return BatchOutcome.DUPLICATE
        if batch.first_seq != ring.received:
            return BatchOutcome.GAP
        if len(ring.entries) + batch.count > RING_CAPACITY:
            return BatchOutcome.OVERFLOW
        rows = np.frombuffer(batch.increments, dtype="<i4").reshape(batch.count, MAX_AXES)
        partial = set(batch.partial)
        for index, row in enumerate(rows.tolist()):
            if index == 0 and batch.sync_id:
                entry = Entry(
                    tuple(row),
                    index in partial,
                    batch.tool,
                    batch.sync_id,
                    tuple(batch.sync_groups),
                )
            else:
                entry = Entry(tuple(row), index in partial, batch.tool)
            ring.entries.append(entry)
        ring.received += batch.count
        ring.through = max(ring.through, batch.through)
        return BatchOutcome.ACCEPTED

    def on_point(self, group: int, point: Point) -> None:
        """A point the gateway published to ``group``'s interpolator: once it is for this
        ring's epoch and continues a trajectory (sequence > 0), its entries are owed. A
        sequence-0 point only starts a trajectory: nothing is owed until its next point."""
        ring = self.rings[group]
        if point.epoch == ring.epoch and point.sequence > 0:
            ring.promised = max(ring.promised, point.point_id)

    def _clear(self, ring: GroupRing) -> None:
        ring.entries.clear()
        ring.epoch = self._next_epoch
        ring.received = 0
        ring.promised = ring.through = 0
        ring.starved_ticks = 0
        self._next_epoch += 1

    def clear_all(self) -> None:
        for ring in self.rings:
            self._clear(ring)

    def set_ready(self, ready: bool) -> None:
        """Motion-ready from the controller; dropping it clears every ring (motoros1 §3.3)."""
        if self.ready and not ready:
            self.clear_all()
        self.ready = ready

    def on_status(self, motion_ready: bool, servo_powered: bool) -> None:
        """A controller status, in the order they were published."""
        self._silent_ticks = 0
        self.servo_powered = servo_powered
        if self.awaiting_not_ready and motion_ready:
            self._unconfirmed_status = True
            return
        self.awaiting_not_ready = False
        self.status_ready = motion_ready
        self.update_ready()

    def controller_silent(self) -> bool:
        """Counts one tick; true once a ready executor has heard no controller status for
        ``STATUS_SILENCE_HEARTBEATS`` heartbeats (the controller or the router stalled)."""
        self._silent_ticks += 1
        return self.ready and self._silent_ticks > STATUS_SILENCE_HEARTBEATS * self.heartbeat_ticks

    def stop_for_stall(self) -> None:
        """A stall past the lateness bound: every ring cleared, nothing applied late, and not
        ready until the controller has said so itself (its alarm), so no ready status sent
        before the alarm restarts motion."""
        self.clear_all()
        self.status_ready = False
        self.awaiting_not_ready = True
        self.update_ready()

    def stall_notice_due(self, ticks_per_second: int) -> bool:
        """Once a second while the controller has not confirmed the stall, and at once when it
        is heard saying ready: a notice lost while the router itself stalled is sent again
        (without waiting up to a second, in which a client would see the cell ready)."""
        heard, self._unconfirmed_status = self._unconfirmed_status, False
        return self.awaiting_not_ready and (heard or self.tick % ticks_per_second == 0)

    def update_ready(self) -> None:
        """Motion-ready needs both a ready status and a controller alive to have sent it."""
        self.set_ready(self.status_ready and self.controller_present)

    def step(self) -> list[int]:
        """One interpolation period: at most one (merged) increment per group, all applied
        together in one call, like MotoROS's single IncMove call per tick (motoros1 §5.3).

        Returns the groups whose increments the motion system refused (beyond an axis's
        maximum per period, or past its range: ``beyond_range``), whose synchronized start
        waited too long, or whose increments stopped coming mid-trajectory (``starved``).
        Then nothing is applied this tick, as a rejected IncMove call moves no group; the
        caller stops motion (MotoROS 1.9.5: NOT_READY 5012 until
        START_TRAJ_MODE; at a range limit, alarm ``SOFT_LIMIT_ALARM``)."""
        self.tick += 1
        held = self._waiting_for_partners()
        broken = [g for g in held if self._held_ticks[g] > BARRIER_TIMEOUT_TICKS]
        self.starved = self._starved_groups()
        broken += sorted(self.starved)
        increments = [
            self._pop_period(ring) if self.ready and group not in held else ZERO
            for group, ring in enumerate(self.rings)
        ]
        broken += [g for g, inc in enumerate(increments) if not self._within_limits(g, inc)]
        self.beyond_range = self._beyond_range(increments)
        broken += [g for g in self.beyond_range if g not in broken]
        if broken:
            increments = [ZERO] * len(self.rings)
        for group, increment in enumerate(increments):
            self.last_increment[group] = increment
            if increment is not ZERO:
                command = self.command[group]
                for axis in range(MAX_AXES):
                    command[axis] += increment[axis]
        self._drive()
        return broken

    def _starved_groups(self) -> set[int]:
        """Counts this tick for every ring that is empty while owed; the groups past the bound.
        A ring that runs dry with nothing owed is a client that is late, which MotoROS waits
        for: no error."""
        starved = set()
        for group, ring in enumerate(self.rings):
            if self.ready and ring.owed and not ring.entries:
                ring.starved_ticks += 1
            else:
                ring.starved_ticks = 0
            if ring.starved_ticks > self.max_starved_ticks:
                starved.add(group)
        return starved

    def _drive(self) -> None:
        """The servos follow this period's command; with the servo off every axis stands where
        its feedback is and the command is set to it, as a controller does, so the next
        servo-on moves nothing. Nothing moves then anyway: servo off is never motion-ready."""
        if self.servo_powered:
            self.servos.step(self.command)
        else:
            self.command = self.servos.brake().tolist()

    def _within_limits(self, group: int, increment: tuple[int, ...]) -> bool:
        if self.max_increments is None or increment is ZERO:
            return True
        limits = self.max_increments[group]
        return all(abs(inc) <= limit for inc, limit in zip(increment, limits, strict=True))

    def _beyond_range(self, increments: list[tuple[int, ...]]) -> dict[int, str]:
        """The groups whose increment would take an axis past its range, as a controller's
        motion-range check refuses them: an axis may end exactly on a limit, and one already
        outside (a range narrowed since) may still move back towards it."""
        found = {}
        for group, increment in enumerate(increments):
            if self.ranges is None or increment is ZERO:
                continue
            lower, upper = self.ranges[group]
            for axis, (now, step, low, high) in enumerate(
                zip(self.command[group], increment, lower, upper, strict=True)
            ):
                target = now + step
                if (target > high and step > 0) or (target < low and step < 0):
                    found[group] = (
                        f"axis {axis} would reach {target} pulses, past its range [{low}, {high}]"
                    )
                    break
        return found

    def _waiting_for_partners(self) -> set[int]:
        """Groups whose next entry starts a synchronized (2016) trajectory while a partner
        group's start entry has not reached the head of its ring yet: they wait, so all start
        in the same tick whichever interpolator was first."""
        held = set()
        for group, ring in enumerate(self.rings):
            head = ring.entries[0] if ring.entries else None
            if head is None or not head.sync_id or not self.ready:
                self._held_ticks[group] = 0
                continue
            for partner in head.sync_groups:
                entries = self.rings[partner].entries if 0 <= partner < len(self.rings) else ()
                if not entries or entries[0].sync_id != head.sync_id:
                    held.add(group)
                    break
            self._held_ticks[group] = self._held_ticks[group] + 1 if group in held else 0
        return held

    @staticmethod
    def _pop_period(ring: GroupRing) -> tuple[int, ...]:
        """Pop the head entry and, while the last popped is a partial period (an off-grid
        waypoint), the next one too, so every tick moves one full period (motoros1 §5.3
        merge)."""
        if not ring.entries:
            return ZERO
        entry = ring.entries.popleft()
        total = list(entry.increments)
        while (
            entry.partial
            and ring.entries
            and ring.entries[0].tool == entry.tool
            and not ring.entries[0].sync_id
        ):
            entry = ring.entries.popleft()
            for axis in range(MAX_AXES):
                total[axis] += entry.increments[axis]
        return tuple(total)

    def queue_state(self, group: int) -> QueueState:
        ring = self.rings[group]
        return QueueState(
            epoch=ring.epoch,
            received=ring.received,
            depth=len(ring.entries),
            capacity=RING_CAPACITY,
            command_pulses=list(self.command[group]),
            tick=self.tick,
            ready=self.ready,
        )

    def group_ticks(self) -> list[GroupTick]:
        feedback = self.servos.feedback_pulses().tolist()
        moved = self.servos.moved.tolist()
        return [
            GroupTick(
                command_pulses=list(self.command[g]),
                feedback_pulses=feedback[g],
                increment=list(self.last_increment[g]),
                depth=len(ring.entries),
                feedback_moved=moved[g],
            )
            for g, ring in enumerate(self.rings)
        ]

    def queue_updates(self, force: bool = False) -> list[tuple[int, QueueState]]:
        """The queue states to publish now: each that changed (every tick while moving), and
        all of them at the heartbeat or when ``force``d, so idle interpolators and gateways
        need not wake 250 times a second."""
        heartbeat = force or self.tick % self.heartbeat_ticks == 0
        updates = []
        for group in range(len(self.rings)):
            state = self.queue_state(group)
            content = (
                state.epoch,
                state.received,
                state.depth,
                tuple(state.command_pulses),
                state.ready,
            )
            if heartbeat or content != self._published_queues[group]:
                self._published_queues[group] = content
                updates.append((group, state))
        return updates

    def tick_report(self, deadline_ns: int, lateness_ns: int, missed: int) -> Tick:
        """What the motion system did this period, for the broadcaster and observers."""
        return Tick(
            tick=self.tick,
            deadline_ns=deadline_ns,
            lateness_ns=lateness_ns,
            missed=missed,
            motion_ready=self.ready,
            groups=self.group_ticks(),
        )
