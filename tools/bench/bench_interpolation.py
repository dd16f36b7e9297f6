"""Figure 2: interpolation throughput, queue entries (one pulse increment per axis, one row per
interpolation period) computed per second for one group, on one core.

    python -m motocell.tools.bench.run --only 2 [--quick]

The group is the 6-axis arm of the default cell at a 4 ms period. Cases:

- typical segments: 100 ms between points, i.e. 25 entries each (24 grid instants plus the
  waypoint), each segment taken in feeder-sized chunks (``MAX_BATCH``);
- the same stream through ``Feeder`` (points in, ``IncrementBatch`` payloads out), which adds
  the batch packing the interpolator service does;
- one long segment taken in chunks of ``MAX_BATCH`` (50) and of a full ring (200).

Each case runs several times after one warm-up run; the figure is the median and the spread.
The goal is 1,000,000 entries/s per group (one group needs 250 entries/s at 4 ms).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from motocell.services.interpolator.core.feeder import MAX_BATCH, Feeder
from motocell.shared.bus.schemas import IncrementBatch, Point, QueueState
from motocell.shared.config import load_cell
from motocell.shared.motion.interpolation import Knot, Trajectory
from motocell.shared.motion.kinematics import AxisMap
from motocell.tools.bench.measuring import figure_result

FIGURE = 2
RUNS = 5
GOAL = 1_000_000.0

CELL = load_cell()
GROUP = CELL.groups[0]
PERIOD_NS = CELL.period_ns
SEGMENT_NS = 25 * PERIOD_NS
"""A typical ROS segment: 100 ms at 4 ms, 25 entries."""

SEGMENTS = 4_000
QUICK_SEGMENTS = 400
LONG_ENTRIES = 200_000
QUICK_LONG_ENTRIES = 20_000


def _knots(count: int) -> list[Knot]:
    """A start knot plus ``count`` random knots ``SEGMENT_NS`` apart, within the arm's limits."""
    rng = np.random.default_rng(1)
    limits = np.array(GROUP.model.max_speed)
    knots = [Knot(0, np.zeros(GROUP.axes), np.zeros(GROUP.axes))]
    for i in range(1, count + 1):
        knots.append(
            Knot(
                i * SEGMENT_NS,
                rng.uniform(-2.0, 2.0, GROUP.axes),
                rng.uniform(-0.5, 0.5, GROUP.axes) * limits,
            )
        )
    return knots


def typical_segments(knots: list[Knot]) -> Callable[[], float]:
    axis_map = AxisMap(GROUP)

    def once() -> float:
        trajectory = Trajectory(axis_map, PERIOD_NS, knots[0], np.zeros(GROUP.axes, np.int64))
        entries = 0
        start = time.perf_counter()
        for end in knots[1:]:
            segment = trajectory.segment_to(end)
            while segment.remaining:
                entries += len(segment.take(MAX_BATCH))
        elapsed = time.perf_counter() - start
        assert entries == 25 * (len(knots) - 1)
        return entries / elapsed

    return once


def through_feeder(knots: list[Knot]) -> Callable[[], float]:
    points = [
        Point(i + 1, i, k.time_ns / 1e9, k.positions.tolist(), k.velocities.tolist())
        for i, k in enumerate(knots)
    ]

    def once() -> float:
        batches: list[IncrementBatch] = []
        feeder = Feeder(GROUP, PERIOD_NS, send=batches.append)
        command = [0] * 8
        feeder.on_queue(QueueState(1, 0, 0, 200, command, 0))
        pending: deque[Point] = deque()
        start = time.perf_counter()
        for point in points:
            pending.append(point)
            feeder.progress(pending)
            # The executor took everything at once: the whole ring is free again.
            feeder.on_queue(QueueState(1, feeder.sent, 0, 200, command, 0))
        elapsed = time.perf_counter() - start
        entries = sum(b.count for b in batches)
        assert entries == 25 * (len(points) - 1)
        return entries / elapsed

    return once


def long_segment(entries: int, chunk: int) -> Callable[[], float]:
    axis_map = AxisMap(GROUP)
    start_knot = Knot(0, np.zeros(GROUP.axes), np.zeros(GROUP.axes))
    end_knot = Knot(entries * PERIOD_NS, np.full(GROUP.axes, 1.5), np.zeros(GROUP.axes))

    def once() -> float:
        trajectory = Trajectory(axis_map, PERIOD_NS, start_knot, np.zeros(GROUP.axes, np.int64))
        produced = 0
        start = time.perf_counter()
        segment = trajectory.segment_to(end_knot)
        while segment.remaining:
            produced += len(segment.take(chunk))
        elapsed = time.perf_counter() - start
        assert produced == entries
        return produced / elapsed

    return once


def measure(name: str, once: Callable[[], float]) -> dict[str, Any]:
    once()  # warm-up: first calls into numpy, caches
    rates = [once() for _ in range(RUNS)]
    return figure_result(FIGURE, name, "entries/s", rates, goal=(">=", GOAL))


def run(quick: bool) -> list[dict[str, Any]]:
    """Every case, RUNS timed runs each."""
    segments = QUICK_SEGMENTS if quick else SEGMENTS
    long_entries = QUICK_LONG_ENTRIES if quick else LONG_ENTRIES
    knots = _knots(segments)
    cases: list[tuple[str, Callable[[], float]]] = [
        (f"6-axis, 25-entry segments, take({MAX_BATCH})", typical_segments(knots)),
        ("6-axis, 25-entry segments, Feeder -> IncrementBatch", through_feeder(knots)),
        (f"6-axis, long segment, take({MAX_BATCH})", long_segment(long_entries, MAX_BATCH)),
        ("6-axis, long segment, take(200)", long_segment(long_entries, 200)),
    ]
    return [measure(name, once) for name, once in cases]
