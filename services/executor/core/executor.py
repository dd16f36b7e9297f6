"""The executor's decisions as a function of (state, input): readiness, the rings, one tick, what
is refused. No clock, no I/O: every time is passed in (CLOCK_MONOTONIC nanoseconds). When a
queue state goes out is ``queue_cadence``'s, when the clock rests ``resting``'s.

What it tells the controller (the IncMove error, a stall, a range limit) waits in ``notices``
until the caller sends it.
"""

from __future__ import annotations

import logging

from motocell.services.executor.core.queue_cadence import QueueCadence
from motocell.services.executor.core.resting import Resting
from motocell.services.executor.core.rings import RING_CAPACITY, ZERO, BatchOutcome, GroupRing
from motocell.services.executor.core.states import (
    Action,
    Readiness,
    ReadinessEvent,
    ReadinessMachine,
)
from motocell.shared.bus.liveness import SILENT_HEARTBEATS, heartbeat_ms, silence_bound_s
from motocell.shared.bus.schemas import (
    CommandReply,
    ControllerStatus,
    GroupTick,
    IncrementBatch,
    Point,
    QueueState,
    Tick,
)
from motocell.shared.config import DEFAULT_MAX_LATENESS_PERIODS, IdealServo
from motocell.shared.motion.servo import Servos
from motocell.shared.protocol.constants import Result

log = logging.getLogger("executor")

SOFT_LIMIT_ALARM = 4416
"""The alarm the controller raises when an increment would take an axis past its motion range
(soft limit): Yaskawa's PULSE LIMIT alarm, whose limits are pulse counts in the controller's
parameters (docs/behaviour.md, "Joint limits"). Sent as ``CommandReply.value`` of the
increment-path notice, with the group as its subcode."""

STALL_ALARM = 4200
"""The alarm the controller raises when the motion system missed its clock (the executor
stalled past its lateness bound, or went without a controller status): a real controller's
motion system stops the servo with a system alarm when its interpolation clock overruns, it
never replays the missed periods. Sent as ``CommandReply.value`` of the increment-path
notice; 0 there means the IncMove error."""

BARRIER_TIMEOUT_TICKS = 250
"""How long a synchronized start waits for a partner group (1 s at 4 ms). Longer means the
partner's increments are not coming: the increment path is broken."""

NOTICE_EVERY_NS = 1_000_000_000
"""How often an unconfirmed stall is told again."""


def stalled(lateness_ns: int, period_ns: int, max_lateness_periods: int) -> bool:
    """Whether a tick this late is a stall: its increments, and all queued behind them, would
    move the robot later than the cell file allows (``max_lateness_periods``)."""
    return lateness_ns > max_lateness_periods * period_ns


def _too_fast(row: tuple[int, ...], most: list[int]) -> bool:
    """Whether an axis's increment exceeds its maximum per period. A loop rather than
    ``any()`` over a generator, which costs a generator per group and tick."""
    for increment, limit in zip(row, most, strict=True):
        if increment > limit or -increment > limit:
            return True
    return False


class ExecutorCore:
    def __init__(
        self,
        command_pulses: list[list[int]],
        first_epoch: int,
        max_increments: list[list[int]] | None = None,
        ranges: list[tuple[list[int], list[int]]] | None = None,
        *,
        period_ns: int = 4_000_000,
        servos: Servos | None = None,
        max_lateness_periods: int = DEFAULT_MAX_LATENESS_PERIODS,
    ) -> None:
        """``max_increments``: per group and Motoman axis, the most pulses the motion system
        takes in one period (None: no limit). ``ranges``: per group, the (lower, upper) pulses
        of each Motoman axis (None: no limits). ``servos``: how the feedback follows the
        command, resting at ``command_pulses`` (None: ideal, feedback = command).
        ``max_lateness_periods``: how late a tick may be, and how long a ring may stay empty
        while its interpolator owes it increments (``starved``)."""
        self.command: list[list[int]] = [[int(p) for p in row] for row in command_pulses]
        """The commanded pulses, one row per group, Motoman order (``MAX_AXES`` each). Plain
        ints, as everything the tick computes per axis: numpy's call overhead on rows of 8
        costs more than the arithmetic (docs/realtime.md, "The tick's cost"). A row is replaced,
        never changed in place, so ``QueueCadence`` may keep it to compare with."""
        self.servos = servos or Servos([IdealServo()] * len(command_pulses), 1.0, command_pulses)
        self.servo_powered = True
        """The controller's last status had the servo on (and not in eco mode); assumed until
        the first status, which changes nothing at rest."""
        self.period_ns = period_ns
        self.max_lateness_periods = max_lateness_periods
        self._max_increments = max_increments
        self._ranges = ranges
        self.readiness = ReadinessMachine()
        self.rings = [GroupRing(first_epoch + g) for g in range(len(command_pulses))]
        self._next_epoch = first_epoch + len(command_pulses)
        self.tick = 0
        self.last_increment: list[tuple[int, ...]] = [ZERO] * len(command_pulses)
        self.beyond_range: dict[int, str] = {}
        """The groups the last tick refused because an axis would pass its range, and why."""
        self.starved: set[int] = set()
        """The groups the last tick stopped because the increments of points the gateway had
        published stopped coming (``GroupRing.owed``) for longer than the lateness bound: the
        interpolator, or the network to it, stalled; what it sends late must not move."""
        self._held_ticks = [0] * len(command_pulses)
        self.notices: list[CommandReply] = []
        """What the controller must be told (``controller/cmd/incmove_error``), oldest first."""
        self._last_status_ns: int | None = None
        self._status_heartbeat_ms = heartbeat_ms(motion_possible=True)
        self._last_notice_ns = 0
        self.rest = Resting()
        """Whether the clock rests (``rest.resting``): the loop stops ticking while it does."""
        self._queue_cadence = QueueCadence(self.rings)

    # -- readiness ---------------------------------------------------------------------------

    @property
    def ready(self) -> bool:
        return self.readiness.ready

    def on_status(self, status: ControllerStatus, received_ns: int) -> None:
        """A controller status, in the order they were published, as it arrived."""
        self._last_status_ns = received_ns
        self._status_heartbeat_ms = status.heartbeat_ms
        self.servo_powered = status.servo_on and not status.eco
        if any(alarm.code == STALL_ALARM for alarm in status.alarms):
            event = ReadinessEvent.ALARM_STATUS
        elif status.motion_ready:
            event = ReadinessEvent.READY_STATUS
        else:
            event = ReadinessEvent.NOT_READY_STATUS
        self._take(event, received_ns, "stall not yet confirmed by the controller")

    def on_controller(self, present: bool, now_ns: int) -> None:
        """Whether the controller's liveliness token is present."""
        self._take(
            ReadinessEvent.CONTROLLER_BACK if present else ReadinessEvent.CONTROLLER_GONE, now_ns
        )

    def _take(self, event: ReadinessEvent, now_ns: int, reason: str = "") -> None:
        before = self.readiness.state
        actions = self.readiness.on(event)
        if Action.CLEAR_RINGS in actions:
            self.clear_all()
        if Action.NOTICE in actions:
            if before is not Readiness.STALLED:
                log.error("%s; stopping motion (alarm %d)", reason, STALL_ALARM)
            self.notices.append(CommandReply(Result.FAILURE, value=STALL_ALARM, detail=reason))
            self._last_notice_ns = now_ns

    def controller_silent(self, now_ns: int) -> bool:
        """A ready executor has heard no controller status for ``SILENT_HEARTBEATS`` of the
        heartbeat the controller announced (the controller or the router stalled)."""
        if not self.ready or self._last_status_ns is None:
            return False
        bound = silence_bound_s(self._status_heartbeat_ms, SILENT_HEARTBEATS)
        return now_ns - self._last_status_ns > bound * 1e9

    # -- inputs ------------------------------------------------------------------------------

    def accept(self, group: int, batch: IncrementBatch | None) -> BatchOutcome:
        """A batch from ``group``'s interpolator (None: it did not decode). One that breaks the
        increment path stops motion (``notices``)."""
        ring = self.rings[group]
        if batch is not None and batch.epoch != ring.epoch:
            return BatchOutcome.STALE
        if not self.ready:
            # Nothing may be queued while motion is not ready (motoros1 §3.3); renewing the
            # epoch makes the interpolator drop the rest of this trajectory instead of leaving
            # a gap.
            self._clear(ring)
            return BatchOutcome.NOT_READY
        outcome = BatchOutcome.MALFORMED if batch is None else ring.check(batch)
        if outcome is BatchOutcome.ACCEPTED and batch is not None:
            ring.append(batch)
            self._run_clock()
        elif outcome.breaks_increment_path:
            self._increment_path_broken(group, f"increment batch {outcome.value}")
        return outcome

    def on_point(self, group: int, point: Point) -> None:
        """A point the gateway published to ``group``'s interpolator: increments follow, so
        the clock runs. Once it is for this ring's epoch and continues a trajectory (sequence
        > 0), its entries are owed. A sequence-0 point only starts a trajectory: nothing is
        owed until its next point."""
        self._run_clock()
        ring = self.rings[group]
        if point.epoch == ring.epoch and point.sequence > 0:
            ring.promised = max(ring.promised, point.point_id)

    def on_stop(self) -> None:
        """STOP_MOTION: every ring cleared before the next tick applies anything."""
        self.clear_all()

    def _clear(self, ring: GroupRing) -> None:
        ring.clear(self._next_epoch)
        self._next_epoch += 1

    def clear_all(self) -> None:
        for ring in self.rings:
            self._clear(ring)

    def _increment_path_broken(self, group: int, reason: str, alarm: int = 0) -> None:
        """Stop everything and have the controller raise the IncMove error (NOT_READY 5012
        until START_TRAJ_MODE), as MotoROS 1.9.5 does when an increment is rejected, or
        ``alarm`` when it is not 0."""
        log.error("group %d: %s; stopping motion", group, reason)
        self.clear_all()
        self.notices.append(CommandReply(Result.FAILURE, group, value=alarm, detail=reason))

    def take_notices(self) -> list[CommandReply]:
        notices, self.notices = self.notices, []
        return notices

    # -- the tick ----------------------------------------------------------------------------

    def on_tick(self, deadline_ns: int, lateness_ns: int, periods: int = 1) -> bool:
        """One tick, ``periods`` after the last (more after a rest): the stall checks, then
        ``step``. Returns whether the clock must restart from now: a tick past the lateness
        bound is not caught up on."""
        now_ns = deadline_ns + lateness_ns
        self.tick += periods
        late = stalled(lateness_ns, self.period_ns, self.max_lateness_periods)
        if late:
            self._take(ReadinessEvent.STALL, now_ns, f"tick {lateness_ns / 1e6:.1f} ms late")
        elif self.controller_silent(now_ns):
            self._take(ReadinessEvent.STALL, now_ns, "no controller status heard")
        self.notice_if_due(now_ns)
        for group in self.step():
            if group in self.beyond_range:
                self._increment_path_broken(group, self.beyond_range[group], SOFT_LIMIT_ALARM)
            elif group in self.starved:
                self._increment_path_broken(group, "increments stopped mid-trajectory")
            else:
                self._increment_path_broken(group, "refused by the motion system")
        if self.rest.after_tick(self.quiet(), now_ns):
            self._queue_cadence.restart_heartbeat()  # tell the long heartbeat at once
        return late

    def notice_if_due(self, now_ns: int) -> None:
        """Tell an unconfirmed stall again once a second."""
        if self.readiness.stalled and now_ns - self._last_notice_ns >= NOTICE_EVERY_NS:
            self._take(
                ReadinessEvent.NOTICE_DUE, now_ns, "stall not yet confirmed by the controller"
            )

    def step(self) -> list[int]:
        """One interpolation period: at most one (merged) increment per group, all applied
        together in one call, like MotoROS's single IncMove call per tick (motoros1 §5.3).

        Returns the groups whose increments the motion system refused (beyond an axis's
        maximum per period, or past its range: ``beyond_range``), whose synchronized start
        waited too long, or whose increments stopped coming mid-trajectory (``starved``).
        Then nothing is applied this tick, as a rejected IncMove call moves no group."""
        held = self._waiting_for_partners()
        broken = [g for g in held if self._held_ticks[g] > BARRIER_TIMEOUT_TICKS]
        self.starved = self._starved_groups()
        broken += sorted(self.starved)
        ready = self.ready
        rows = [
            ring.pop_period() if ready and group not in held else ZERO
            for group, ring in enumerate(self.rings)
        ]
        broken += [g for g in self._over_limits(rows) if g not in broken]
        self.beyond_range = self._beyond_range(rows)
        broken += [g for g in self.beyond_range if g not in broken]
        if broken:
            rows = [ZERO] * len(self.rings)
        self.last_increment = rows
        self.command = [
            command if row == ZERO else [c + i for c, i in zip(command, row, strict=True)]
            for command, row in zip(self.command, rows, strict=True)
        ]
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
            if ring.starved_ticks > self.max_lateness_periods:
                starved.add(group)
        return starved

    def _drive(self) -> None:
        """The servos follow this period's command; with the servo off every axis stands where
        its feedback is and the command is set to it, as a controller does, so the next
        servo-on moves nothing. Nothing moves then anyway: servo off is never motion-ready."""
        if self.servo_powered:
            self.servos.step(self.command)
        else:
            self.command = self.servos.brake()

    def _over_limits(self, rows: list[tuple[int, ...]]) -> list[int]:
        """The groups whose increment exceeds an axis's maximum per period (the motion
        system's speed limit)."""
        if self._max_increments is None:
            return []
        return [
            group
            for group, (row, most) in enumerate(zip(rows, self._max_increments, strict=True))
            if row != ZERO and _too_fast(row, most)
        ]

    def _beyond_range(self, rows: list[tuple[int, ...]]) -> dict[int, str]:
        """The groups whose increment would take an axis past its range, as a controller's
        motion-range check refuses them: an axis may end exactly on a limit, and one already
        outside (a range narrowed since) may still move back towards it."""
        if self._ranges is None:
            return {}
        found = {}
        for group, row in enumerate(rows):
            if row == ZERO:
                continue
            low, high = self._ranges[group]
            for axis, (c, i) in enumerate(zip(self.command[group], row, strict=True)):
                target = c + i
                if (i > 0 and target > high[axis]) or (i < 0 and target < low[axis]):
                    found[group] = (
                        f"axis {axis} would reach {target} pulses, "
                        f"past its range [{low[axis]}, {high[axis]}]"
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

    # -- rest --------------------------------------------------------------------------------

    def _run_clock(self) -> None:
        """Motion is asked for: a resting clock runs again, and its queue states announce the
        short heartbeat from the next one on, which must then come that soon."""
        if self.rest.wake():
            self._queue_cadence.restart_heartbeat()

    def quiet(self) -> bool:
        """Nothing for the clock to do: every ring empty and owed nothing, no synchronized
        start waiting, every axis settled on its command."""
        return (
            all(not ring.entries and not ring.owed for ring in self.rings)
            and not any(self._held_ticks)
            and self.servos.at_rest
        )

    def rest_deadline(self) -> int:
        """When a resting clock must wake even if nothing arrives: the queue heartbeat, or the
        next notice of an unconfirmed stall."""
        heartbeat_ns = self._queue_cadence.next_heartbeat_ns
        if self.readiness.stalled:
            return min(heartbeat_ns, self._last_notice_ns + NOTICE_EVERY_NS)
        return heartbeat_ns

    # -- reports -----------------------------------------------------------------------------

    def queue_heartbeat_ms(self) -> int:
        """Short while the clock runs; long while it rests, when the queues cannot change
        without a point or a status waking it first."""
        return heartbeat_ms(motion_possible=not self.rest.resting)

    def queue_state(self, group: int) -> QueueState:
        ring = self.rings[group]
        return QueueState(
            epoch=ring.epoch,
            received=ring.received,
            depth=len(ring.entries),
            capacity=RING_CAPACITY,
            command_pulses=list(self.command[group]),  # a snapshot, never the row itself
            tick=self.tick,
            ready=self.ready,
            heartbeat_ms=self.queue_heartbeat_ms(),
        )

    def queue_updates(self, now_ns: int, force: bool = False) -> list[tuple[int, QueueState]]:
        """The queue states to publish now (``QueueCadence``): each that changed, and all of
        them at the heartbeat or when ``force``d, so idle interpolators and gateways need not
        wake 250 times a second."""
        updates = []
        for group in self._queue_cadence.due(
            now_ns, self.tick, self.command, self.ready, self.queue_heartbeat_ms(), force=force
        ):
            updates.append((group, self.queue_state(group)))
        return updates

    def group_ticks(self) -> list[GroupTick]:
        feedback = self.servos.feedback_pulses()
        moved = self.servos.moved
        command = self.command
        return [
            GroupTick(
                command_pulses=list(command[g]),
                feedback_pulses=feedback[g],
                increment=list(self.last_increment[g]),
                depth=len(ring.entries),
                feedback_moved=list(moved[g]),  # the servo changes its rows in place
            )
            for g, ring in enumerate(self.rings)
        ]

    def tick_report(self, deadline_ns: int, lateness_ns: int, missed: int) -> Tick:
        """What the motion system did this period, for the broadcaster and observers."""
        return Tick(
            tick=self.tick,
            deadline_ns=deadline_ns,
            lateness_ns=lateness_ns,
            missed=missed,
            motion_ready=self.ready,
            groups=self.group_ticks(),
            resting=self.rest.resting,
        )
