"""The broadcaster's decisions about a snapshot, no I/O: when one is due and what it holds.

Snapshots follow the executor's ticks (default 10 ms, 100 Hz: the first tick at or after each
due time), so feedback leaves as soon as its tick arrives and the rate is exact on average even
when the state period is not a whole number of ticks. MotoROS 1.9 sends "work time + 25 ms"
per client, a little under 40 Hz (motoros1 §6); motocell keeps a steady configurable rate
instead (docs/behaviour.md, state rate). Without ticks, the beat is the pacing table's
(``states.PACING``).
"""

from __future__ import annotations

from typing import Protocol

import msgspec

from motocell.services.broadcaster.core.admission import queued
from motocell.services.broadcaster.core.joints import JointStates
from motocell.services.broadcaster.core.poses import Poses
from motocell.services.broadcaster.core.robot_status import robot_status
from motocell.services.broadcaster.core.states import (
    PACING,
    Beat,
    BeatFrom,
    Pacing,
    PacingEvent,
    PacingStep,
    Sends,
)
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S
from motocell.shared.bus.schemas import CommandReply, ControllerStatus, GroupState, State, Tick
from motocell.shared.config import Cell
from motocell.shared.protocol.constants import Result
from motocell.shared.schedule import Schedule

MIN_SILENCE_S = 0.05


class ControllerView(Protocol):
    """What the broadcaster knows of the controller; asked only when a snapshot is due."""

    def status(self) -> ControllerStatus | None:
        """The newest status published, if any."""
        ...

    def alive(self) -> bool:
        """Whether the controller's liveliness token is present."""
        ...


TICK_EVENT = (PacingEvent.TICK, PacingEvent.RESTING_TICK)
"""The event a tick is, by its ``resting``."""
WAKE_EVENT = (PacingEvent.WAKE_WITHOUT_CLIENTS, PacingEvent.WAKE_WITH_CLIENTS)
"""The event a wake-up without a tick is, by whether a state client is connected."""

# Read on every cycle, so bound once: EnumType's ``__getattr__`` makes every attribute read on
# an Enum class several times slower than a global's.
_SENDS_TICK, _SENDS_ON_SCHEDULE, _SENDS_ON_BEAT = (
    Sends.TICK,
    Sends.TICK_ON_SCHEDULE,
    Sends.LAST_TICK_ON_BEAT,
)
_FROM_DUE_TIME = BeatFrom.DUE_TIME
_AT_REST = Pacing.AT_REST


class Broadcaster:
    """Ticks in, numbered State snapshots out, at the cell's state period. Times are the
    broadcaster's own CLOCK_MONOTONIC seconds, passed in."""

    def __init__(self, cell: Cell, controller: ControllerView) -> None:
        self.joints = JointStates(cell)
        self.schedule = Schedule(cell.state_period_ns)
        self.state_period_s = cell.state_period_ns / 1e9
        self.controller = controller
        self.silence_s = max(MIN_SILENCE_S, 3 * cell.state_period_ns / 1e9)
        """Ticks unheard this long while the executor's clock runs: it stalled or went."""
        self.beats = {
            Beat.STATE_PERIOD: self.state_period_s,
            Beat.REST_HEARTBEAT: AT_REST_HEARTBEAT_S,
            Beat.REST_SILENCE: AT_REST_HEARTBEAT_S + self.silence_s,
            Beat.SILENCE: self.silence_s,
        }
        self.pacing = Pacing.WAITING
        self.last: Tick | None = None
        self.seq = 0
        self.poses = Poses(cell)
        self.tools: list[int] = []
        """The tool per group in the newest controller status a snapshot read, kept when the
        controller has none to give, so the TCP never jumps back to the flange for a snapshot
        (tool 0 until a status says otherwise)."""
        self._next_beat: float | None = None
        """When a wake-up without a tick is due to do what ``PACING`` says; None: never."""
        self._sent_at = 0.0
        """When the newest snapshot was made."""
        self._groups_of: tuple[Tick | None, list[GroupState]] = (None, [])

    @property
    def ticks_expected(self) -> bool:
        """Whether the executor's clock runs: a tick is what to wait for."""
        return self.pacing is not _AT_REST

    def on_tick(self, tick: Tick, now: float) -> State | None:
        """The snapshot to send now, if the pacing step says so: the tick the executor rests
        after always, any other tick if it is the first at or after the due time."""
        self.last = tick
        step = PACING[self.pacing, TICK_EVENT[tick.resting]]
        self._take(step, now, now)
        sends = step.sends
        if sends is _SENDS_TICK or (
            sends is _SENDS_ON_SCHEDULE and self.schedule.due(tick.deadline_ns)
        ):
            return self._snapshot(tick, now)
        return None

    def on_wake(self, now: float, clients: bool) -> State | None:
        """Woken without a tick: the snapshot due now from the last tick, with the controller
        as it is now, if a beat is due. ``clients``: a state client is connected."""
        step = PACING[self.pacing, WAKE_EVENT[clients]]
        if step.sends is not _SENDS_ON_BEAT or self.last is None:
            return None
        due = self._next_beat
        if due is None:
            return None
        if step.due_within is not None:
            due = min(due, self._sent_at + self.beats[step.due_within])
        if now < due:
            return None
        self._take(step, now, due)
        return self._snapshot(self.last, now)

    def next_wake(self, now: float, clients: bool) -> float | None:
        """When the caller must wake if no tick comes first (None: only for a tick)."""
        step = PACING[self.pacing, WAKE_EVENT[clients]]
        if step.sends is not _SENDS_ON_BEAT or self._next_beat is None:
            return None
        if step.due_within is None:
            return self._next_beat
        return min(self._next_beat, max(now, self._sent_at + self.beats[step.due_within]))

    def _take(self, step: PacingStep, now: float, due: float) -> None:
        """Into ``step``'s pacing, its next beat counted from ``now`` or from ``due``; a beat
        that would already be past is counted from now: no burst to catch up."""
        self.pacing = step.then
        if step.next_beat is None:
            self._next_beat = None
            return
        beat = self.beats[step.next_beat]
        following = (due if step.counted_from is _FROM_DUE_TIME else now) + beat
        self._next_beat = following if following > now else now + beat

    def positions(self) -> CommandReply:
        """Where the newest tick left the robot (the commanded pulses of every group): where a
        restarted executor resumes. FAILURE before any tick."""
        last = self.last
        if last is None:
            return CommandReply(Result.FAILURE, detail="no tick heard yet")
        return CommandReply(Result.SUCCESS, pulses=[group.command_pulses for group in last.groups])

    def motion_queued(self) -> bool:
        """Whether the newest tick had motion data queued (no tick yet: nothing is)."""
        return self.last is not None and queued(self.last)

    def for_observers(self, state: State) -> State:
        """``state``, the newest snapshot, with its commanded joints and its arms' poses, for
        observers: computed after the TCP clients have their frames, which carry the feedback
        joints only."""
        tick = self._groups_of[0]
        if tick is None:
            return state
        groups = self.joints.groups(tick)
        return self.poses.add(msgspec.structs.replace(state, groups=groups), self.tools)

    def _snapshot(self, tick: Tick, now: float) -> State:
        self.seq += 1
        self._sent_at = now
        status = self.controller.status()
        if status is not None:
            self.tools = status.tools
        if tick is not self._groups_of[0]:
            # A beat without ticks repeats the last tick: its feedback is converted once.
            self._groups_of = (tick, self.joints.groups(tick, commanded=False))
        return State(
            seq=self.seq,
            tick=tick.tick,
            tick_ns=tick.deadline_ns + tick.lateness_ns,
            groups=self._groups_of[1],
            status=robot_status(status, tick, self.controller.alive()),
        )
