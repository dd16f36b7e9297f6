"""One state cycle as Simple Message frames, the way MotoROS's state server sends it
(motoros1 §6). Pure: a ``State`` in, its messages' bytes out, built once per cycle for every
client.

The frames go out 250 times a second to up to four clients, so each is packed by one
precompiled ``struct`` from the protocol's own layouts (``shared.protocol.layouts``) instead of
through the generic codec: the bytes are the codec's (tests/services/broadcaster/test_frames.py
compares them), the work a fraction.
"""

from __future__ import annotations

import struct
from functools import cache

from motocell.shared.bus.schemas import GroupState, State
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import (
    MAX_GROUPS,
    MAX_JOINTS,
    CommType,
    MsgType,
    ReplyType,
    ValidFields,
)
from motocell.shared.protocol.layouts import FRAME_HEAD, JOINT_BLOCK

FEEDBACK_FIELDS = int(ValidFields.POSITION | ValidFields.VELOCITY)
"""MotoROS 1.9 sends 6 when it can read speed feedback (the 2012 spec's 2 is superseded)."""

_ZEROS = (0.0,) * MAX_JOINTS
_LENGTH_PREFIX_SIZE = 4
_TOPIC = (int(CommType.TOPIC), int(ReplyType.INVALID))
"""What every state-port message carries as comm and reply type."""
_STATUS_BODY = "7i"


class _Layouts:
    """The three frame formats of one byte order, head (prefix and header) and body together."""

    def __init__(self, order: ByteOrder) -> None:
        head = FRAME_HEAD[order].format[1:]  # without the byte-order character
        prefix = order.struct_prefix
        self.feedback = struct.Struct(prefix + head + JOINT_BLOCK)
        self.feedback_ex = struct.Struct(prefix + head + "i" + JOINT_BLOCK * MAX_GROUPS)
        self.status = struct.Struct(prefix + head + _STATUS_BODY)

    @staticmethod
    def length(layout: struct.Struct) -> int:
        """The prefix's value: the frame's size after the prefix."""
        return layout.size - _LENGTH_PREFIX_SIZE


@cache
def _layouts(order: ByteOrder) -> _Layouts:
    return _Layouts(order)


def _block(group: GroupState) -> tuple[float | int, ...]:
    """One JOINT_FEEDBACK body's values: time always 0, zero acceleration, zero beyond the
    group's axes (motoros1 §6)."""
    positions, velocities = group.positions, group.velocities
    return (
        group.group_no,
        FEEDBACK_FIELDS,
        0.0,
        *positions,
        *_ZEROS[len(positions) :],
        *velocities,
        *_ZEROS[len(velocities) :],
        *_ZEROS,
    )


_EMPTY_BLOCK = (0, 0, 0.0, *_ZEROS, *_ZEROS, *_ZEROS)
"""An unused slot of JOINT_FEEDBACK_EX: all zero."""


def state_frames(state: State, byte_order: ByteOrder) -> tuple[bytes, ...]:
    """JOINT_FEEDBACK per group, then JOINT_FEEDBACK_EX when there are 2+ groups (always 4
    slots), then ROBOT_STATUS, which ends the cycle for a client: one frame per message,
    since each is written on its own (``backlog``)."""
    layouts = _layouts(byte_order)
    feedback, feedback_ex, status = layouts.feedback, layouts.feedback_ex, layouts.status
    blocks = [_block(group) for group in state.groups]
    head = (_Layouts.length(feedback), int(MsgType.JOINT_FEEDBACK), *_TOPIC)
    frames = [feedback.pack(*head, *block) for block in blocks]
    if len(blocks) >= 2:
        slots = [value for block in blocks for value in block]
        slots += _EMPTY_BLOCK * (MAX_GROUPS - len(blocks))
        ex_head = (_Layouts.length(feedback_ex), int(MsgType.MOTO_JOINT_FEEDBACK_EX), *_TOPIC)
        frames.append(feedback_ex.pack(*ex_head, len(blocks), *slots))
    s = state.status
    frames.append(
        status.pack(
            _Layouts.length(status),
            int(MsgType.ROBOT_STATUS),
            *_TOPIC,
            s.drives_powered,
            s.e_stopped,
            s.error_code,
            s.in_error,
            s.in_motion,
            s.mode,
            s.motion_possible,
        )
    )
    return tuple(frames)
