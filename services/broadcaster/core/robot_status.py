"""ROBOT_STATUS's fields (motoros1 §6), from the controller's status and the newest tick."""

from __future__ import annotations

from motocell.shared.bus.schemas import ControllerStatus, RobotStatusFields, Tick

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
    moving = int(in_motion(tick))
    if status is None or not controller_alive:
        # Without the controller nothing is known but that motion is impossible.
        return RobotStatusFields(-1, -1, -1, -1, moving, -1, 0)
    return RobotStatusFields(
        drives_powered=int(status.servo_on and not status.eco),
        e_stopped=int(status.estop),
        error_code=status.alarms[0].code if status.alarms else 0,
        in_error=int(bool(status.alarms)),
        in_motion=moving,
        # MotoROS sends 2 in PLAY, else 1 (the industrial_msgs convention; the FS100 capture
        # shows 2), not the 2012 spec's 0 = auto / 1 = manual.
        mode=2 if status.play else 1,
        motion_possible=int(status.motion_ready),
    )
