"""Every Simple Message byte layout, stated once.

All fields are packed 32-bit words (int32 ``i``, uint32 ``I``, float32 ``f``) in the controller
CPU's byte order: little-endian on DX100/DX200/YRC1000, big-endian on FS100; MotoROS never swaps
(motoros1 §1.1). Each body has one precompiled ``struct.Struct`` per byte order.

Frame: ``@0 length`` (int32, the bytes after it = 12 + body), ``@4 msg_type``, ``@8 comm_type``,
``@12 reply_type``, ``@16 body``. Body offsets below are from the body's start; ``[10]`` is
10 x float32 = 40 bytes; ``ctl``/``cli`` = received by the controller/client (motoros1 §1.2):

====  =======  ===========  =================================================================
type  to       body bytes   fields @offset
====  =======  ===========  =================================================================
1     ctl cli  0            (PING, and 2020 request)
13    cli ctl  28           drives_powered@0 e_stopped@4 error_code@8 in_error@12 in_motion@16
                            mode@20 motion_possible@24
14    ctl      136          group_no@0 sequence@4 valid_fields@8 time@12 pos[10]@16 vel[10]@56
                            acc[10]@96
15    cli ctl  132          group_no@0 valid_fields@4 time@8 pos[10]@12 vel[10]@52 acc[10]@92
2001  ctl      52           group_no@0 sequence@4 command@8 data[10]@12
2002  cli ctl  60           group_no@0 sequence@4 command@8 result@12 subcode@16 data[10]@20
2003  ctl      4            address(u)@0
2004  cli      8            value(u)@0 result_code@4
2005  ctl      8            address(u)@0 value(u)@4
2006  cli      4            result_code@0
2007  ctl      4            address(u, byte number)@0
2008  cli      8            value(u)@0 result_code@4
2009  ctl      8            address(u)@0 value(u)@4
2010  cli      4            result_code@0
2012  ctl      4            register(u)@0
2012  cli      8            value(u)@0 result_code@4           (reply re-uses the type number)
2013  ctl      8            register(u)@0 value(u)@4
2013  cli      4            result_code@0                      (reply re-uses the type number)
2016  ctl      8+132n, 536  number_of_valid_groups@0 sequence@4 block k@8+132k, n = 1..4;
                            block = group_no@0 valid_fields@4 time@8 pos@12 vel@52 acc@92
2017  cli ctl  532          number_of_valid_groups@0, slot k@4+132k for k = 0..3 (15's layout)
2018  ctl      12           group_no@0 tool@4 sequence@8
2020  cli      512          group g link l @128g+16l: theta@0 d@4 a@8 alpha@12
====  =======  ===========  =================================================================

A controller knows the sizes of 13, 15, 2002 and 2017 although it never handles them: MotoROS
then closes the connection (motoros1 §2.7), so they decode rather than come out as unknown types.
"""

from __future__ import annotations

import functools
import struct
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping
from enum import Enum, StrEnum
from typing import Any, Final

import msgspec

from motocell.shared.protocol.constants import (
    DH_LINKS,
    MAX_GROUPS,
    MAX_JOINTS,
    InvalidSubcode,
    MsgType,
)
from motocell.shared.protocol.errors import LocalProtocolError, PeerProtocolError
from motocell.shared.protocol.messages import (
    Body,
    DhLink,
    Empty,
    Floats,
    GetDhParametersReply,
    JointFeedback,
    JointFeedbackEx,
    JointTrajPtExGroup,
    JointTrajPtFull,
    JointTrajPtFullEx,
    MotoMotionCtrl,
    MotoMotionReply,
    ReadIOBit,
    ReadIOBitReply,
    ReadIOGroup,
    ReadIOGroupReply,
    ReadMRegister,
    ReadMRegisterReply,
    RobotStatus,
    SelectTool,
    WriteIOBit,
    WriteIOBitReply,
    WriteIOGroup,
    WriteIOGroupReply,
    WriteMRegister,
    WriteMRegisterReply,
)

Buffer = bytes | bytearray | memoryview
Decode = Callable[[Buffer, int, int], Body]
"""(buffer, offset of the body, body size) -> body; raises PeerProtocolError on a bad size."""
Encode = Callable[[Body], bytes]
"""body -> body bytes; raises LocalProtocolError for a body the wire cannot carry."""


class ByteOrder(StrEnum):
    """The controller CPU's order (motoros1 §1.1): LITTLE for DX100/DX200/YRC1000, BIG for
    FS100."""

    LITTLE = "little"
    BIG = "big"

    @property
    def struct_prefix(self) -> str:
        return "<" if self is ByteOrder.LITTLE else ">"


class Direction(Enum):
    TO_CONTROLLER = "to_controller"
    TO_CLIENT = "to_client"


def _structs(fmt: str) -> dict[ByteOrder, struct.Struct]:
    return {order: struct.Struct(order.struct_prefix + fmt) for order in ByteOrder}


PREFIX: Final = _structs("i")
HEADER: Final = _structs("3i")
FRAME_HEAD: Final = _structs("4i")
"""Prefix and header together, for encoding a frame in one call."""

ZERO_JOINTS: Final[Floats] = (0.0,) * MAX_JOINTS
JOINT_BLOCK: Final = "2i31f"
"""group_no, valid_fields, time, pos[10], vel[10], acc[10]: 15's body, 2016's and 2017's blocks."""
JOINT_BLOCK_SIZE: Final = struct.calcsize("<" + JOINT_BLOCK)
_BLOCK_VALUES = 33  # 3 scalars and 3 x 10 joints


def pad_joints(values: Floats) -> Floats:
    """``values`` widened to the 10 joint slots every message carries (unused slots are 0)."""
    if len(values) > MAX_JOINTS:
        raise LocalProtocolError(f"{len(values)} joint values; a message carries {MAX_JOINTS}")
    return (*values, *ZERO_JOINTS[len(values) :])


class BodyLayout(ABC):
    """How one body maps to bytes, with a decoder and an encoder per byte order."""

    msg_type: int
    body_type: type[Body]
    max_size: int
    """The largest legal body, which bounds the frame length a receiver accepts."""

    @abstractmethod
    def decoder(self, order: ByteOrder) -> Decode: ...

    @abstractmethod
    def encoder(self, order: ByteOrder) -> Encode: ...

    def _wrong_size(self, size: int, expected: str) -> PeerProtocolError:
        # motoros1 §2.7: a known type with the wrong size gets INVALID/3001.
        return PeerProtocolError(
            f"type {self.msg_type}: body of {size} bytes, expected {expected}",
            InvalidSubcode.MSGSIZE,
            self.msg_type,
        )

    def _encode_error(self, err: Exception) -> LocalProtocolError:
        return LocalProtocolError(f"type {self.msg_type}: cannot encode body: {err}")

    def _wrong_body(self, body: object) -> LocalProtocolError:
        return LocalProtocolError(
            f"type {self.msg_type} carries {self.body_type.__name__}, not {type(body).__name__}"
        )


class FixedLayout(BodyLayout):
    """A body of one fixed size. ``to_body``/``to_values`` default to the flat field order."""

    def __init__(
        self,
        msg_type: MsgType,
        body_type: type[Body],
        fmt: str,
        to_body: Callable[[tuple[Any, ...]], Body] | None = None,
        to_values: Callable[[Any], Iterable[Any]] = msgspec.structs.astuple,
    ) -> None:
        self.msg_type = int(msg_type)
        self.body_type = body_type
        self._structs = _structs(fmt)
        self.max_size = self._structs[ByteOrder.LITTLE].size
        self._to_body = to_body or (lambda values: body_type(*values))
        self._to_values = to_values

    def decoder(self, order: ByteOrder) -> Decode:
        unpack_from = self._structs[order].unpack_from
        size = self.max_size
        to_body = self._to_body

        def decode(buf: Buffer, offset: int, body_size: int) -> Body:
            if body_size != size:
                raise self._wrong_size(body_size, str(size))
            return to_body(unpack_from(buf, offset))

        return decode

    def encoder(self, order: ByteOrder) -> Encode:
        pack = self._structs[order].pack
        to_values = self._to_values

        def encode(body: Body) -> bytes:
            if not isinstance(body, self.body_type):
                raise self._wrong_body(body)
            try:
                return pack(*to_values(body))
            except (struct.error, OverflowError) as err:
                raise self._encode_error(err) from err

        return encode


def _feedback(v: tuple[Any, ...]) -> JointFeedback:
    return JointFeedback(v[0], v[1], v[2], v[3:13], v[13:23], v[23:33])


def _ex_group_at(v: tuple[Any, ...], i: int) -> JointTrajPtExGroup:
    return JointTrajPtExGroup(
        v[i], v[i + 1], v[i + 2], v[i + 3 : i + 13], v[i + 13 : i + 23], v[i + 23 : i + 33]
    )


def _block_values(block: JointFeedback | JointTrajPtExGroup) -> tuple[Any, ...]:
    return (
        block.group_no,
        block.valid_fields,
        block.time,
        *pad_joints(block.positions),
        *pad_joints(block.velocities),
        *pad_joints(block.accelerations),
    )


def _blocks_values(blocks: Iterable[JointFeedback | JointTrajPtExGroup]) -> list[Any]:
    values: list[Any] = []
    for block in blocks:
        values += _block_values(block)
    return values


def _traj_pt_full_values(b: JointTrajPtFull) -> tuple[Any, ...]:
    return (
        b.group_no,
        b.sequence,
        b.valid_fields,
        b.time,
        *pad_joints(b.positions),
        *pad_joints(b.velocities),
        *pad_joints(b.accelerations),
    )


def _motion_ctrl_values(b: MotoMotionCtrl) -> tuple[Any, ...]:
    return (b.group_no, b.sequence, b.command, *pad_joints(b.data))


def _motion_reply_values(b: MotoMotionReply) -> tuple[Any, ...]:
    return (b.group_no, b.sequence, b.command, b.result, b.subcode, *pad_joints(b.data))


ZERO_FEEDBACK: Final = JointFeedback(0, 0, 0.0, ZERO_JOINTS, ZERO_JOINTS, ZERO_JOINTS)
_ZERO_BLOCK: Final = bytes(JOINT_BLOCK_SIZE)


def _feedback_ex_values(b: JointFeedbackEx) -> list[Any]:
    # 2017 always has 4 slots; the real client rejects shorter frames (docs/spec/driver-client.md).
    if len(b.groups) > MAX_GROUPS:
        raise LocalProtocolError(f"2017: {len(b.groups)} groups; it has {MAX_GROUPS} slots")
    slots = (*b.groups, *(ZERO_FEEDBACK,) * (MAX_GROUPS - len(b.groups)))
    return [b.number_of_valid_groups, *_blocks_values(slots)]


ZERO_LINK: Final = DhLink(0.0, 0.0, 0.0, 0.0)
_DH_LINK_VALUES = 4
_DH_GROUP_VALUES = DH_LINKS * _DH_LINK_VALUES


def _dh_body(v: tuple[Any, ...]) -> GetDhParametersReply:
    return GetDhParametersReply(
        tuple(
            tuple(
                DhLink(*v[at : at + _DH_LINK_VALUES])
                for at in range(group_at, group_at + _DH_GROUP_VALUES, _DH_LINK_VALUES)
            )
            for group_at in range(0, MAX_GROUPS * _DH_GROUP_VALUES, _DH_GROUP_VALUES)
        )
    )


def _dh_values(b: GetDhParametersReply) -> tuple[float, ...]:
    # motoros1 §1.2: always 4 groups x 8 links; groups beyond the cell's count are zero.
    if len(b.groups) > MAX_GROUPS:
        raise LocalProtocolError(f"2020: {len(b.groups)} groups; the reply has {MAX_GROUPS}")
    values: list[float] = []
    for links in (*b.groups, *((),) * (MAX_GROUPS - len(b.groups))):
        if len(links) > DH_LINKS:
            raise LocalProtocolError(f"2020: {len(links)} links; a group has {DH_LINKS}")
        for link in (*links, *(ZERO_LINK,) * (DH_LINKS - len(links))):
            values += (link.theta, link.d, link.a, link.alpha)
    return tuple(values)


class FeedbackExLayout(FixedLayout):
    """2017: int32 number_of_valid_groups, then always 4 slots of 15's body (motoros1 §1.2,
    motoros1 §6).

    Encodes as any fixed layout; decodes slot by slot.
    """

    def __init__(self) -> None:
        super().__init__(
            MsgType.MOTO_JOINT_FEEDBACK_EX,
            JointFeedbackEx,
            "i" + JOINT_BLOCK * MAX_GROUPS,
            to_values=_feedback_ex_values,
        )
        self._counts = _structs("i")
        self._slots = _structs(JOINT_BLOCK)

    def decoder(self, order: ByteOrder) -> Decode:
        unpack_count = self._counts[order].unpack_from
        unpack_slot = self._slots[order].unpack_from
        size = self.max_size

        def slot(buf: Buffer, at: int) -> JointFeedback:
            # Slots beyond the cell's groups are all zero (motoros1 §6). Sharing one zero slot
            # instead of unpacking 33 zeros decodes a 2-group frame about 1.5 times as fast.
            if buf[at : at + JOINT_BLOCK_SIZE] == _ZERO_BLOCK:
                return ZERO_FEEDBACK
            return _feedback(unpack_slot(buf, at))

        def decode(buf: Buffer, offset: int, body_size: int) -> Body:
            if body_size != size:
                raise self._wrong_size(body_size, str(size))
            (n,) = unpack_count(buf, offset)
            return JointFeedbackEx(
                n,
                (
                    slot(buf, offset + 4),
                    slot(buf, offset + 4 + JOINT_BLOCK_SIZE),
                    slot(buf, offset + 4 + 2 * JOINT_BLOCK_SIZE),
                    slot(buf, offset + 4 + 3 * JOINT_BLOCK_SIZE),
                ),
            )

        return decode


class TrajPtFullExLayout(BodyLayout):
    """2016: int32 number_of_valid_groups, int32 sequence, then one 132-byte block per group."""

    msg_type = int(MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX)
    body_type = JointTrajPtFullEx
    _HEAD_SIZE = 8
    max_size = _HEAD_SIZE + MAX_GROUPS * JOINT_BLOCK_SIZE

    def __init__(self) -> None:
        self._heads = _structs("2i")
        group_counts = range(1, MAX_GROUPS + 1)
        self._blocks = {n: _structs(JOINT_BLOCK * n) for n in group_counts}
        self._frames = {n: _structs("2i" + JOINT_BLOCK * n) for n in group_counts}

    def decoder(self, order: ByteOrder) -> Decode:
        unpack_head = self._heads[order].unpack_from
        unpack_blocks = {n: structs[order].unpack_from for n, structs in self._blocks.items()}
        head_size = self._HEAD_SIZE
        padded_size = self.max_size

        def decode(buf: Buffer, offset: int, body_size: int) -> Body:
            if body_size < head_size:
                raise self._wrong_size(body_size, "8 + 132 x groups")
            n, sequence = unpack_head(buf, offset)
            # MotoROS does not range-check n: n > 4 cannot fit and gets 3001, while n <= 0
            # answers from a stale reply buffer [quirk, motoros1 §1.2, motoros1 §2.5]. We
            # answer 3001 for both.
            if not 1 <= n <= MAX_GROUPS:
                raise self._wrong_size(body_size, f"1 to {MAX_GROUPS} groups, not {n}")
            # motoros1 §1.2 (v1.3.0/v1.5.1): the exact size for n groups, or the full 4-group
            # size with its padding ignored (not taken as the start of the next message).
            if body_size != head_size + n * JOINT_BLOCK_SIZE and body_size != padded_size:
                raise self._wrong_size(body_size, f"{head_size + n * JOINT_BLOCK_SIZE} for {n}")
            v = unpack_blocks[n](buf, offset + head_size)
            return JointTrajPtFullEx(
                sequence, tuple(_ex_group_at(v, k * _BLOCK_VALUES) for k in range(n))
            )

        return decode

    def encoder(self, order: ByteOrder) -> Encode:
        packs = {n: structs[order].pack for n, structs in self._frames.items()}

        def encode(body: Body) -> bytes:
            if not isinstance(body, JointTrajPtFullEx):
                raise self._wrong_body(body)
            n = len(body.groups)
            if not 1 <= n <= MAX_GROUPS:
                raise LocalProtocolError(f"2016 carries 1 to {MAX_GROUPS} groups, not {n}")
            # Variable length, only the groups sent, as motoman_driver sends it.
            values = _blocks_values(body.groups)
            try:
                return packs[n](n, body.sequence, *values)
            except (struct.error, OverflowError) as err:
                raise self._encode_error(err) from err

        return encode


_PING = FixedLayout(MsgType.PING, Empty, "")
_ROBOT_STATUS = FixedLayout(MsgType.ROBOT_STATUS, RobotStatus, "7i")
_TRAJ_PT_FULL = FixedLayout(
    MsgType.JOINT_TRAJ_PT_FULL,
    JointTrajPtFull,
    "3i31f",
    lambda v: JointTrajPtFull(v[0], v[1], v[2], v[3], v[4:14], v[14:24], v[24:34]),
    _traj_pt_full_values,
)
_JOINT_FEEDBACK = FixedLayout(
    MsgType.JOINT_FEEDBACK, JointFeedback, JOINT_BLOCK, _feedback, _block_values
)
_MOTION_CTRL = FixedLayout(
    MsgType.MOTO_MOTION_CTRL,
    MotoMotionCtrl,
    "3i10f",
    lambda v: MotoMotionCtrl(v[0], v[1], v[2], v[3:13]),
    _motion_ctrl_values,
)
_MOTION_REPLY = FixedLayout(
    MsgType.MOTO_MOTION_REPLY,
    MotoMotionReply,
    "5i10f",
    lambda v: MotoMotionReply(v[0], v[1], v[2], v[3], v[4], v[5:15]),
    _motion_reply_values,
)
_READ_IO_BIT = FixedLayout(MsgType.MOTO_READ_IO_BIT, ReadIOBit, "I")
_READ_IO_BIT_REPLY = FixedLayout(MsgType.MOTO_READ_IO_BIT_REPLY, ReadIOBitReply, "Ii")
_WRITE_IO_BIT = FixedLayout(MsgType.MOTO_WRITE_IO_BIT, WriteIOBit, "2I")
_WRITE_IO_BIT_REPLY = FixedLayout(MsgType.MOTO_WRITE_IO_BIT_REPLY, WriteIOBitReply, "i")
_READ_IO_GROUP = FixedLayout(MsgType.MOTO_READ_IO_GROUP, ReadIOGroup, "I")
_READ_IO_GROUP_REPLY = FixedLayout(MsgType.MOTO_READ_IO_GROUP_REPLY, ReadIOGroupReply, "Ii")
_WRITE_IO_GROUP = FixedLayout(MsgType.MOTO_WRITE_IO_GROUP, WriteIOGroup, "2I")
_WRITE_IO_GROUP_REPLY = FixedLayout(MsgType.MOTO_WRITE_IO_GROUP_REPLY, WriteIOGroupReply, "i")
_READ_MREGISTER = FixedLayout(MsgType.MOTO_READ_MREGISTER, ReadMRegister, "I")
_READ_MREGISTER_REPLY = FixedLayout(MsgType.MOTO_READ_MREGISTER, ReadMRegisterReply, "Ii")
_WRITE_MREGISTER = FixedLayout(MsgType.MOTO_WRITE_MREGISTER, WriteMRegister, "2I")
_WRITE_MREGISTER_REPLY = FixedLayout(MsgType.MOTO_WRITE_MREGISTER, WriteMRegisterReply, "i")
_TRAJ_PT_FULL_EX = TrajPtFullExLayout()
_JOINT_FEEDBACK_EX = FeedbackExLayout()
_SELECT_TOOL = FixedLayout(MsgType.MOTO_SELECT_TOOL, SelectTool, "3i")
_GET_DH_PARAMETERS = FixedLayout(MsgType.MOTO_GET_DH_PARAMETERS, Empty, "")
_GET_DH_PARAMETERS_REPLY = FixedLayout(
    MsgType.MOTO_GET_DH_PARAMETERS,
    GetDhParametersReply,
    f"{MAX_GROUPS * _DH_GROUP_VALUES}f",
    _dh_body,
    _dh_values,
)

_RECEIVED: Final[Mapping[Direction, tuple[BodyLayout, ...]]] = {
    Direction.TO_CONTROLLER: (
        _PING,
        _TRAJ_PT_FULL,
        _MOTION_CTRL,
        _READ_IO_BIT,
        _WRITE_IO_BIT,
        _READ_IO_GROUP,
        _WRITE_IO_GROUP,
        _READ_MREGISTER,
        _WRITE_MREGISTER,
        _TRAJ_PT_FULL_EX,
        _SELECT_TOOL,
        _GET_DH_PARAMETERS,
        # Known sizes without a handler: MotoROS closes the connection on these (motoros1 §2.7).
        _ROBOT_STATUS,
        _JOINT_FEEDBACK,
        _MOTION_REPLY,
        _JOINT_FEEDBACK_EX,
    ),
    Direction.TO_CLIENT: (
        _PING,
        _ROBOT_STATUS,
        _JOINT_FEEDBACK,
        _MOTION_REPLY,
        _READ_IO_BIT_REPLY,
        _WRITE_IO_BIT_REPLY,
        _READ_IO_GROUP_REPLY,
        _WRITE_IO_GROUP_REPLY,
        _READ_MREGISTER_REPLY,
        _WRITE_MREGISTER_REPLY,
        _JOINT_FEEDBACK_EX,
        _GET_DH_PARAMETERS_REPLY,
    ),
}

LAYOUTS: Final[Mapping[tuple[Direction, int], BodyLayout]] = {
    (direction, layout.msg_type): layout
    for direction, layouts in _RECEIVED.items()
    for layout in layouts
}
"""Body layout by (direction of travel, msg_type); a missing key is an unknown type there."""


def max_body_size(direction: Direction) -> int:
    return max(layout.max_size for layout in _RECEIVED[direction])


@functools.cache
def decoders(direction: Direction, order: ByteOrder) -> Mapping[int, Decode]:
    return {layout.msg_type: layout.decoder(order) for layout in _RECEIVED[direction]}


@functools.cache
def encoders(direction: Direction, order: ByteOrder) -> Mapping[int, Encode]:
    return {layout.msg_type: layout.encoder(order) for layout in _RECEIVED[direction]}
