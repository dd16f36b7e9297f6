"""Trajectory/Segment against the closed form of incremental-motion §2.7.2, here in float64.

Every entry's cumulative absolute pulse position (start pulses + running sum of increments) must
equal round(p(t) * pulses_per_unit) in Motoman axis order, i.e. deviate by at most 0.5 pulse from
the float closed form; grid entries sit exactly on ``anchor + k * period`` (anchor = the
sequence-0 time) and every waypoint gets its own entry, partial when off the grid. The sum of the
increments is the last waypoint's pulses minus the start pulses, exactly.
"""

from __future__ import annotations

import itertools
import tracemalloc
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motocell.shared.config import Group, parse_cell
from motocell.shared.motion.interpolation import Entries, Knot, Trajectory, time_to_ns
from motocell.shared.motion.kinematics import AxisMap, FloatArray, IntArray

MS = 1_000_000
PERIOD = 4 * MS

# moto[i] = ros[SEVEN_AXIS[i]]: ROS S-L-E-U-R-B-T -> Motoman S-L-U-R-B-T-E (motoros1 §4.3).
SEVEN_AXIS = [0, 1, 3, 4, 5, 6, 2]


def group_of(model: str) -> Group:
    return parse_cell({"groups": [{"name": "G", "model": model}]}).groups[0]


def moto_scale(group: Group) -> tuple[list[int], FloatArray]:
    """(ROS index of each Motoman axis, pulses per unit in Motoman order)."""
    n = group.model.axes
    order = SEVEN_AXIS if group.model.seven_axis else list(range(n))
    ppu = np.array([group.model.pulses_per_unit[i] for i in order], dtype=np.float64)
    return order, ppu


def to_pulses_float(group: Group, ros: FloatArray) -> FloatArray:
    """Unrounded Motoman-order pulses for ROS-order positions, shape (k, n)."""
    order, ppu = moto_scale(group)
    result: FloatArray = ros[:, order] * ppu
    return result


def knot(time_ns: int, positions: list[float], velocities: list[float] | None = None) -> Knot:
    vel = velocities if velocities is not None else [0.0] * len(positions)
    return Knot(time_ns, np.array(positions, dtype=np.float64), np.array(vel, dtype=np.float64))


def cubic(start: Knot, end: Knot, times_ns: npt.NDArray[np.int64]) -> FloatArray:
    """incremental-motion §2.7.2 in float64: ROS-order positions at absolute times inside the
    segment."""
    duration = (end.time_ns - start.time_ns) / 1e9
    p0, p1, v0, v1 = start.positions, end.positions, start.velocities, end.velocities
    a1 = 6 * (p1 - p0) / duration**2 - 2 * (v1 + 2 * v0) / duration
    a2 = -12 * (p1 - p0) / duration**3 + 6 * (v0 + v1) / duration**2
    tau = ((times_ns - start.time_ns) / 1e9)[:, None]
    result: FloatArray = p0 + v0 * tau + a1 * tau**2 / 2 + a2 * tau**3 / 6
    return result


@dataclass
class Expected:
    times: npt.NDArray[np.int64]
    partial: npt.NDArray[np.bool_]
    pulses: FloatArray
    """Unrounded Motoman-order pulses of every entry."""


def expected_entries(group: Group, period: int, knots: list[Knot]) -> Expected:
    anchor = knots[0].time_ns
    times: list[npt.NDArray[np.int64]] = []
    partial: list[npt.NDArray[np.bool_]] = []
    positions: list[FloatArray] = []
    for start, end in itertools.pairwise(knots):
        # Grid instants strictly inside (start, end): smallest k with anchor + k P > start ...
        first = -(-(start.time_ns - anchor + 1) // period)
        # ... and largest k with anchor + k P < end.
        last = (end.time_ns - anchor - 1) // period
        grid = anchor + period * np.arange(first, last + 1, dtype=np.int64)
        times += [grid, np.array([end.time_ns], dtype=np.int64)]
        partial += [
            np.zeros(len(grid), dtype=np.bool_),
            np.array([(end.time_ns - anchor) % period != 0]),
        ]
        positions += [cubic(start, end, grid), end.positions[None, :]]
    return Expected(
        np.concatenate(times),
        np.concatenate(partial),
        to_pulses_float(group, np.vstack(positions)),
    )


def assert_pulses(actual: IntArray, expected: FloatArray) -> None:
    """``actual == round(expected)``; within 1e-6 of a .5 tie either neighbour is accepted."""
    assert actual.shape == expected.shape
    deviation = actual - expected
    assert np.all(np.abs(deviation) <= 0.5 + 1e-6), float(np.max(np.abs(deviation)))
    clear = np.abs(np.abs(expected - np.floor(expected)) - 0.5) > 1e-6
    assert np.array_equal(actual[clear], np.rint(expected[clear]).astype(np.int64))


def interpolate(
    group: Group, period: int, knots: list[Knot], start_pulses: IntArray, limit: int = 10**9
) -> tuple[Trajectory, Entries]:
    trajectory = Trajectory(AxisMap(group), period, knots[0], start_pulses)
    chunks: list[Entries] = []
    for end in knots[1:]:
        segment = trajectory.segment_to(end)
        while segment.remaining:
            chunk = segment.take(limit)
            assert 0 < len(chunk) <= limit
            chunks.append(chunk)
    n = group.model.axes
    return trajectory, Entries(
        np.concatenate([c.times_ns for c in chunks]) if chunks else np.zeros(0, np.int64),
        np.vstack([c.increments for c in chunks]) if chunks else np.zeros((0, n), np.int32),
        np.concatenate([c.partial for c in chunks]) if chunks else np.zeros(0, np.bool_),
    )


def check_closed_form(
    group: Group, period: int, knots: list[Knot], start_pulses: IntArray, entries: Entries
) -> None:
    expected = expected_entries(group, period, knots)
    assert entries.increments.dtype == np.int32
    assert np.array_equal(entries.times_ns, expected.times)
    assert np.array_equal(entries.partial, expected.partial)
    absolute = start_pulses + np.cumsum(entries.increments.astype(np.int64), axis=0)
    assert_pulses(absolute, expected.pulses)
    final = np.rint(to_pulses_float(group, knots[-1].positions[None, :])[0]).astype(np.int64)
    assert np.array_equal(absolute[-1], final)
    assert np.array_equal(entries.increments.astype(np.int64).sum(axis=0), final - start_pulses)


def start_pulses_of(group: Group, positions: FloatArray, offset: int = 0) -> IntArray:
    exact: IntArray = np.rint(to_pulses_float(group, positions[None, :])[0]).astype(np.int64)
    result: IntArray = exact + offset
    return result


ARM6 = group_of("arm6")
ARM7 = group_of("arm7")
TRACK = group_of("track1")


def test_time_to_ns_rounds_to_the_nearest_nanosecond() -> None:
    assert time_to_ns(0.0101) == 10_100_000
    assert time_to_ns(1 / 30) == 33_333_333
    assert time_to_ns(14399.999) == 14_399_999_000_000
    assert time_to_ns(0.0) == 0


def test_on_grid_waypoints_give_one_entry_per_period_and_no_partial() -> None:
    knots = [
        knot(0, [0.0] * 6),
        knot(40 * MS, [0.1, -0.2, 0.3, 0.5, -0.6, 1.0], [0.5, -0.5, 1.0, 2.0, -2.0, 3.0]),
        knot(80 * MS, [0.2, -0.1, 0.5, 0.6, -0.3, 1.1]),
    ]
    start = np.zeros(6, dtype=np.int64)
    trajectory, entries = interpolate(ARM6, PERIOD, knots, start)
    assert entries.times_ns.tolist() == [k * PERIOD for k in range(1, 21)]
    assert not entries.partial.any()
    check_closed_form(ARM6, PERIOD, knots, start, entries)
    assert trajectory.pulses.tolist() == [11734, -5867, 29335, 19556, -9778, 24189]


def test_off_grid_waypoints_give_partial_entries_and_the_grid_stays_anchored() -> None:
    p1 = [0.01, 0.02, -0.03, 0.04, 0.05, -0.06]
    p2 = [0.02, 0.01, -0.01, 0.05, 0.02, -0.02]
    knots = [
        knot(0, [0.0] * 6),
        knot(time_to_ns(0.0101), p1, [0.3] * 6),
        knot(time_to_ns(1 / 30), p2, [0.1] * 6),
        knot(time_to_ns(0.05), [0.0] * 6),
    ]
    start = np.zeros(6, dtype=np.int64)
    _, entries = interpolate(ARM6, PERIOD, knots, start)
    assert entries.times_ns.tolist() == [
        4 * MS, 8 * MS, 10_100_000,
        12 * MS, 16 * MS, 20 * MS, 24 * MS, 28 * MS, 32 * MS, 33_333_333,
        36 * MS, 40 * MS, 44 * MS, 48 * MS, 50 * MS,
    ]  # fmt: skip
    assert np.flatnonzero(entries.partial).tolist() == [2, 9, 14]  # 50 ms is off-grid too
    check_closed_form(ARM6, PERIOD, knots, start, entries)
    assert entries.increments.astype(np.int64).sum(axis=0).tolist() == [0] * 6


def test_grid_is_anchored_at_the_sequence_0_time_not_at_zero() -> None:
    knots = [knot(1_300_000, [0.0] * 6), knot(14_300_000, [0.01] * 6), knot(20 * MS, [0.0] * 6)]
    start = np.zeros(6, dtype=np.int64)
    _, entries = interpolate(ARM6, PERIOD, knots, start)
    assert entries.times_ns.tolist() == [
        5_300_000, 9_300_000, 13_300_000, 14_300_000, 17_300_000, 20 * MS,
    ]  # fmt: skip
    assert entries.partial.tolist() == [False, False, False, True, False, True]
    check_closed_form(ARM6, PERIOD, knots, start, entries)


def test_start_pulses_off_the_start_point_are_absorbed_by_the_first_increment() -> None:
    p0 = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    knots = [knot(0, p0.tolist()), knot(12 * MS, [0.1, 0.2, 0.3, 0.4, 0.5, 0.61])]
    start = start_pulses_of(ARM6, p0, offset=-17)
    _, entries = interpolate(ARM6, PERIOD, knots, start)
    check_closed_form(ARM6, PERIOD, knots, start, entries)
    # The first five axes do not move: the whole 17-pulse offset goes into the first entry.
    assert entries.increments[:, :5].tolist() == [[17] * 5, [0] * 5, [0] * 5]


def test_segment_shorter_than_one_period_gives_only_its_waypoint() -> None:
    knots = [
        knot(0, [0.0] * 6),
        knot(2_500_000, [0.001] * 6, [0.1] * 6),  # before the first grid instant
        knot(10_100_000, [0.002] * 6, [0.1] * 6),
        knot(11_300_000, [0.003] * 6),  # no grid instant in (10.1 ms, 11.3 ms)
    ]
    start = np.zeros(6, dtype=np.int64)
    _, entries = interpolate(ARM6, PERIOD, knots, start)
    assert entries.times_ns.tolist() == [2_500_000, 4 * MS, 8 * MS, 10_100_000, 11_300_000]
    assert entries.partial.tolist() == [True, False, False, True, True]
    check_closed_form(ARM6, PERIOD, knots, start, entries)


def test_segment_ending_on_the_next_grid_instant_is_one_full_entry() -> None:
    knots = [knot(0, [0.0] * 6), knot(PERIOD, [0.001] * 6)]
    start = np.zeros(6, dtype=np.int64)
    trajectory = Trajectory(AxisMap(ARM6), PERIOD, knots[0], start)
    segment = trajectory.segment_to(knots[1])
    assert segment.remaining == 1
    entries = segment.take(10)
    assert entries.times_ns.tolist() == [PERIOD]
    assert entries.partial.tolist() == [False]
    assert entries.increments.tolist() == [[59, 59, 59, 33, 33, 22]]
    assert segment.remaining == 0
    assert len(segment.take(10)) == 0


def test_zero_displacement_segment_gives_all_zero_increments() -> None:
    p = [0.3, -0.2, 0.1, 1.0, -1.0, 2.0]
    knots = [knot(0, p), knot(time_to_ns(0.1013), p)]
    start = start_pulses_of(ARM6, np.array(p))
    trajectory, entries = interpolate(ARM6, PERIOD, knots, start)
    assert len(entries) == 26  # 25 grid instants (4..100 ms) + the off-grid waypoint
    assert entries.partial.tolist() == [False] * 25 + [True]
    assert not entries.increments.any()
    assert np.array_equal(trajectory.pulses, start)


def test_remaining_counts_every_entry_still_to_come() -> None:
    trajectory = Trajectory(AxisMap(ARM6), PERIOD, knot(0, [0.0] * 6), np.zeros(6, np.int64))
    segment = trajectory.segment_to(knot(time_to_ns(0.0333), [0.1] * 6))
    assert segment.remaining == 9  # 4..32 ms, then 33.3 ms
    assert len(segment.take(4)) == 4
    assert segment.remaining == 5
    assert len(segment.take(5)) == 5
    assert segment.remaining == 0


@pytest.mark.parametrize("limit", [1, 2, 3, 7, 24, 25, 26, 50, 199])
def test_take_in_chunks_gives_the_same_entries_as_one_big_take(limit: int) -> None:
    rng = np.random.default_rng(7)
    times = np.cumsum(rng.integers(MS, 150 * MS, size=12))
    knots = [knot(0, [0.0] * 6)] + [
        knot(int(t), rng.uniform(-1, 1, 6).tolist(), rng.uniform(-0.5, 0.5, 6).tolist())
        for t in times
    ]
    start = np.zeros(6, dtype=np.int64)
    whole_trajectory, whole = interpolate(ARM6, PERIOD, knots, start)
    chunked_trajectory, chunked = interpolate(ARM6, PERIOD, knots, start, limit=limit)
    assert np.array_equal(chunked.times_ns, whole.times_ns)
    assert np.array_equal(chunked.increments, whole.increments)
    assert np.array_equal(chunked.partial, whole.partial)
    assert np.array_equal(chunked_trajectory.pulses, whole_trajectory.pulses)
    check_closed_form(ARM6, PERIOD, knots, start, whole)


def test_very_long_segment_is_produced_lazily_and_matches_the_closed_form() -> None:
    start_knot = knot(0, [0.0] * 6, [0.001, -0.001, 0.0, 0.002, 0.0, 0.0])
    end_knot = knot(3600 * 10**9, [1.0, -0.5, 0.3, 2.0, -1.0, 3.0])
    start = np.zeros(6, dtype=np.int64)
    trajectory = Trajectory(AxisMap(ARM6), PERIOD, start_knot, start)

    tracemalloc.start()
    try:
        segment = trajectory.segment_to(end_knot)
        first = segment.take(1000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # All 900 000 entries at once would need > 40 MB of int64 pulses alone.
    assert peak < 2_000_000
    assert segment.remaining == 900_000 - 1000

    absolute = start.copy()
    count = 0
    chunk = first
    while True:
        assert len(chunk) <= 100_000
        assert np.all(np.diff(chunk.times_ns) == PERIOD)
        assert chunk.times_ns[0] == (count + 1) * PERIOD
        running = absolute + np.cumsum(chunk.increments.astype(np.int64), axis=0)
        sample = np.array([0, len(chunk) // 2, len(chunk) - 1])
        assert_pulses(
            running[sample],
            to_pulses_float(ARM6, cubic(start_knot, end_knot, chunk.times_ns[sample])),
        )
        absolute = running[-1]
        count += len(chunk)
        if not segment.remaining:
            break
        chunk = segment.take(100_000)
    assert count == 900_000
    assert chunk.times_ns[-1] == 3600 * 10**9
    assert not chunk.partial.any()  # 3600 s is on the 4 ms grid
    final = start_pulses_of(ARM6, end_knot.positions)
    assert np.array_equal(absolute, final)
    assert np.array_equal(trajectory.pulses, final)


def test_long_multi_segment_trajectory_ends_exactly_on_the_last_waypoint() -> None:
    rng = np.random.default_rng(2024)
    limits = np.array(ARM6.model.max_speed)
    t = 1_234_567
    knots = [knot(t, rng.uniform(-3, 3, 6).tolist())]
    for _ in range(500):
        t += int(rng.integers(100_000, 120 * MS))  # many shorter than a period, most off-grid
        knots.append(
            knot(t, rng.uniform(-3, 3, 6).tolist(), (rng.uniform(-0.9, 0.9, 6) * limits).tolist())
        )
    start = start_pulses_of(ARM6, knots[0].positions, offset=5)
    trajectory, entries = interpolate(ARM6, PERIOD, knots, start)
    check_closed_form(ARM6, PERIOD, knots, start, entries)
    assert np.array_equal(trajectory.pulses, start_pulses_of(ARM6, knots[-1].positions))
    assert int(entries.partial.sum()) == sum(
        (k.time_ns - knots[0].time_ns) % PERIOD != 0 for k in knots[1:]
    )


@pytest.mark.parametrize("delta_ns", [0, -1, -PERIOD])
def test_point_whose_time_does_not_increase_is_refused(delta_ns: int) -> None:
    start = np.zeros(6, dtype=np.int64)
    k0 = knot(0, [0.0] * 6)
    k1 = knot(8 * MS, [0.01] * 6)
    k2 = knot(16 * MS, [0.03] * 6)
    trajectory = Trajectory(AxisMap(ARM6), PERIOD, k0, start)
    first = trajectory.segment_to(k1).take(100)
    assert not trajectory.reaches(knot(8 * MS + delta_ns, [0.02] * 6))
    assert trajectory.reaches(k2)
    with pytest.raises(ValueError, match="not after the previous"):
        trajectory.segment_to(knot(8 * MS + delta_ns, [0.02] * 6))
    # The refused point does not advance the trajectory: the next segment starts at k1.
    assert trajectory.last is k1
    second = trajectory.segment_to(k2).take(100)
    _, reference = interpolate(ARM6, PERIOD, [k0, k1, k2], start)
    assert np.array_equal(np.vstack([first.increments, second.increments]), reference.increments)
    assert second.times_ns.tolist() == [12 * MS, 16 * MS]
    check_closed_form(ARM6, PERIOD, [k0, k1, k2], start, reference)


def test_seven_axis_arm_increments_are_in_motoman_order() -> None:
    # Only ROS joint 2 (E) moves: its pulses must come out in Motoman slot 6, scaled by E's
    # pulses per radian (ROS index 2), not by slot 6's ROS joint (T).
    knots = [knot(0, [0.0] * 7), knot(12 * MS, [0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0])]
    start = np.zeros(7, dtype=np.int64)
    trajectory, entries = interpolate(ARM7, PERIOD, knots, start)
    assert entries.increments.shape == (3, 7)
    assert not entries.increments[:, :6].any()
    assert entries.increments[:, 6].sum() == 32768  # 0.5 rad x 65536
    check_closed_form(ARM7, PERIOD, knots, start, entries)
    assert trajectory.pulses.tolist() == [0, 0, 0, 0, 0, 0, 32768]


def test_seven_axis_arm_full_mapping_against_the_closed_form() -> None:
    ros_end = [0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7]
    knots = [
        knot(0, [0.0] * 7),
        knot(time_to_ns(0.0173), [v / 2 for v in ros_end], [0.2] * 7),
        knot(time_to_ns(0.05), ros_end),
    ]
    start = np.array([3, -4, 5, 0, 0, 1, -2], dtype=np.int64)
    trajectory, entries = interpolate(ARM7, PERIOD, knots, start)
    check_closed_form(ARM7, PERIOD, knots, start, entries)
    # S, L, U, R, B, T, E = ros[0], ros[1], ros[3], ros[4], ros[5], ros[6], ros[2]
    assert trajectory.pulses.tolist() == [6554, -13107, -26214, 18204, -21845, 17203, 19661]


def test_linear_axis_uses_pulses_per_metre() -> None:
    knots = [
        knot(0, [0.25]),
        knot(time_to_ns(0.5003), [0.75], [1.2]),
        knot(time_to_ns(1.0), [1.0]),
    ]
    start = np.array([250_000], dtype=np.int64)
    trajectory, entries = interpolate(TRACK, PERIOD, knots, start)
    check_closed_form(TRACK, PERIOD, knots, start, entries)
    assert entries.increments.shape == (251, 1)
    assert int(entries.increments.sum()) == 750_000
    assert trajectory.pulses.tolist() == [1_000_000]


# -- property ---------------------------------------------------------------------------


@dataclass
class Case:
    group: Group
    period: int
    knots: list[Knot]
    start: IntArray


GROUPS = [ARM6, ARM7, TRACK, group_of("positioner2")]


@st.composite
def cases(draw: st.DrawFn) -> Case:
    group = draw(st.sampled_from(GROUPS))
    n = group.model.axes
    period = draw(st.integers(1 * MS, 8 * MS))
    speeds = group.model.max_speed

    def point() -> tuple[list[float], list[float]]:
        positions = [draw(st.floats(-3.0, 3.0, allow_nan=False)) for _ in range(n)]
        velocities = [draw(st.floats(-s, s, allow_nan=False)) for s in speeds]
        return positions, velocities

    t = draw(st.integers(0, 10**12))
    first, _ = point()
    knots = [knot(t, first)]
    for _ in range(draw(st.integers(1, 6))):
        t += draw(st.one_of(st.integers(1_000, 2 * period), st.integers(1_000, 120 * MS)))
        knots.append(knot(t, *point()))
    offset = draw(st.integers(-30, 30))
    return Case(group, period, knots, start_pulses_of(group, knots[0].positions, offset))


@settings(
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(cases(), st.integers(1, 60))
def test_property_grid_entries_exact_end_and_half_pulse_deviation(case: Case, limit: int) -> None:
    trajectory, entries = interpolate(case.group, case.period, case.knots, case.start, limit)
    anchor, end = case.knots[0].time_ns, case.knots[-1].time_ns
    waypoints = {k.time_ns for k in case.knots[1:]}
    grid = set(range(anchor + case.period, end, case.period))
    times = entries.times_ns.tolist()
    # One entry per grid instant, one per waypoint, in time order, nothing else.
    assert times == sorted(grid | waypoints)
    assert entries.partial.tolist() == [
        t in waypoints and (t - anchor) % case.period != 0 for t in times
    ]
    check_closed_form(case.group, case.period, case.knots, case.start, entries)
    assert np.array_equal(trajectory.pulses, start_pulses_of(case.group, case.knots[-1].positions))
