"""The face's decisions, no I/O: which state sample to publish, when, and stamped how.

``Face`` follows the table ``states.PACING``; its shell passes every sample and every wake-up
in with the instant (CLOCK_MONOTONIC ns) and publishes what it returns.
"""

from __future__ import annotations

from motocell.services.ros2.core.states import (
    PACING,
    ImpossibleEventError,
    Pacing,
    PacingEvent,
    Publish,
    Wake,
)
from motocell.services.ros2.core.topics import TopicValues, topic_values
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S, STALE_HEARTBEATS
from motocell.shared.bus.schemas import ControllerStatus, State
from motocell.shared.config import Cell, Ros2Face
from motocell.shared.robot_status import robot_status_fields
from motocell.shared.schedule import Schedule

SILENCE_NS = round(STALE_HEARTBEATS * AT_REST_HEARTBEAT_S * 1e9)
"""No sample for this long: the cell's state is gone. A resting cell sends one a second
(``shared.bus.liveness``); the same count of missed heartbeats marks anything stale."""


class Face:
    """MotoROS2's topics at ``controller_status_monitor_period`` from the cell's ``state``."""

    def __init__(self, cell: Cell, face: Ros2Face) -> None:
        self._groups = cell.groups
        self.period_ns = face.update_periods.controller_status_monitor_period * 1_000_000
        self._schedule = Schedule(self.period_ns)
        self.pacing = Pacing.QUIET
        self._newest: State | None = None
        self._heard_ns: int | None = None
        self._status: ControllerStatus | None = None
        self._status_ns = 0
        self._stamped_ns = 0
        """The newest stamp published: the next is always later."""
        self._published: tuple[State, TopicValues] | None = None
        """The sample last published, and what was published for it."""
        self.wake_ns: int | None = None
        """When the face must wake without a sample (CLOCK_MONOTONIC ns); None: only for one."""

    @property
    def samples_expected(self) -> bool:
        """Whether a sample is due any moment (the cell's clock runs, or the face waits for its
        first): wait for it, rather than only for the next deadline."""
        return self.pacing is not Pacing.HOLDING

    def newest(self) -> State | None:
        """The newest state sample: the robot as a running goal sees it (read from the goal's
        thread: the reference is replaced whole, never changed)."""
        return self._newest

    def on_status(self, status: ControllerStatus, now_ns: int) -> None:
        """A controller status, newer than any state sample heard before ``now_ns``: the
        robot status follows it within a period even while the cell's state comes once a
        second (a robot at rest)."""
        self._status, self._status_ns = status, now_ns

    def on_sample(self, state: State, now_ns: int) -> TopicValues | None:
        due = self._schedule.due(state.tick_ns)
        self._newest, self._heard_ns = state, now_ns
        return self._take(PacingEvent.SAMPLE_DUE if due else PacingEvent.SAMPLE_EARLY, now_ns)

    def on_wake(self, now_ns: int) -> TopicValues | None:
        """Woken without a sample: at ``wake_ns``, or before it for nothing (a doorbell rung
        at stop, a sample that did not decode)."""
        if self.wake_ns is not None and now_ns < self.wake_ns:
            return None
        heard = self._heard_ns
        silent = heard is None or now_ns - heard >= SILENCE_NS
        return self._take(PacingEvent.SILENCE if silent else PacingEvent.DUE, now_ns)

    def _take(self, event: PacingEvent, now_ns: int) -> TopicValues | None:
        step = PACING[(self.pacing, event)]
        if step is None:
            raise ImpossibleEventError(f"{event.name} while {self.pacing.name}")
        self.pacing = step.then
        self._wake(step.wake, now_ns)
        newest = self._newest
        if step.publish is Publish.NOTHING or newest is None:
            return None
        sampled_ns = newest.tick_ns if step.publish is Publish.SAMPLE else now_ns
        if sampled_ns <= self._stamped_ns:
            # A resting cell's tick sent again is the robot as it is now: stamps never go back.
            sampled_ns = now_ns
        self._stamped_ns = sampled_ns
        status = newest.status
        if self._status is not None and self._status_ns > (self._heard_ns or 0):
            moving = bool(newest.status.in_motion)
            status = robot_status_fields(self._status, moving, controller_alive=True)
        last = self._published
        if last is not None and last[0] is newest:
            # The same sample again (a resting robot): the same joint values, so the node can
            # send the messages it built for them again, stamped anew.
            old = last[1]
            values = TopicValues(sampled_ns, old.positions, old.velocities, status, newest)
        else:
            values = topic_values(newest, self._groups, sampled_ns, status)
        self._published = (newest, values)
        return values

    def _wake(self, wake: Wake, now_ns: int) -> None:
        if wake is Wake.HOLD_AFTER:
            self.wake_ns = now_ns + self.period_ns * 3 // 2
        elif wake is Wake.PERIOD:
            # On the grid of the first held publication: a late wake-up does not slow the rate.
            after = (self.wake_ns or now_ns) + self.period_ns
            self.wake_ns = after if after > now_ns else now_ns + self.period_ns
        elif wake is Wake.NEVER:
            self.wake_ns = None
