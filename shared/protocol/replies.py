"""Builders for every message the controller answers or sends, and the client's requests.

Headers follow MotoROS: replies are comm type 3 (SERVICE_REPLY), state messages comm type 1
(TOPIC) with reply type 0, and requests comm type 2 with reply type 0, as motoman_driver sends
them (docs/spec/driver-client.md). Header fields are stored as plain ints, and joint arrays are
widened to 10 slots, so a built message equals what the peer decodes.
"""

from __future__ import annotations

from collections.abc import Sequence

from motocell.shared.protocol.constants import (
    CommType,
    InvalidSubcode,
    MsgType,
    ReplyType,
    Result,
    ValidFields,
)
from motocell.shared.protocol.errors import LocalProtocolError, PeerProtocolError
from motocell.shared.protocol.layouts import ZERO_JOINTS, pad_joints
from motocell.shared.protocol.messages import (
    Body,
    Empty,
    Floats,
    JointTrajPtExGroup,
    JointTrajPtFull,
    JointTrajPtFullEx,
    Message,
    MotoMotionCtrl,
    MotoMotionReply,
    ReadIOBit,
    ReadIOBitReply,
    ReadIOGroup,
    ReadIOGroupReply,
    ReadMRegister,
    ReadMRegisterReply,
    SelectTool,
    UnknownMessage,
    WriteIOBit,
    WriteIOBitReply,
    WriteIOGroup,
    WriteIOGroupReply,
    WriteMRegister,
    WriteMRegisterReply,
)


def service_reply(msg_type: int, body: Body, success: bool = True) -> Message:
    """A reply as MotoROS sends it: comm type 3, reply type 1 (success) or 2 (failure)."""
    reply_type = ReplyType.SUCCESS if success else ReplyType.FAILURE
    return Message(int(msg_type), int(CommType.SERVICE_REPLY), int(reply_type), body)


def _motion_reply(group_no: int, sequence: int, command: int, result: int, subcode: int) -> Message:
    # motoros1 §1.4: reply type is 1 (SUCCESS) whatever the result; the result is in the body.
    body = MotoMotionReply(
        int(group_no), int(sequence), int(command), int(result), int(subcode), ZERO_JOINTS
    )
    return service_reply(MsgType.MOTO_MOTION_REPLY, body)


def motion_reply(
    request: Message | UnknownMessage, result: int, subcode: int, group_no: int | None = None
) -> Message:
    """The MOTO_MOTION_REPLY to ``request`` (motoros1 §1.4).

    ``group_no`` is the group the reply refers to; by default the request's group, for 2016 the
    last listed group (MotoROS overwrites one reply buffer per group, motoros1 §2.5), and -1
    for types without a group.
    """
    body = None if isinstance(request, UnknownMessage) else request.body
    match body:
        case MotoMotionCtrl():
            group, sequence, command = body.group_no, body.sequence, body.command
        case JointTrajPtFull():
            group, sequence, command = body.group_no, body.sequence, MsgType.JOINT_TRAJ_PT_FULL
        case JointTrajPtFullEx():
            group = body.groups[-1].group_no if body.groups else -1
            sequence, command = body.sequence, MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX
        case SelectTool():
            # The request's sequence is echoed since v1.9.11 (#519); earlier versions garbled it.
            group, sequence, command = body.group_no, body.sequence, MsgType.MOTO_SELECT_TOOL
        case _:
            group, sequence, command = -1, -1, request.msg_type
    return _motion_reply(
        group if group_no is None else group_no, sequence, command, result, subcode
    )


def invalid_reply(error: PeerProtocolError | UnknownMessage) -> Message:
    """INVALID with 3001/3002 (bad frame) or 3003 (unknown type) as the motion port sends it."""
    if isinstance(error, UnknownMessage):
        return _motion_reply(-1, -1, error.msg_type, Result.INVALID, InvalidSubcode.MSGTYPE)
    return _motion_reply(-1, -1, error.msg_type, error.result, error.subcode)


def io_error_reply(subcode: InvalidSubcode) -> Message:
    """The I/O port's answer to an unknown type or a short message (motoros1 §8).

    MotoROS fills a {result, subcode} body (MOTO_IOCTRL_REPLY's) but sends it as msgType 2002
    with the motion reply's length, so a client reading a MOTO_MOTION_REPLY finds result (3) in
    groupNo and the subcode in sequence. Clients were built against that, so we copy it.
    """
    body = MotoMotionReply(
        group_no=int(Result.INVALID),
        sequence=int(subcode),
        command=0,
        result=0,
        subcode=0,
        data=ZERO_JOINTS,
    )
    return service_reply(MsgType.MOTO_MOTION_REPLY, body, success=False)


def io_reply(request: Message, result_code: int, value: int = 0) -> Message:
    """The reply to an I/O or M-register request; ``value`` is what was read (unused for writes).

    Reply type is 1 when ``result_code`` is 0 (IoResult.OK, MotoROS 1.9.2+), else 2 (motoros1 §8).
    """
    result_code, value = int(result_code), int(value)
    body: Body
    match request.body:
        case ReadIOBit():
            msg_type, body = MsgType.MOTO_READ_IO_BIT_REPLY, ReadIOBitReply(value, result_code)
        case WriteIOBit():
            msg_type, body = MsgType.MOTO_WRITE_IO_BIT_REPLY, WriteIOBitReply(result_code)
        case ReadIOGroup():
            msg_type, body = MsgType.MOTO_READ_IO_GROUP_REPLY, ReadIOGroupReply(value, result_code)
        case WriteIOGroup():
            msg_type, body = MsgType.MOTO_WRITE_IO_GROUP_REPLY, WriteIOGroupReply(result_code)
        case ReadMRegister():
            # 1.9.2+ answers the M-register requests under their own type numbers.
            msg_type, body = MsgType.MOTO_READ_MREGISTER, ReadMRegisterReply(value, result_code)
        case WriteMRegister():
            msg_type, body = MsgType.MOTO_WRITE_MREGISTER, WriteMRegisterReply(result_code)
        case _:
            raise LocalProtocolError(f"type {request.msg_type} is not an I/O request")
    return service_reply(msg_type, body, success=result_code == 0)


def state_message(msg_type: int, body: Body) -> Message:
    """A state-port message (13, 15, 2017) as MotoROS sends it: comm type 1, reply type 0."""
    return Message(int(msg_type), int(CommType.TOPIC), int(ReplyType.INVALID), body)


def _request(msg_type: MsgType, body: Body) -> Message:
    return Message(int(msg_type), int(CommType.SERVICE_REQUEST), int(ReplyType.INVALID), body)


def ping() -> Message:
    return _request(MsgType.PING, Empty())


def motion_ctrl(command: int, group_no: int = 0, sequence: int = 0) -> Message:
    return _request(
        MsgType.MOTO_MOTION_CTRL, MotoMotionCtrl(group_no, sequence, int(command), ZERO_JOINTS)
    )


def _point_fields(accelerations: Floats) -> int:
    # motoman_driver sends 0x07, or 0x0F when the ROS point has accelerations.
    fields = ValidFields.TIME | ValidFields.POSITION | ValidFields.VELOCITY
    return int(fields | ValidFields.ACCELERATION if accelerations else fields)


def traj_point(
    group_no: int,
    sequence: int,
    time: float,
    positions: Floats,
    velocities: Floats,
    *,
    accelerations: Floats = (),
) -> Message:
    body = JointTrajPtFull(
        group_no,
        sequence,
        _point_fields(accelerations),
        time,
        pad_joints(positions),
        pad_joints(velocities),
        pad_joints(accelerations),
    )
    return _request(MsgType.JOINT_TRAJ_PT_FULL, body)


def ex_group(
    group_no: int,
    time: float,
    positions: Floats,
    velocities: Floats,
    *,
    accelerations: Floats = (),
) -> JointTrajPtExGroup:
    return JointTrajPtExGroup(
        group_no,
        _point_fields(accelerations),
        time,
        pad_joints(positions),
        pad_joints(velocities),
        pad_joints(accelerations),
    )


def traj_point_ex(sequence: int, groups: Sequence[JointTrajPtExGroup]) -> Message:
    return _request(MsgType.MOTO_JOINT_TRAJ_PT_FULL_EX, JointTrajPtFullEx(sequence, tuple(groups)))


def select_tool(group_no: int, tool: int, sequence: int = 0) -> Message:
    return _request(MsgType.MOTO_SELECT_TOOL, SelectTool(group_no, tool, sequence))


def get_dh_parameters() -> Message:
    return _request(MsgType.MOTO_GET_DH_PARAMETERS, Empty())


def read_io_bit(address: int) -> Message:
    return _request(MsgType.MOTO_READ_IO_BIT, ReadIOBit(address))


def write_io_bit(address: int, value: int) -> Message:
    return _request(MsgType.MOTO_WRITE_IO_BIT, WriteIOBit(address, value))


def read_io_group(address: int) -> Message:
    return _request(MsgType.MOTO_READ_IO_GROUP, ReadIOGroup(address))


def write_io_group(address: int, value: int) -> Message:
    return _request(MsgType.MOTO_WRITE_IO_GROUP, WriteIOGroup(address, value))


def read_mregister(register: int) -> Message:
    return _request(MsgType.MOTO_READ_MREGISTER, ReadMRegister(register))


def write_mregister(register: int, value: int) -> Message:
    return _request(MsgType.MOTO_WRITE_MREGISTER, WriteMRegister(register, value))
