"""What the executor starts from: the cell file's groups (their speed limits, ranges and servo
models) and where the robot is, which across an executor restart is what the broadcaster
remembers. Pure."""

from __future__ import annotations

import logging

import numpy as np

from motocell.services.executor.core.executor import ExecutorCore
from motocell.shared.bus.schemas import CommandReply
from motocell.shared.config import Cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.motion.servo import Servos
from motocell.shared.protocol.constants import Result

log = logging.getLogger("executor")


def pulse_ranges(cell: Cell) -> list[tuple[list[int], list[int]]]:
    """Each group's motion range as (lower, upper) pulses in Motoman order (unused axes 0),
    converted as positions are, so a point exactly at a limit lands exactly on it."""
    ranges = []
    for group in cell.groups:
        axis_map = AxisMap(group)
        lower, upper = np.array(group.joint_limits, dtype=np.float64).T
        ranges.append(
            (
                axis_map.pad_moto(axis_map.ros_to_pulses(lower)),
                axis_map.pad_moto(axis_map.ros_to_pulses(upper)),
            )
        )
    return ranges


def starting_pulses(cell: Cell, remembered: CommandReply | None) -> list[list[int]]:
    """Where the robot is: across an executor restart, the commanded pulses of the newest tick
    the broadcaster had (``remembered``, its reply to ``positions``); without them, the cell
    file's initial positions."""
    if (
        remembered is not None
        and remembered.result == Result.SUCCESS
        and len(remembered.pulses) == len(cell.groups)
    ):
        log.info("resuming from the last commanded position")
        return remembered.pulses
    pulses = []
    for group in cell.groups:
        axis_map = AxisMap(group)
        pulses.append(axis_map.pad_moto(axis_map.ros_to_pulses(np.array(group.initial_position))))
    return pulses


def core_for_cell(cell: Cell, remembered: CommandReply | None, first_epoch: int) -> ExecutorCore:
    """The core of ``cell``'s executor, starting where ``starting_pulses`` says, its rings'
    epochs numbered from ``first_epoch``."""
    start = starting_pulses(cell, remembered)
    return ExecutorCore(
        start,
        first_epoch,
        max_increments=[AxisMap(group).max_increments(cell.period_s) for group in cell.groups],
        ranges=pulse_ranges(cell),
        period_ns=cell.period_ns,
        servos=Servos([group.servo for group in cell.groups], cell.period_s, start),
        max_lateness_periods=cell.max_lateness_periods,
    )
