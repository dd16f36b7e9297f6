"""One frozen msgspec Struct per Simple Message body, fields in wire order.

Angles are radians (metres for linear axes), times seconds, all as the float32 the wire carries
(widened to Python floats). Joint arrays are always MAX_JOINTS (10) long after decoding; the
encoder pads shorter tuples with zeros.
"""

from __future__ import annotations

import msgspec

Floats = tuple[float, ...]


class Empty(msgspec.Struct, frozen=True):
    """The body of PING and of the GET_DH_PARAMETERS request: nothing."""


class RobotStatus(msgspec.Struct, frozen=True):
    """13 ROBOT_STATUS. Tri-state fields: -1 unknown, 0 false, 1 true. ``mode`` is MotoROS's
    2 = PLAY (auto), 1 = otherwise (the 2012 spec's 0/1 is superseded)."""

    drives_powered: int
    e_stopped: int
    error_code: int
    in_error: int
    in_motion: int
    mode: int
    motion_possible: int


class JointTrajPtFull(msgspec.Struct, frozen=True):
    """14 JOINT_TRAJ_PT_FULL: one trajectory point of one group, ROS joint order."""

    group_no: int
    sequence: int
    valid_fields: int
    time: float
    positions: Floats
    velocities: Floats
    accelerations: Floats


class JointFeedback(msgspec.Struct, frozen=True):
    """15 JOINT_FEEDBACK, also each slot of 2017 MOTO_JOINT_FEEDBACK_EX."""

    group_no: int
    valid_fields: int
    time: float
    positions: Floats
    velocities: Floats
    accelerations: Floats


class MotoMotionCtrl(msgspec.Struct, frozen=True):
    """2001 MOTO_MOTION_CTRL. ``data`` is reserved and ignored by MotoROS."""

    group_no: int
    sequence: int
    command: int
    data: Floats = ()


class MotoMotionReply(msgspec.Struct, frozen=True):
    """2002 MOTO_MOTION_REPLY. ``data`` is always zero from MotoROS."""

    group_no: int
    sequence: int
    command: int
    result: int
    subcode: int
    data: Floats = ()


class ReadIOBit(msgspec.Struct, frozen=True):
    """2003 MOTO_READ_IO_BIT."""

    address: int


class ReadIOBitReply(msgspec.Struct, frozen=True):
    """2004 MOTO_READ_IO_BIT_REPLY."""

    value: int
    result_code: int


class WriteIOBit(msgspec.Struct, frozen=True):
    """2005 MOTO_WRITE_IO_BIT."""

    address: int
    value: int


class WriteIOBitReply(msgspec.Struct, frozen=True):
    """2006 MOTO_WRITE_IO_BIT_REPLY."""

    result_code: int


class ReadIOGroup(msgspec.Struct, frozen=True):
    """2007 MOTO_READ_IO_GROUP: ``address`` is the byte number (bits address*10 + 0..7)."""

    address: int


class ReadIOGroupReply(msgspec.Struct, frozen=True):
    """2008 MOTO_READ_IO_GROUP_REPLY."""

    value: int
    result_code: int


class WriteIOGroup(msgspec.Struct, frozen=True):
    """2009 MOTO_WRITE_IO_GROUP."""

    address: int
    value: int


class WriteIOGroupReply(msgspec.Struct, frozen=True):
    """2010 MOTO_WRITE_IO_GROUP_REPLY."""

    result_code: int


class ReadMRegister(msgspec.Struct, frozen=True):
    """2012 MOTO_READ_MREGISTER request."""

    register: int


class ReadMRegisterReply(msgspec.Struct, frozen=True):
    """2012 reply: MotoROS 1.9.2+ re-uses the request's type number for the reply."""

    value: int
    result_code: int


class WriteMRegister(msgspec.Struct, frozen=True):
    """2013 MOTO_WRITE_MREGISTER request."""

    register: int
    value: int


class WriteMRegisterReply(msgspec.Struct, frozen=True):
    """2013 reply (type number re-used, like 2012)."""

    result_code: int


class JointTrajPtExGroup(msgspec.Struct, frozen=True):
    """One group's block of 2016 MOTO_JOINT_TRAJ_PT_FULL_EX (132 bytes, no own sequence)."""

    group_no: int
    valid_fields: int
    time: float
    positions: Floats
    velocities: Floats
    accelerations: Floats


class JointTrajPtFullEx(msgspec.Struct, frozen=True):
    """2016 MOTO_JOINT_TRAJ_PT_FULL_EX: 1-4 groups sharing one sequence number.

    On the wire ``number_of_valid_groups`` precedes ``sequence``; it is ``len(groups)`` and so
    not stored twice. A frame padded to the full 4-group size decodes to the listed groups only.
    """

    sequence: int
    groups: tuple[JointTrajPtExGroup, ...]


class JointFeedbackEx(msgspec.Struct, frozen=True):
    """2017 MOTO_JOINT_FEEDBACK_EX: always 4 slots on the wire, unused slots zero.

    Decoding yields all 4 slots; encoding pads ``groups`` with zero slots up to 4.
    """

    number_of_valid_groups: int
    groups: tuple[JointFeedback, ...]


class SelectTool(msgspec.Struct, frozen=True):
    """2018 MOTO_SELECT_TOOL. Wire order is group, tool, sequence (as MotoROS defines it)."""

    group_no: int
    tool: int
    sequence: int


class DhLink(msgspec.Struct, frozen=True):
    theta: float
    d: float
    a: float
    alpha: float


class GetDhParametersReply(msgspec.Struct, frozen=True):
    """2020 reply: 4 groups x 8 links; groups beyond the cell's count are zero."""

    groups: tuple[tuple[DhLink, ...], ...]


Body = (
    Empty
    | RobotStatus
    | JointTrajPtFull
    | JointFeedback
    | MotoMotionCtrl
    | MotoMotionReply
    | ReadIOBit
    | ReadIOBitReply
    | WriteIOBit
    | WriteIOBitReply
    | ReadIOGroup
    | ReadIOGroupReply
    | WriteIOGroup
    | WriteIOGroupReply
    | ReadMRegister
    | ReadMRegisterReply
    | WriteMRegister
    | WriteMRegisterReply
    | JointTrajPtFullEx
    | JointFeedbackEx
    | SelectTool
    | GetDhParametersReply
)


class Message(msgspec.Struct, frozen=True):
    """A whole Simple Message: header fields and decoded body."""

    msg_type: int
    comm_type: int
    reply_type: int
    body: Body


class UnknownMessage(msgspec.Struct, frozen=True):
    """A well-framed message whose type this side does not handle (the server answers 3003)."""

    msg_type: int
    comm_type: int
    reply_type: int
    body: bytes
