"""Interpolation throughput: queue entries (one pulse increment per axis, one row per
interpolation period) computed per second for one group, on one core.

    python -m motocell.tools.bench.bench_interpolation [--quick] [--runs N]

The group is the 6-axis arm of the default cell at a 4 ms period. Cases:

- typical segments: 100 ms between points, i.e. 25 entries each (24 grid instants plus the
  waypoint), each segment taken in feeder-sized chunks (``MAX_BATCH``);
- the same stream through ``Feeder`` (points in, ``IncrementBatch`` payloads out), which adds
  the batch packing the interpolator service does;
- one long segment taken in chunks of ``MAX_BATCH`` (50) and of a full ring (200).

Each case runs several times after one warm-up run; the table shows the median and the spread.
The goal is 1,000,000 entries/s per group (one group needs 250 entries/s at 4 ms).
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
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
from motocell.tools.bench.measuring import RESULTS_DIR

RUNS = 5
GOAL = 1_000_000.0
UNIT = "entries/s"
RESULTS_FILE = RESULTS_DIR / "interpolation.json"

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


def measure(name: str, runs: int, once: Callable[[], float]) -> dict[str, Any]:
    once()  # warm-up: first calls into numpy, caches
    rates = [once() for _ in range(runs)]
    return {
        "name": name,
        "unit": UNIT,
        "median": statistics.median(rates),
        "min": min(rates),
        "max": max(rates),
        "runs": rates,
    }


def run(quick: bool, runs: int = RUNS) -> list[dict[str, Any]]:
    """Every case, ``runs`` timed runs each (at least 5)."""
    runs = max(runs, 5)
    segments = QUICK_SEGMENTS if quick else SEGMENTS
    long_entries = QUICK_LONG_ENTRIES if quick else LONG_ENTRIES
    knots = _knots(segments)
    cases: list[tuple[str, Callable[[], float]]] = [
        (f"6-axis, 25-entry segments, take({MAX_BATCH})", typical_segments(knots)),
        ("6-axis, 25-entry segments, Feeder -> IncrementBatch", through_feeder(knots)),
        (f"6-axis, long segment, take({MAX_BATCH})", long_segment(long_entries, MAX_BATCH)),
        ("6-axis, long segment, take(200)", long_segment(long_entries, 200)),
    ]
    return [measure(name, runs, once) for name, once in cases]


def table(results: list[dict[str, Any]]) -> str:
    width = max(len(r["name"]) for r in results)
    lines = [f"{'case':<{width}}  {'median':>11}  {'min - max':>23}  {UNIT}, goal {GOAL:,.0f}"]
    for r in results:
        spread = f"{r['min']:,.0f} - {r['max']:,.0f}"
        verdict = "ok" if r["median"] >= GOAL else "BELOW GOAL"
        lines.append(f"{r['name']:<{width}}  {r['median']:>11,.0f}  {spread:>23}  {verdict}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Interpolation throughput per group")
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"{QUICK_SEGMENTS} segments / {QUICK_LONG_ENTRIES} long-segment entries per run",
    )
    parser.add_argument("--runs", type=int, default=RUNS, help="runs per case (default 5, min 5)")
    args = parser.parse_args(argv)
    results = run(args.quick, args.runs)
    print(table(results))
    RESULTS_FILE.parent.mkdir(parents=True, exist_ok=True)
    report = {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "machine": platform.machine(),
        "period_ms": PERIOD_NS / 1e6,
        "goal": GOAL,
        "quick": args.quick,
        "results": results,
    }
    RESULTS_FILE.write_text(json.dumps(report, indent=2) + "\n")
    print(f"written to {RESULTS_FILE}")


if __name__ == "__main__":
    main()
