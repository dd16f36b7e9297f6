"""Trajectory-point checks in MotoROS's order (motoros1 §2.4-2.6). Pure.

The gateway answers a point from state it already holds (motion-ready, commanded position,
the pending slot) because a Zenoh round trip alone costs more than a real controller's whole
0.34 ms reply (docs/reply-path.md). These functions decide the reply.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import REQUIRED_POINT_FIELDS, InvalidSubcode, Result

MAX_TRAJECTORY_TIME_S = 14400.0
"""4 h: beyond this float32 seconds lose millisecond precision (motoros1 §2.4 step 4, 3016)."""
START_TOLERANCE_PULSES = 30
"""Sequence-0 start position vs the *commanded* position, per axis (motoros1 §2.6, since v1.8.2)."""
MAX_ABS_PULSES = 2**30
"""Positions whose pulses reach this are refused: differences of two such values still fit
the int32 increments on the wire between interpolator and executor."""

Verdict = tuple[int, int]
OK: Verdict = (int(Result.SUCCESS), 0)


def invalid(subcode: InvalidSubcode) -> Verdict:
    return int(Result.INVALID), int(subcode)


@dataclass(frozen=True)
class PointData:
    """One group's part of a point: what 14 and each block of 2016 carry."""

    group_no: int
    valid_fields: int
    time: float
    positions: Sequence[float]
    velocities: Sequence[float]


_REQUIRED_FIELDS = int(REQUIRED_POINT_FIELDS)
"""As a plain int: masking with the flag would build an enum member on every point."""


def check_fields(point: PointData) -> Verdict | None:
    """motoros1 §2.4 step 3: time, position and velocity must all be present (3015)."""
    if point.valid_fields & _REQUIRED_FIELDS != _REQUIRED_FIELDS:
        return invalid(InvalidSubcode.DATA_INSUFFICIENT)
    return None


def check_time_limit(point: PointData) -> Verdict | None:
    """motoros1 §2.4 step 4 (3016). Also refuses NaN/infinite times, which MotoROS lets through."""
    if not math.isfinite(point.time) or point.time >= MAX_TRAJECTORY_TIME_S:
        return invalid(InvalidSubcode.DATA_TIME)
    return None


def position_bounds(axis_map: AxisMap) -> tuple[float, ...]:
    """Per axis (ROS order), the size of a position whose pulses reach MAX_ABS_PULSES: worked
    out once per group, so checking a point takes no array arithmetic (it is on every reply)."""
    bounds = [0.0] * axis_map.axes
    for moto, ros in enumerate(axis_map.ros_index_of_moto.tolist()):
        bounds[ros] = MAX_ABS_PULSES / float(axis_map.pulses_per_unit_moto[moto])
    return tuple(bounds)


def check_positions(point: PointData, bounds: Sequence[float]) -> Verdict | None:
    """Positions must be finite and convertible to pulses (3012, ``position_bounds``). MotoROS
    does not check; a huge value would overflow the pulse arithmetic (and dodge the start
    check) instead. NaN fails the comparison too."""
    positions = point.positions[: len(bounds)]
    if not all(abs(p) < bound for p, bound in zip(positions, bounds, strict=True)):
        return invalid(InvalidSubcode.DATA_POSITION)
    return None


def _speed_ok(velocity: float, limit: float) -> bool:
    """MotoROS compares ``abs()`` of the *integer-truncated* velocity [quirk, motoros1 §2.6]:
    2.9 rad/s passes a 2.0 limit there. We compare the real value; NaN is refused too (it
    would pass any ``>`` comparison)."""
    return abs(velocity) <= limit


def check_speeds(point: PointData, axis_map: AxisMap) -> Verdict | None:
    """Velocities within the axis limits (3013), for points after the first."""
    for velocity, limit in zip(
        point.velocities[: axis_map.axes], axis_map.max_speed_ros.tolist(), strict=True
    ):
        if not _speed_ok(velocity, limit):
            return invalid(InvalidSubcode.DATA_SPEED)
    return None


def check_start(
    point: PointData, axis_map: AxisMap, command_pulses: Sequence[int]
) -> Verdict | None:
    """motoros1 §2.6, axis by axis as MotoROS loops: within 30 pulses of the *commanded* position
    (3011), then that index's velocity within its limit (3013)."""
    requested = axis_map.ros_to_pulses(np.array(point.positions[: axis_map.axes], dtype=np.float64))
    limits = axis_map.max_speed_ros.tolist()
    for axis in range(axis_map.axes):
        if abs(int(requested[axis]) - command_pulses[axis]) > START_TOLERANCE_PULSES:
            return invalid(InvalidSubcode.DATA_START_POS)
        if not _speed_ok(point.velocities[axis], limits[axis]):
            return invalid(InvalidSubcode.DATA_SPEED)
    return None
