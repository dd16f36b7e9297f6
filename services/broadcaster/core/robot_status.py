"""ROBOT_STATUS's fields (motoros1 §6), from the controller's status and the newest tick: when
the tick says the robot is in motion (``shared.robot_status`` maps the rest)."""

from __future__ import annotations

from motocell.shared.bus.schemas import ControllerStatus, RobotStatusFields, Tick
from motocell.shared.robot_status import robot_status_fields

IN_MOTION_PULSES = 30
"""in_motion also while |feedback - command| exceeds 30 pulses on any axis (motoros1 §6,
v1.8.1)."""


def in_motion(tick: Tick) -> bool:
    return any(
        group.depth > 0
        or any(
            abs(feedback - command) > IN_MOTION_PULSES
            for feedback, command in zip(group.feedback_pulses, group.command_pulses, strict=True)
        )
        for group in tick.groups
    )


def robot_status(
    status: ControllerStatus | None, tick: Tick, controller_alive: bool
) -> RobotStatusFields:
    return robot_status_fields(status, in_motion(tick), controller_alive)
