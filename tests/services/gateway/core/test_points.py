"""Trajectory-point checks (motoros1 §2.4-2.6): fields 3015, time 3016,
position 3012, speed 3013, start position 3011."""

from __future__ import annotations

import math
from collections.abc import Sequence

import pytest

from motocell.services.gateway.core.points import (
    MAX_ABS_PULSES,
    MAX_TRAJECTORY_TIME_S,
    OK,
    START_TOLERANCE_PULSES,
    PointData,
    Verdict,
    check_fields,
    check_positions,
    check_speeds,
    check_start,
    check_time_limit,
    invalid,
    position_bounds,
)
from motocell.shared.config import parse_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import InvalidSubcode

ARM6 = AxisMap(parse_cell({}).groups[0])
ARM7 = AxisMap(parse_cell({"groups": [{"name": "R1", "model": "arm7"}]}).groups[0])
TRACK = AxisMap(parse_cell({"groups": [{"name": "B1", "model": "track1"}]}).groups[0])

INVALID = 3


def check_values(point: PointData, axis_map: AxisMap) -> Verdict | None:
    """Positions, then speeds: the data checks of a point after the first."""
    return check_positions(point, position_bounds(axis_map)) or check_speeds(point, axis_map)


def data(
    positions: Sequence[float] = (0.0,) * 10,
    velocities: Sequence[float] = (0.0,) * 10,
    valid_fields: int = 7,
    time: float = 0.0,
) -> PointData:
    """A point as the wire carries it: 10 joint slots, padded with zeros."""
    return PointData(
        group_no=0,
        valid_fields=valid_fields,
        time=time,
        positions=[*positions, *([0.0] * (10 - len(positions)))],
        velocities=[*velocities, *([0.0] * (10 - len(velocities)))],
    )


def test_verdict_helpers() -> None:
    assert OK == (0, 0)
    assert invalid(InvalidSubcode.DATA_SPEED) == (3, 3013)
    assert (MAX_TRAJECTORY_TIME_S, START_TOLERANCE_PULSES) == (14400.0, 30)


@pytest.mark.parametrize(
    ("valid_fields", "verdict"),
    [
        (7, None),
        (15, None),  # acceleration is optional
        (0xFF, None),
        (0, (INVALID, 3015)),
        (3, (INVALID, 3015)),  # no velocity
        (5, (INVALID, 3015)),  # no position
        (6, (INVALID, 3015)),  # no time
        (8 | 4 | 2, (INVALID, 3015)),
    ],
)
def test_check_fields(valid_fields: int, verdict: tuple[int, int] | None) -> None:
    assert check_fields(data(valid_fields=valid_fields)) == verdict


@pytest.mark.parametrize(
    ("time", "verdict"),
    [
        (0.0, None),
        (-5.0, None),  # MotoROS has no check on negative or decreasing time
        (14399.999, None),
        (14400.0, (INVALID, 3016)),
        (1e9, (INVALID, 3016)),
        (math.nan, (INVALID, 3016)),
        (math.inf, (INVALID, 3016)),
        (-math.inf, (INVALID, 3016)),
    ],
)
def test_check_time_limit(time: float, verdict: tuple[int, int] | None) -> None:
    assert check_time_limit(data(time=time)) == verdict


def test_check_values_accepts_speeds_up_to_the_limit() -> None:
    limits = [6.54, 5.50, 7.15, 9.60, 9.60, 13.96]
    assert check_values(data(velocities=limits), ARM6) is None
    assert check_values(data(velocities=[-v for v in limits]), ARM6) is None


@pytest.mark.parametrize("axis", range(6))
def test_check_values_refuses_a_speed_over_the_limit_on_any_axis(axis: int) -> None:
    limit = [6.54, 5.50, 7.15, 9.60, 9.60, 13.96][axis]
    for velocity in (math.nextafter(limit, math.inf), -limit - 0.01, math.nan, math.inf):
        velocities = [0.0] * 6
        velocities[axis] = velocity
        assert check_values(data(velocities=velocities), ARM6) == (INVALID, 3013), velocity


def test_check_values_compares_the_real_speed_not_its_integer_part() -> None:
    # MotoROS's integer abs() would pass 2.99 against 2.96 [quirk]; we do not.
    assert check_values(data(velocities=[2.99, 0, 0, 0, 0, 0, 0]), ARM7) == (INVALID, 3013)


def test_check_values_uses_ros_order_limits_on_a_seven_axis_arm() -> None:
    # ROS joint 4 (R) allows 3.49 rad/s, ROS joint 2 (E) only 2.96.
    assert check_values(data(velocities=[0, 0, 0, 0, 3.2, 0, 0]), ARM7) is None
    assert check_values(data(velocities=[0, 0, 3.2, 0, 0, 0, 0]), ARM7) == (INVALID, 3013)
    assert check_values(data(velocities=[0, 0, 0, 0, 0, 0, 6.28]), ARM7) is None


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_check_values_refuses_non_finite_positions(bad: float) -> None:
    for axis in range(6):
        positions = [0.0] * 6
        positions[axis] = bad
        assert check_values(data(positions=positions), ARM6) == (INVALID, 3012)


def test_position_error_is_reported_before_speed_error() -> None:
    point = data(positions=[math.nan] + [0.0] * 5, velocities=[100.0] * 6)
    assert check_values(point, ARM6) == (INVALID, 3012)


def test_check_values_ignores_slots_beyond_the_group_axes() -> None:
    point = data(
        positions=[0.0] * 6 + [math.nan, math.inf, 1e30, -1.0],
        velocities=[0.0] * 6 + [math.nan, 1e9, -1e9, 99.0],
    )
    assert check_values(point, ARM6) is None
    track_point = data(positions=[1.0, math.nan], velocities=[1.5, 50.0])
    assert check_values(track_point, TRACK) is None
    assert check_values(data(velocities=[1.51]), TRACK) == (INVALID, 3013)


def test_check_start_within_30_pulses_of_the_command() -> None:
    command = [100, -200, 300, 400, -500, 600, 0, 0]
    ppu = [58670.0, 58670.0, 58670.0, 32594.0, 32594.0, 21990.0]
    exact = [c / p for c, p in zip(command, ppu, strict=False)]
    assert check_start(data(positions=exact), ARM6, command) is None
    bad = (INVALID, 3011)
    for axis in range(6):
        for delta, verdict in ((30, None), (-30, None), (31, bad), (-31, bad)):
            positions = list(exact)
            positions[axis] = (command[axis] + delta) / ppu[axis]
            assert check_start(data(positions=positions), ARM6, command) == verdict, (axis, delta)


def test_check_start_rounds_the_requested_position_to_pulses() -> None:
    command = [0] * 8
    assert check_start(data(positions=[30.4 / 58670.0]), ARM6, command) is None
    assert check_start(data(positions=[30.6 / 58670.0]), ARM6, command) == (INVALID, 3011)


def test_check_start_compares_in_motoman_order_on_a_seven_axis_arm() -> None:
    # Motoman slot 6 is the E axis, ROS joint 2.
    command = [0, 0, 0, 0, 0, 0, 65536, 0]
    assert check_start(data(positions=[0, 0, 1.0, 0, 0, 0, 0]), ARM7, command) is None
    assert check_start(data(positions=[0, 0, 0, 0, 0, 0, 1.0]), ARM7, command) == (
        INVALID,
        3011,
    )


def test_check_start_ignores_command_slots_beyond_the_group_axes() -> None:
    assert check_start(data(positions=[0.5]), TRACK, [500_000, 9, 9, 9, 9, 9, 9, 9]) is None
    assert check_start(data(positions=[0.5]), TRACK, [500_031, 0, 0, 0, 0, 0, 0, 0]) == (
        INVALID,
        3011,
    )


def test_positions_beyond_the_pulse_range_are_refused() -> None:
    # 1e15 rad would overflow the pulse arithmetic and slip past the start check.
    assert check_positions(data(positions=[1e15, 0, 0, 0, 0, 0]), position_bounds(ARM6)) == (
        INVALID,
        3012,
    )
    assert check_positions(data(positions=[20000.0, 0, 0, 0, 0, 0]), position_bounds(ARM6)) == (
        INVALID,
        3012,
    )
    assert check_positions(data(positions=[1000.0, 0, 0, 0, 0, 0]), position_bounds(ARM6)) is None


@pytest.mark.parametrize("axis_map", [ARM6, ARM7, TRACK])
def test_position_bounds_are_each_axis_own_in_ros_order(axis_map: AxisMap) -> None:
    pulses_per_unit = axis_map.pulses_per_unit_moto[axis_map.moto_index_of_ros]
    assert position_bounds(axis_map) == pytest.approx(tuple(MAX_ABS_PULSES / pulses_per_unit))


def test_start_check_goes_axis_by_axis_like_motoros() -> None:
    command = [0] * 8
    # Axis 0 too fast, axis 3 too far: axis 0 is looked at first, so 3013.
    point = data(positions=[0, 0, 0, 0.01, 0, 0], velocities=[100.0, 0, 0, 0, 0, 0])
    assert check_start(point, ARM6, command) == (INVALID, 3013)
    # Axis 0 too far, axis 3 too fast: 3011.
    point = data(positions=[0.01, 0, 0, 0, 0, 0], velocities=[0, 0, 0, 100.0, 0, 0])
    assert check_start(point, ARM6, command) == (INVALID, 3011)
