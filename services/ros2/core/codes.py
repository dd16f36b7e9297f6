"""MotoROS2's result codes from the cell's Simple Message replies.

MotoROS2's ``MotionReadyEnum`` numbers its NOT_READY reasons as MotoROS1's subcodes less 4900
(ALARM 5001 -> 101, ..., INC_MOVE_ERROR 5012 -> 112), and the gateway tells the face that the
other face holds trajectory mode as 5014 -> 114 (NOT_READY_OTHER_TRAJ_MODE_ACTIVE). MotoROS2 has
no 110 (MotoROS1's SKILLSEND); what it has no code for is UNSPECIFIED.
"""

from __future__ import annotations

from motocell.shared.protocol.constants import Result

READY = 1
UNSPECIFIED = 100
NOT_READY_ALARM = 101
MOTION_READY_CODES = frozenset({READY, *range(100, 110), *range(111, 115)})
"""Every value of MotoROS2 0.2.1's ``MotionReadyEnum``."""
SUBCODE_OFFSET = 4900


def motion_ready_code(result: int, subcode: int) -> int:
    """A Simple Message reply to a motion command (START_TRAJ_MODE, RESET_ALARM,
    CHECK_MOTION_READY) as MotoROS2's ``MotionReadyEnum``."""
    if result in (Result.SUCCESS, Result.TRUE):
        return READY
    if result in (Result.NOT_READY, Result.FALSE):
        code = subcode - SUBCODE_OFFSET
        return code if code in MOTION_READY_CODES else UNSPECIFIED
    return UNSPECIFIED
