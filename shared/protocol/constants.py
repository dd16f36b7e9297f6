"""Numeric codes of the Simple Message protocol as MotoROS 1.9 uses them.

Values come from incremental-motion §4.3-4.5 and motoros1 §1.3. Where the two disagree the
MotoROS 1.9 value wins, because the real clients were built against it.
"""

from __future__ import annotations

from enum import IntEnum, IntFlag

PREFIX_SIZE = 4
HEADER_SIZE = 12
MAX_JOINTS = 10
"""Joint slots in every trajectory/feedback body (ROS_MAX_JOINT)."""
MAX_AXES = 8
"""Axes a Motoman control group can have (MP_GRP_AXES_NUM); slots beyond are zero."""
MAX_GROUPS = 4
"""Groups in the _EX messages (MOT_MAX_GR)."""
DH_LINKS = 8
TOOL_NUMBERS = range(64)
"""Tool files a controller has (0-63); MOTO_SELECT_TOOL refuses others with INVALID 3017."""


class MsgType(IntEnum):
    PING = 1
    GET_VERSION = 2
    JOINT_TRAJ_PT = 11
    ROBOT_STATUS = 13
    JOINT_TRAJ_PT_FULL = 14
    JOINT_FEEDBACK = 15
    MOTO_MOTION_CTRL = 2001
    MOTO_MOTION_REPLY = 2002
    MOTO_READ_IO_BIT = 2003
    MOTO_READ_IO_BIT_REPLY = 2004
    MOTO_WRITE_IO_BIT = 2005
    MOTO_WRITE_IO_BIT_REPLY = 2006
    MOTO_READ_IO_GROUP = 2007
    MOTO_READ_IO_GROUP_REPLY = 2008
    MOTO_WRITE_IO_GROUP = 2009
    MOTO_WRITE_IO_GROUP_REPLY = 2010
    MOTO_IOCTRL_REPLY = 2011
    MOTO_READ_MREGISTER = 2012
    MOTO_WRITE_MREGISTER = 2013
    MOTO_JOINT_TRAJ_PT_FULL_EX = 2016
    MOTO_JOINT_FEEDBACK_EX = 2017
    MOTO_SELECT_TOOL = 2018
    MOTO_GET_DH_PARAMETERS = 2020


class CommType(IntEnum):
    INVALID = 0
    TOPIC = 1
    SERVICE_REQUEST = 2
    SERVICE_REPLY = 3


class ReplyType(IntEnum):
    INVALID = 0
    SUCCESS = 1
    FAILURE = 2


class Command(IntEnum):
    """MOTO_MOTION_CTRL.command values."""

    CHECK_MOTION_READY = 200101
    CHECK_QUEUE_CNT = 200102
    STOP_MOTION = 200111
    START_SERVOS = 200112
    STOP_SERVOS = 200113
    RESET_ALARM = 200114
    START_TRAJ_MODE = 200121
    STOP_TRAJ_MODE = 200122
    DISCONNECT = 200130


class Result(IntEnum):
    """MOTO_MOTION_REPLY.result values (TRUE/FALSE alias SUCCESS/FAILURE)."""

    SUCCESS = 0
    BUSY = 1
    FAILURE = 2
    INVALID = 3
    ALARM = 4
    NOT_READY = 5
    MP_FAILURE = 6

    TRUE = 0
    FALSE = 2


class InvalidSubcode(IntEnum):
    UNSPECIFIED = 3000
    MSGSIZE = 3001
    MSGHEADER = 3002
    MSGTYPE = 3003
    GROUPNO = 3004
    SEQUENCE = 3005
    COMMAND = 3006
    DATA = 3010
    DATA_START_POS = 3011
    DATA_POSITION = 3012
    DATA_SPEED = 3013
    DATA_ACCEL = 3014
    DATA_INSUFFICIENT = 3015
    DATA_TIME = 3016
    DATA_TOOLNO = 3017


class NotReadySubcode(IntEnum):
    UNSPECIFIED = 5000
    ALARM = 5001
    ERROR = 5002
    ESTOP = 5003
    NOT_PLAY = 5004
    NOT_REMOTE = 5005
    SERVO_OFF = 5006
    HOLD = 5007
    NOT_STARTED = 5008
    WAITING_ROS = 5009
    SKILLSEND = 5010
    PFL_ACTIVE = 5011
    INC_MOVE_ERROR = 5012


SUBCODE_MEANINGS: dict[int, str] = {
    InvalidSubcode.UNSPECIFIED: "unspecified",
    InvalidSubcode.MSGSIZE: "wrong message size",
    InvalidSubcode.MSGHEADER: "bad header",
    InvalidSubcode.MSGTYPE: "unknown message type",
    InvalidSubcode.GROUPNO: "no such group",
    InvalidSubcode.SEQUENCE: "bad sequence",
    InvalidSubcode.COMMAND: "unknown command",
    InvalidSubcode.DATA: "bad data",
    InvalidSubcode.DATA_START_POS: "start is not the current position",
    InvalidSubcode.DATA_POSITION: "bad position",
    InvalidSubcode.DATA_SPEED: "too fast",
    InvalidSubcode.DATA_ACCEL: "bad acceleration",
    InvalidSubcode.DATA_INSUFFICIENT: "time, position and velocity needed",
    InvalidSubcode.DATA_TIME: "bad time",
    InvalidSubcode.DATA_TOOLNO: "no such tool",
    NotReadySubcode.UNSPECIFIED: "not ready",
    NotReadySubcode.ALARM: "alarm",
    NotReadySubcode.ERROR: "error",
    NotReadySubcode.ESTOP: "E-stop",
    NotReadySubcode.NOT_PLAY: "TEACH mode",
    NotReadySubcode.NOT_REMOTE: "not REMOTE",
    NotReadySubcode.SERVO_OFF: "servo off",
    NotReadySubcode.HOLD: "HOLD",
    NotReadySubcode.NOT_STARTED: "INIT_ROS job not running",
    NotReadySubcode.WAITING_ROS: "job not at its WAIT",
    NotReadySubcode.SKILLSEND: "SKILLSEND",
    NotReadySubcode.PFL_ACTIVE: "PFL stop",
    NotReadySubcode.INC_MOVE_ERROR: "IncMove error",
}
"""What each INVALID and NOT_READY subcode means, in a few words for a person."""


def describe_reply(result: int, subcode: int = 0) -> str:
    """A motion reply's result and subcode as a person reads them: ``SUCCESS``, ``BUSY``,
    ``NOT_READY 5003 (E-stop)``; numbers without a name stay numbers (``result 9``, and a
    subcode that is a count or -1, as CHECK_QUEUE_CNT and failures give)."""
    try:
        name = Result(result).name
    except ValueError:
        name = f"result {result}"
    if subcode == 0:
        return name
    meaning = SUBCODE_MEANINGS.get(subcode)
    return f"{name} {subcode}" if meaning is None else f"{name} {subcode} ({meaning})"


class IoResult(IntEnum):
    """resultCode of the I/O replies. MotoROS 1.9.2+ sends 0 on success (the 2012 spec's
    1 = success / 2 = failure is superseded; the real io_relay client checks for 0)."""

    OK = 0
    READ_ADDRESS_INVALID = 1001
    WRITE_ADDRESS_INVALID = 1002
    WRITE_VALUE_INVALID = 1003
    READ_API_ERROR = 1004
    WRITE_API_ERROR = 1005


class ValidFields(IntFlag):
    TIME = 1
    POSITION = 2
    VELOCITY = 4
    ACCELERATION = 8


REQUIRED_POINT_FIELDS = ValidFields.TIME | ValidFields.POSITION | ValidFields.VELOCITY
"""A trajectory point must carry at least these (MotoROS replies 3/3015 otherwise)."""
