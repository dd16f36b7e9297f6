"""One state cycle as Simple Message frames, the way MotoROS's state server sends it
(motoros1 §6). Pure: a ``State`` in, its messages' bytes out, built once per cycle for every
client."""

from __future__ import annotations

from motocell.shared.bus.schemas import State
from motocell.shared.protocol.codec import ByteOrder, Role, encode
from motocell.shared.protocol.constants import MAX_JOINTS, MsgType, ValidFields
from motocell.shared.protocol.messages import JointFeedback, JointFeedbackEx, RobotStatus
from motocell.shared.protocol.replies import state_message

FEEDBACK_FIELDS = int(ValidFields.POSITION | ValidFields.VELOCITY)
"""MotoROS 1.9 sends 6 when it can read speed feedback (the 2012 spec's 2 is superseded)."""

_ZEROS = (0.0,) * MAX_JOINTS


def _joints(values: list[float]) -> tuple[float, ...]:
    return (*values, *([0.0] * (MAX_JOINTS - len(values))))


def state_frames(state: State, byte_order: ByteOrder) -> tuple[bytes, ...]:
    """JOINT_FEEDBACK per group, then JOINT_FEEDBACK_EX when there are 2+ groups (always 4
    slots), then ROBOT_STATUS, which ends the cycle for a client: one frame per message,
    since each is written on its own (``backlog``)."""
    feedback = [
        JointFeedback(
            g.group_no, FEEDBACK_FIELDS, 0.0, _joints(g.positions), _joints(g.velocities), _ZEROS
        )
        for g in state.groups
    ]
    messages = [state_message(MsgType.JOINT_FEEDBACK, body) for body in feedback]
    if len(feedback) >= 2:
        messages.append(
            state_message(
                MsgType.MOTO_JOINT_FEEDBACK_EX, JointFeedbackEx(len(feedback), tuple(feedback))
            )
        )
    s = state.status
    messages.append(
        state_message(
            MsgType.ROBOT_STATUS,
            RobotStatus(
                s.drives_powered,
                s.e_stopped,
                s.error_code,
                s.in_error,
                s.in_motion,
                s.mode,
                s.motion_possible,
            ),
        )
    )
    return tuple(encode(m, byte_order, Role.CONTROLLER) for m in messages)
