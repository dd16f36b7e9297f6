"""Spec §2.7 interpolation: trajectory points to per-period pulse increments. Pure: no clock.

Between two points (p0, v0, t0) and (p1, v1, t1) every joint follows the cubic Hermite of spec
§2.7.2 (acceleration linear in time, position and velocity matched at both ends):

    a1 = 6(p1 - p0)/T^2 - 2(v1 + 2 v0)/T
    a2 = -12(p1 - p0)/T^3 + 6(v0 + v1)/T^2
    p(tau) = p0 + v0 tau + a1 tau^2/2 + a2 tau^3/6

Differences from MotoROS 1.9 (motoros1-behaviour.md §4.2-4.3), all on purpose:
- float64 instead of float32, and times in integer nanoseconds instead of truncated
  milliseconds, so the grid never drifts and off-grid waypoints keep their exact time;
- pulses are rounded to nearest, not truncated (see ``AxisMap.ros_to_pulses``);
- the leftover-equals-segment [quirk] cannot happen: the grid is ``anchor + k * period``.

What stays the same: the sample grid is anchored at the sequence-0 point's time; each segment
yields one entry per grid instant strictly inside it plus one entry at the waypoint itself,
holding the waypoint's exact position. A waypoint off the grid gives a *partial* entry that the
executor merges with the next one, so every tick moves exactly one period's worth (§5.3).
Increments are differences of absolute pulse positions from the commanded start position, so
the pulses applied add up exactly to the last waypoint's pulse position.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from shared.motion.kinematics import AxisMap, FloatArray, IntArray


@dataclass(frozen=True)
class Knot:
    """A trajectory point in the interpolator's units: ROS-order positions and velocities."""

    time_ns: int
    positions: FloatArray
    velocities: FloatArray


@dataclass(frozen=True)
class Entries:
    """A run of queue entries: one row per entry, increments in Motoman axis order."""

    times_ns: IntArray
    increments: npt.NDArray[np.int32]
    partial: npt.NDArray[np.bool_]

    def __len__(self) -> int:
        return len(self.times_ns)


def time_to_ns(seconds: float) -> int:
    return round(seconds * 1e9)


class Segment:
    """The entries between two knots, produced on demand so a 4-hour segment costs no memory."""

    def __init__(self, trajectory: Trajectory, start: Knot, end: Knot) -> None:
        period = trajectory.period_ns
        offset0 = start.time_ns - trajectory.anchor_ns
        offset1 = end.time_ns - trajectory.anchor_ns
        self._trajectory = trajectory
        self._start = start
        self._end = end
        self._next_k = offset0 // period + 1
        # Grid instants strictly before the waypoint; the waypoint gets its own entry.
        self._last_k = (offset1 - 1) // period
        self._waypoint_partial = offset1 % period != 0
        self._waypoint_done = False
        duration = (end.time_ns - start.time_ns) / 1e9
        dp = end.positions - start.positions
        v0, v1 = start.velocities, end.velocities
        self._a1: FloatArray = 6 * dp / duration**2 - 2 * (v1 + 2 * v0) / duration
        self._a2: FloatArray = -12 * dp / duration**3 + 6 * (v0 + v1) / duration**2

    @property
    def remaining(self) -> int:
        return max(0, self._last_k - self._next_k + 1) + (0 if self._waypoint_done else 1)

    def positions_at(self, times_ns: IntArray) -> FloatArray:
        """The cubic, in ROS order, at absolute times inside the segment."""
        tau = ((times_ns - self._start.time_ns) / 1e9)[:, None]
        s = self._start
        result: FloatArray = (
            s.positions + s.velocities * tau + self._a1 * tau**2 / 2 + self._a2 * tau**3 / 6
        )
        return result

    def take(self, limit: int) -> Entries:
        """The next ``limit`` entries at most (fewer at the segment's end)."""
        trajectory = self._trajectory
        grid_count = max(0, min(limit, self._last_k - self._next_k + 1))
        ks = np.arange(self._next_k, self._next_k + grid_count, dtype=np.int64)
        times = trajectory.anchor_ns + ks * trajectory.period_ns
        positions = self.positions_at(times)
        self._next_k += grid_count
        with_waypoint = grid_count < limit and not self._waypoint_done and self.remaining == 1
        if with_waypoint:
            self._waypoint_done = True
            times = np.append(times, self._end.time_ns)
            positions = np.vstack([positions, self._end.positions[None, :]])
        absolute = trajectory.axis_map.ros_to_pulses(positions)
        increments = np.diff(absolute, axis=0, prepend=trajectory.pulses[None, :])
        if len(absolute):
            trajectory.pulses = absolute[-1]
        partial = np.zeros(len(times), dtype=np.bool_)
        if with_waypoint:
            partial[-1] = self._waypoint_partial
        return Entries(times, increments.astype(np.int32), partial)


class Trajectory:
    """One group's trajectory from its sequence-0 point on.

    ``pulses`` is the absolute Motoman-order pulse position reached after every entry produced
    so far; it starts at the commanded position the robot had when the trajectory began.
    """

    def __init__(
        self, axis_map: AxisMap, period_ns: int, start: Knot, start_pulses: IntArray
    ) -> None:
        self.axis_map = axis_map
        self.period_ns = period_ns
        self.anchor_ns = start.time_ns
        self.last = start
        self.pulses: IntArray = np.array(start_pulses[: axis_map.axes], dtype=np.int64)

    def segment_to(self, end: Knot) -> Segment:
        """Start the segment from the last knot to ``end``; its time must be later."""
        if end.time_ns <= self.last.time_ns:
            raise ValueError(
                f"point time {end.time_ns} ns is not after the previous {self.last.time_ns} ns"
            )
        segment = Segment(self, self.last, end)
        self.last = end
        return segment
