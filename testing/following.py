"""The following error of a motion, from the executor's ticks: commanded minus feedback pulses
per axis, its largest magnitude and its RMS while the robot moves (the demo and figure 8 report
them next to the final error; docs/servo.md says what to expect)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from motocell.shared.bus.schemas import Tick
from motocell.shared.config import Cell, Group
from motocell.shared.motion.kinematics import AxisMap, FloatArray


@dataclass(frozen=True)
class FollowingError:
    """One group's following error over a motion, per axis in ROS order."""

    group: Group
    max_pulses: FloatArray
    rms_pulses: FloatArray
    max_units: FloatArray
    """``max_pulses`` in radians (metres for a linear axis)."""
    rms_units: FloatArray


def moving(ticks: Sequence[Tick]) -> list[Tick]:
    """The ticks in which some axis of some group moved, commanded or feedback: the motion and
    the servo's settling after it, none of the rest before or after."""
    return [
        tick
        for tick in ticks
        if any(any(g.increment) or any(g.feedback_moved) for g in tick.groups)
    ]


def following_errors(cell: Cell, ticks: Sequence[Tick]) -> list[FollowingError]:
    """Every group's following error over ``moving(ticks)``; zeros when nothing moved."""
    during = moving(ticks)
    result = []
    for group in cell.groups:
        axis_map = AxisMap(group)
        axes = axis_map.axes
        error = np.array(
            [
                np.subtract(
                    t.groups[group.index].command_pulses, t.groups[group.index].feedback_pulses
                )[:axes]
                for t in during
            ],
            dtype=np.float64,
        ).reshape(len(during), axes)
        peak = np.abs(error).max(axis=0) if during else np.zeros(axes)
        rms = np.sqrt((error**2).mean(axis=0)) if during else np.zeros(axes)
        ros = axis_map.moto_index_of_ros
        per_unit = axis_map.pulses_per_unit_moto
        result.append(
            FollowingError(
                group, peak[ros], rms[ros], (peak / per_unit)[ros], (rms / per_unit)[ros]
            )
        )
    return result
