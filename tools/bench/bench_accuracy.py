"""Figure 8: accuracy of the applied pulses against the float64 closed form.

    python -m motocell.tools.bench.run --only 8 [--quick]

Pure part (no cell): for every robot model of the catalogue (arm6, arm7 with its axis
reordering, positioner2, track1), a long random trajectory (knots 10-400 ms apart at arbitrary
nanosecond times, so waypoints are off the 4 ms grid; random positions and velocities within the
speed limits) goes through ``shared.motion.interpolation`` (Trajectory/Segment with AxisMap,
taken in feeder-sized chunks). The increments are summed from the start pulses, as the executor
applies them, and compared at every entry time with the closed form computed here
independently: the incremental-motion §2.7 cubic in float64, mapped to Motoman order and
multiplied by the pulses per unit. Reported: the largest |applied - closed form| (goal <= 0.5
pulse), how many entries differ from round(closed form), and the final error (applied after
the last entry - the last waypoint's pulses; goal 0). Three runs, three seeds.

End-to-end part: one real 4-group cell streams a random 2016 trajectory (off-grid times,
non-zero start velocity, within the speed limits); the executor's commanded pulses, tick by
tick from the first moving tick, are compared with the closed form at the grid instants
(built from the float32 values the wire carried), and the final feedback pulses with the last
point's pulses. One trajectory per run, three runs. The same ticks give the following error of
the cell's servos (commanded - feedback pulses while moving, ``testing.following``): the largest
per-axis maximum and RMS over every group; the motion runs at up to 0.3 x each axis's speed
limit, so these are about a third of the rated-speed figures of docs/servo.md.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from typing import Any

import numpy as np

from motocell.services.interpolator.core.feeder import MAX_BATCH
from motocell.shared.bus.schemas import Tick
from motocell.shared.config import Group, load_catalogue
from motocell.shared.motion.interpolation import Knot, Trajectory, time_to_ns
from motocell.shared.motion.kinematics import AxisMap
from motocell.testing.client import PlannedPoint, ex_messages
from motocell.testing.following import following_errors
from motocell.tools.bench.clients import StreamClientProcess, stream_bound_s
from motocell.tools.bench.measuring import (
    Observer,
    bench_cell,
    figure_result,
    positions_of,
    workdir,
)

FIGURE = 8
RUNS = 3
PERIOD_NS = 4_000_000
SEGMENTS = 5_000
QUICK_SEGMENTS = 500
E2E_POINTS = 40
QUICK_E2E_POINTS = 12
GOAL_PULSES = 0.5
RANGE_MARGIN = 0.2
DECIMALS = 6
"""Deviations are reported rounded to 1e-6 pulse: two float64 evaluations of the same cubic
differ by ~1e-9, which must not turn an exact 0.5 into a miss."""


def random_knots(rng: np.random.Generator, axes: int, limits: np.ndarray, count: int) -> list[Knot]:
    knots = [Knot(0, rng.uniform(-1, 1, axes), rng.uniform(-0.5, 0.5, axes) * limits)]
    time_ns = 0
    for _ in range(count):
        time_ns += int(rng.integers(10_000_000, 400_000_000))
        knots.append(
            Knot(
                time_ns,
                np.clip(knots[-1].positions + rng.uniform(-0.3, 0.3, axes), -3.0, 3.0),
                rng.uniform(-0.5, 0.5, axes) * limits,
            )
        )
    return knots


def closed_form(knots: Sequence[Knot], times_ns: np.ndarray, axis_map: AxisMap) -> np.ndarray:
    """incremental-motion §2.7 in float64 at ``times_ns`` (each in (first, last] knot time), in
    Motoman-order pulses (unrounded)."""
    knot_times = np.array([k.time_ns for k in knots], dtype=np.int64)
    segment = np.searchsorted(knot_times, times_ns, side="left") - 1
    result = np.empty((len(times_ns), axis_map.axes))
    for s in np.unique(segment):
        start, end = knots[s], knots[s + 1]
        rows = segment == s
        duration = (end.time_ns - start.time_ns) / 1e9
        dp = end.positions - start.positions
        v0, v1 = start.velocities, end.velocities
        a1 = 6 * dp / duration**2 - 2 * (v1 + 2 * v0) / duration
        a2 = -12 * dp / duration**3 + 6 * (v0 + v1) / duration**2
        tau = ((times_ns[rows] - start.time_ns) / 1e9)[:, None]
        ros = start.positions + v0 * tau + a1 * tau**2 / 2 + a2 * tau**3 / 6
        result[rows] = ros[:, axis_map.ros_index_of_moto] * axis_map.pulses_per_unit_moto
    return result


def pure_once(group: Group, segments: int, seed: int) -> tuple[float, int, int, int]:
    """(max |applied - closed form|, entries != round(closed form), entries, final error)."""
    axis_map = AxisMap(group)
    rng = np.random.default_rng(seed)
    knots = random_knots(rng, group.axes, axis_map.max_speed_ros, segments)
    start_pulses = axis_map.ros_to_pulses(knots[0].positions)
    trajectory = Trajectory(axis_map, PERIOD_NS, knots[0], start_pulses)
    times: list[np.ndarray] = []
    increments: list[np.ndarray] = []
    for end in knots[1:]:
        segment = trajectory.segment_to(end)
        while segment.remaining:
            entries = segment.take(MAX_BATCH)
            times.append(entries.times_ns)
            increments.append(entries.increments.astype(np.int64))
    all_times = np.concatenate(times)
    applied = start_pulses + np.cumsum(np.concatenate(increments), axis=0)
    exact = closed_form(knots, all_times, axis_map)
    deviation = round(float(np.max(np.abs(applied - exact))), DECIMALS)
    mismatched = int(np.sum(np.any(applied != np.rint(exact), axis=1)))
    final = int(np.max(np.abs(applied[-1] - axis_map.ros_to_pulses(knots[-1].positions))))
    return deviation, mismatched, len(all_times), final


def wire(value: float) -> float:
    """What a float32 Simple Message field carries."""
    return float(np.float32(value))


def e2e_plans(
    rng: np.random.Generator, starts: dict[int, tuple[float, ...]], groups: list[Group], count: int
) -> dict[int, list[PlannedPoint]]:
    """Random knots for every group at shared off-grid times; non-zero start velocity on
    every axis (so the first tick moves), zero at the end; positions kept 0.2 rad (m) inside
    the joint ranges (the executor refuses a tick past one)."""
    times = [0.0]
    for _ in range(count - 1):
        times.append(times[-1] + float(rng.integers(40, 300)) / 1000 + 0.000_37)
    plans: dict[int, list[PlannedPoint]] = {}
    for g, start in starts.items():
        axis_map = AxisMap(groups[g])
        limits = axis_map.max_speed_ros
        axes = axis_map.axes
        lower, upper = np.array(groups[g].joint_limits).T + np.array(
            [[RANGE_MARGIN], [-RANGE_MARGIN]]
        )
        positions = np.array(start)
        points = []
        for i, t in enumerate(times):
            if i == 0:
                velocity = rng.choice((-1.0, 1.0), axes) * rng.uniform(0.1, 0.3, axes) * limits
            elif i == len(times) - 1:
                velocity = np.zeros(axes)
            else:
                velocity = rng.uniform(-0.3, 0.3, axes) * limits
            if i > 0:
                # Within the speed limits all along the cubic (the executor refuses faster
                # increments): average speed and knot speeds at most 0.3 x the limit.
                step = rng.uniform(-0.3, 0.3, axes) * limits * (t - times[i - 1])
                positions = np.clip(positions + step, lower, upper)
            points.append(PlannedPoint(t, tuple(positions.tolist()), tuple(velocity.tolist())))
        plans[g] = points
    return plans


def e2e_runs(points: int) -> tuple[list[float], list[float], list[float], list[float]]:
    """Per run: max |commanded - closed form|, final error, following error max and RMS."""
    deviations: list[float] = []
    finals: list[float] = []
    following_max: list[float] = []
    following_rms: list[float] = []
    with contextlib.ExitStack() as stack:
        directory = stack.enter_context(workdir())
        cell = stack.enter_context(bench_cell(directory, "bench8"))
        groups = list(cell.cell.groups)
        maps = [AxisMap(group) for group in groups]
        observer = stack.enter_context(Observer(cell))
        observer.record_ticks()
        streamer = stack.enter_context(StreamClientProcess(cell, directory))
        streamer.start_traj_mode()
        for seed in range(RUNS):
            still = observer.wait_still()
            plans = e2e_plans(
                np.random.default_rng(100 + seed), positions_of(cell.cell, still), groups, points
            )
            mark = observer.mark()
            duration = plans[0][-1].time
            streamer.stream(ex_messages(plans), stream_bound_s(duration)).check()
            observer.wait_still(timeout=30.0)
            ticks = observer.ticks_since(mark)
            worst, final = deviation(plans, maps, ticks)
            deviations.append(round(worst, DECIMALS))
            finals.append(float(final))
            following = following_errors(cell.cell, ticks)
            following_max.append(max(float(f.max_pulses.max()) for f in following))
            following_rms.append(round(max(float(f.rms_pulses.max()) for f in following), 1))
    return deviations, finals, following_max, following_rms


def deviation(
    plans: dict[int, list[PlannedPoint]], maps: list[AxisMap], ticks: list[Tick]
) -> tuple[float, int]:
    """(max |commanded - closed form| over every tick and group, final feedback error)."""
    first = next(t.tick for t in ticks if any(any(g.increment) for g in t.groups))
    # By tick number: a tick sample the observer missed is skipped, not misaligned.
    by_number = {t.tick: t for t in ticks}
    worst = 0.0
    final = 0
    for g, plan in plans.items():
        knots = [
            Knot(
                time_to_ns(wire(p.time)),
                np.array([wire(x) for x in p.positions]),
                np.array([wire(x) for x in p.velocities]),
            )
            for p in plan
        ]
        axes = maps[g].axes
        end = knots[-1].time_ns
        count = -(-end // PERIOD_NS)  # ticks until the last waypoint is applied
        grid = np.minimum(np.arange(1, count + 1, dtype=np.int64) * PERIOD_NS, end)
        exact = closed_form(knots, grid, maps[g])
        seen = [j for j in range(count) if first + j in by_number]
        applied = np.array([by_number[first + j].groups[g].command_pulses[:axes] for j in seen])
        worst = max(worst, float(np.max(np.abs(applied - exact[seen]))))
        target = maps[g].ros_to_pulses(knots[-1].positions)
        feedback = np.array(ticks[-1].groups[g].feedback_pulses[:axes])
        final = max(final, int(np.max(np.abs(feedback - target))))
    return worst, final


def run(quick: bool) -> list[dict[str, Any]]:
    segments = QUICK_SEGMENTS if quick else SEGMENTS
    catalogue = load_catalogue()
    deviation: list[float] = []
    mismatched: list[float] = []
    final: list[float] = []
    entries = 0
    for seed in range(RUNS):
        worst, wrong, finals = 0.0, 0, 0
        for index, (name, model) in enumerate(sorted(catalogue.items())):
            group = Group(index, name, name, model, tuple(model.initial_position), model.ranges)
            d, m, n, f = pure_once(group, segments, seed * 100 + index)
            worst, wrong, finals = max(worst, d), wrong + m, max(finals, f)
            entries += n
        deviation.append(worst)
        mismatched.append(float(wrong))
        final.append(float(finals))
    e2e_deviation, e2e_final, following_max, following_rms = e2e_runs(
        QUICK_E2E_POINTS if quick else E2E_POINTS
    )
    note = (
        f"{len(catalogue)} models x {segments} random segments per run, "
        f"{entries // RUNS:,} entries per run"
    )
    return [
        figure_result(
            FIGURE,
            "max |applied - closed form|",
            "pulse",
            deviation,
            goal=("<=", GOAL_PULSES),
            rule="all",
            note=note,
        ),
        figure_result(FIGURE, "entries != round(closed form)", "entries", mismatched),
        figure_result(FIGURE, "final error", "pulse", final, goal=("==", 0), rule="all"),
        figure_result(
            FIGURE,
            "end to end: max |commanded - closed form| per tick",
            "pulse",
            e2e_deviation,
            goal=("<=", GOAL_PULSES),
            rule="all",
            note="4-group cell, random 2016 trajectory, float32 wire values",
        ),
        figure_result(
            FIGURE,
            "end to end: final feedback - last point",
            "pulse",
            e2e_final,
            goal=("==", 0),
            rule="all",
        ),
        figure_result(
            FIGURE,
            "end to end: following error max (worst axis)",
            "pulse",
            following_max,
            note="commanded - feedback while moving, the catalogue's servos (docs/servo.md)",
        ),
        figure_result(
            FIGURE, "end to end: following error RMS (worst axis)", "pulse", following_rms
        ),
    ]
