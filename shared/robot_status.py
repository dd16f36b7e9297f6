"""ROBOT_STATUS's fields (motoros1 §6) from the controller's status: what the state port sends,
what the ``state`` sample carries, and what the ROS 2 face's ``robot_status`` says."""

from __future__ import annotations

from motocell.shared.bus.schemas import ControllerStatus, RobotStatusFields


def robot_status_fields(
    status: ControllerStatus | None, in_motion: bool, controller_alive: bool
) -> RobotStatusFields:
    """``in_motion`` is the motion system's (the newest tick's), the rest the controller's."""
    moving = int(in_motion)
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
