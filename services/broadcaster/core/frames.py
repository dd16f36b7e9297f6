"""One state cycle as Simple Message frames, the way MotoROS's state server sends it
(motoros1 §6). Pure: a ``State`` in, its messages' bytes out, built once per cycle for every
client.

The frames go out 250 times a second to up to four clients, so they are packed by precompiled
``struct``s from the protocol's own layouts (``shared.protocol.layouts``) instead of through the
generic codec, each group's block once for its JOINT_FEEDBACK and JOINT_FEEDBACK_EX, behind
heads packed once: the bytes are the codec's (tests/services/broadcaster/core/test_frames.py
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
    """The pieces of one byte order's frames: each frame's head (prefix and header) is the same
    every cycle, so it is packed once; a group's JOINT_FEEDBACK block is packed once per cycle
    and goes both into its own frame and into JOINT_FEEDBACK_EX. The pieces have no padding
    between them (``<`` and ``>`` formats), so joined they are the frame packed whole."""

    def __init__(self, order: ByteOrder) -> None:
        head = struct.Struct(FRAME_HEAD[order].format)
        prefix = order.struct_prefix
        self.block = struct.Struct(prefix + JOINT_BLOCK)
        self.count = struct.Struct(prefix + "i")
        self.status_body = struct.Struct(prefix + _STATUS_BODY)
        self.feedback_head = self._head(head, MsgType.JOINT_FEEDBACK, self.block.size)
        self.feedback_ex_head = self._head(
            head, MsgType.MOTO_JOINT_FEEDBACK_EX, self.count.size + self.block.size * MAX_GROUPS
        )
        self.status_head = self._head(head, MsgType.ROBOT_STATUS, self.status_body.size)
        self.empty_blocks = [self.block.pack(*_EMPTY_BLOCK) * (MAX_GROUPS - n) for n in range(5)]
        """The unused slots of JOINT_FEEDBACK_EX after ``n`` groups: all zero."""

    @staticmethod
    def _head(head: struct.Struct, msg_type: MsgType, body_size: int) -> bytes:
        """Prefix and header of a frame whose body is ``body_size`` bytes; the prefix counts
        what follows it."""
        length = head.size - _LENGTH_PREFIX_SIZE + body_size
        return head.pack(length, int(msg_type), *_TOPIC)


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
    pack_block, feedback_head = layouts.block.pack, layouts.feedback_head
    blocks = [pack_block(*_block(group)) for group in state.groups]
    frames = [feedback_head + block for block in blocks]
    if len(blocks) >= 2:
        frames.append(
            b"".join(
                (
                    layouts.feedback_ex_head,
                    layouts.count.pack(len(blocks)),
                    *blocks,
                    layouts.empty_blocks[len(blocks)],
                )
            )
        )
    s = state.status
    frames.append(
        layouts.status_head
        + layouts.status_body.pack(
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
