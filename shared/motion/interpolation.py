"""Trajectory points to per-period pulse increments (incremental-motion §2.7). Pure: no clock.

Between two points (p0, v0, t0) and (p1, v1, t1) every joint follows the cubic Hermite of
incremental-motion §2.7.2 (acceleration linear in time, position and velocity matched at both
ends):

    a1 = 6(p1 - p0)/T^2 - 2(v1 + 2 v0)/T
    a2 = -12(p1 - p0)/T^3 + 6(v0 + v1)/T^2
    p(tau) = p0 + v0 tau + a1 tau^2/2 + a2 tau^3/6

Differences from MotoROS 1.9 (motoros1 §4.2-4.3), all on purpose:
- float64 instead of float32, and times in integer nanoseconds instead of truncated
  milliseconds, so the grid never drifts and off-grid waypoints keep their exact time;
- pulses are rounded to nearest, not truncated (see ``AxisMap.ros_to_pulses``);
- the leftover-equals-segment [quirk] cannot happen: the grid is ``anchor + k * period``.

What stays the same: the sample grid is anchored at the sequence-0 point's time; each segment
yields one entry per grid instant strictly inside it plus one entry at the waypoint itself,
holding the waypoint's exact position. A waypoint off the grid gives a *partial* entry that the
executor merges with the next one, so every tick moves exactly one period's worth (motoros1 §5.3).
Increments are differences of absolute pulse positions from the commanded start position, so
the pulses applied add up exactly to the last waypoint's pulse position.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from motocell.shared.motion.kinematics import AxisMap, FloatArray, IntArray


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


def max_segment_entries(duration_ns: int, period_ns: int) -> int:
    """An upper bound on the ring entries of a segment this long, wherever the grid falls in
    it (``Segment.remaining`` before the first ``take``): at most ``duration // period + 1``
    grid instants strictly inside it, plus the waypoint's own entry."""
    return duration_ns // period_ns + 2


_POWERS = np.arange(4)


def _hermite(duration_ns: int) -> FloatArray:
    """The matrix taking (p0, v0, p1, v1) to the coefficients of 1, tau, tau^2, tau^3 of
    incremental-motion §2.7.2's cubic: p0 + v0 tau + (a1/2) tau^2 + (a2/6) tau^3 with
    a1 = 6(p1 - p0)/T^2 - 2(v1 + 2 v0)/T and a2 = -12(p1 - p0)/T^3 + 6(v0 + v1)/T^2."""
    t = duration_ns / 1e9
    t2, t3 = t * t, t * t * t
    return np.array(
        (
            (1.0, 0.0, 0.0, 0.0),
            (0.0, 1.0, 0.0, 0.0),
            (-3 / t2, -2 / t, 3 / t2, -1 / t),
            (2 / t3, 1 / t2, -2 / t3, 1 / t2),
        )
    )


class Segment:
    """The entries between two knots, produced on demand so a 4-hour segment costs no memory.

    The cubic's coefficients are computed once, already in Motoman axis order and in pulses,
    so producing entries is one Horner evaluation and one rounding per chunk: typical 100 ms
    segments are a few dozen entries, where numpy's per-call overhead dominates.
    """

    def __init__(self, trajectory: Trajectory, start: Knot, end: Knot) -> None:
        period = trajectory.period_ns
        offset0 = start.time_ns - trajectory.anchor_ns
        offset1 = end.time_ns - trajectory.anchor_ns
        self._trajectory = trajectory
        self._start_ns = start.time_ns
        self._end_ns = end.time_ns
        self._next_k = offset0 // period + 1
        # Grid instants strictly before the waypoint; the waypoint gets its own entry.
        self._last_k = (offset1 - 1) // period
        self._waypoint_partial = offset1 % period != 0
        self._waypoint_done = False
        axis_map = trajectory.axis_map
        knots = np.array((start.positions, start.velocities, end.positions, end.velocities))
        knots = knots[:, axis_map.ros_index_of_moto] * axis_map.pulses_per_unit_moto
        self._coefficients: FloatArray = _hermite(end.time_ns - start.time_ns) @ knots
        # The waypoint's entry holds its exact position, not the cubic evaluated at T.
        self._waypoint_pulses = np.rint(knots[2]).astype(np.int64)

    @property
    def remaining(self) -> int:
        return max(0, self._last_k - self._next_k + 1) + (0 if self._waypoint_done else 1)

    def pulses_at(self, times_ns: IntArray) -> FloatArray:
        """The cubic, in Motoman-order pulses (not rounded), at absolute times in the segment."""
        tau = ((times_ns - self._start_ns) * 1e-9)[:, None]
        result: FloatArray = (tau**_POWERS) @ self._coefficients
        return result

    def take(self, limit: int) -> Entries:
        """The next ``limit`` entries at most (fewer at the segment's end)."""
        trajectory = self._trajectory
        grid_count = max(0, min(limit, self._last_k - self._next_k + 1))
        with_waypoint = (
            grid_count < limit
            and not self._waypoint_done
            and (self._next_k + grid_count > self._last_k)
        )
        count = grid_count + with_waypoint
        times = np.empty(count, dtype=np.int64)
        times[:grid_count] = trajectory.anchor_ns + trajectory.period_ns * np.arange(
            self._next_k, self._next_k + grid_count, dtype=np.int64
        )
        absolute = np.empty((count, self._coefficients.shape[1]), dtype=np.int64)
        if grid_count:
            absolute[:grid_count] = np.rint(self.pulses_at(times[:grid_count]))
        self._next_k += grid_count
        partial = np.zeros(count, dtype=np.bool_)
        if with_waypoint:
            self._waypoint_done = True
            times[-1] = self._end_ns
            absolute[-1] = self._waypoint_pulses
            partial[-1] = self._waypoint_partial
        increments = np.empty((count, self._coefficients.shape[1]), dtype=np.int32)
        if count:
            increments[0] = absolute[0] - trajectory.pulses
            increments[1:] = absolute[1:] - absolute[:-1]
            trajectory.pulses = absolute[-1]
        return Entries(times, increments, partial)


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

    def reaches(self, end: Knot) -> bool:
        """Whether a segment can end at ``end``: its time is after the last knot's."""
        return end.time_ns > self.last.time_ns

    def segment_to(self, end: Knot) -> Segment:
        """Start the segment from the last knot to ``end``; it must be ``reaches``-able."""
        if not self.reaches(end):
            raise ValueError(
                f"point time {end.time_ns} ns is not after the previous {self.last.time_ns} ns"
            )
        segment = Segment(self, self.last, end)
        self.last = end
        return segment
