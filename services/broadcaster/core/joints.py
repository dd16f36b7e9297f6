"""A tick's joints as the state carries them: per group, in radians (or metres) and ROS joint
order."""

from __future__ import annotations

from motocell.shared.bus.schemas import GroupState, Tick
from motocell.shared.config import Cell
from motocell.shared.motion.kinematics import AxisMap


class JointStates:
    """Turns a tick into per-group joint states in radians (or metres) and ROS joint order."""

    def __init__(self, cell: Cell) -> None:
        self.maps = [AxisMap(group) for group in cell.groups]
        self.per_second = 1e9 / cell.period_ns

    def groups(self, tick: Tick, commanded: bool = True) -> list[GroupState]:
        """``commanded``: also the commanded joints, which only observers get; the state
        port's frames carry the feedback alone, and leaving the rest out halves the
        conversion every state period (``command_positions`` then stays empty)."""
        result = []
        for index, (axis_map, group) in enumerate(zip(self.maps, tick.groups, strict=True)):
            # What an axis moved this period, pulses per period to rad/s: the servo's feedback
            # (MotoROS sends the servo's speed feedback, motoros1 §6), and the command.
            positions = axis_map.ros_values(group.feedback_pulses)
            velocities = axis_map.ros_values(group.feedback_moved, self.per_second)
            if not commanded:
                result.append(GroupState(index, positions, velocities, command_positions=[]))
                continue
            result.append(
                GroupState(
                    group_no=index,
                    positions=positions,
                    velocities=velocities,
                    command_positions=axis_map.ros_values(group.command_pulses),
                    command_velocities=axis_map.ros_values(group.increment, self.per_second),
                )
            )
        return result
