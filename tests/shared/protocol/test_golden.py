"""Golden frames written by hand from motoros1 §1.2, checked both ways.

Each vector is the big-endian (FS100) frame, one 32-bit word per string. Every field is a 32-bit
word, so the little-endian frame is the same words each byte-reversed; a few little-endian
frames are also written out in full to check that rule. Values are distinctive (group 1,
sequence 7, exactly representable floats in different slots) so a wrong offset shows.
"""

from __future__ import annotations

from typing import NamedTuple

import pytest

from motocell.shared.protocol.codec import ByteOrder, Role, decode_frames, encode
from motocell.shared.protocol.constants import InvalidSubcode, MsgType, Result
from motocell.shared.protocol.layouts import LAYOUTS, Direction
from motocell.shared.protocol.messages import (
    Body,
    DhLink,
    Empty,
    GetDhParametersReply,
    JointFeedback,
    JointFeedbackEx,
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
    RobotStatus,
    SelectTool,
    UnknownMessage,
    WriteIOBit,
    WriteIOBitReply,
    WriteIOGroup,
    WriteIOGroupReply,
    WriteMRegister,
    WriteMRegisterReply,
)
from motocell.shared.protocol.replies import invalid_reply, io_error_reply, motion_reply, traj_point

Z = "00000000"
"""One zero word."""


def zeros(n: int) -> str:
    return Z * n


def array(words: str) -> str:
    """A float32[10] field: the given words, then zero words up to 10."""
    given = words.replace(" ", "")
    return given + Z * (10 - len(given) // 8)


def frame(*words: str) -> bytes:
    return bytes.fromhex("".join(words).replace(" ", ""))


def swap_words(data: bytes) -> bytes:
    return b"".join(data[i : i + 4][::-1] for i in range(0, len(data), 4))


def joints(*values: float) -> tuple[float, ...]:
    return (*values, *(0.0,) * (10 - len(values)))


REQ, REP, TOPIC = (2, 0), (3, 1), (1, 0)


def msg(msg_type: int, header: tuple[int, int], body: Body) -> Message:
    return Message(msg_type, header[0], header[1], body)


class Golden(NamedTuple):
    name: str
    sender: Role
    big_endian: bytes
    message: Message
    encodes: bool = True
    """False for a frame our encoder never produces (2016 padded to the full size)."""


TRAJ_PT_FULL = Golden(
    "14 JOINT_TRAJ_PT_FULL",
    Role.CLIENT,
    frame(
        "00000094 0000000e 00000002 00000000",  # length 148, type 14, request, reply 0
        "00000001 00000007 0000000f 3f000000",  # group 1, sequence 7, valid 15, time 0.5
        array("3f800000 bfa00000 3f000000"),  # pos@16 = 1.0, -1.25, 0.5
        "3e800000" + zeros(8) + "c0200000",  # vel@56 = 0.25 ... -2.5 in slot 9
        zeros(5) + "40400000" + zeros(4),  # acc@96 = 3.0 in slot 5
    ),
    msg(
        14,
        REQ,
        JointTrajPtFull(
            1,
            7,
            15,
            0.5,
            joints(1.0, -1.25, 0.5),
            (0.25, *(0.0,) * 8, -2.5),
            joints(0.0, 0.0, 0.0, 0.0, 0.0, 3.0),
        ),
    ),
)

ZERO_LINK = DhLink(0.0, 0.0, 0.0, 0.0)
ZERO_SLOT = JointFeedback(0, 0, 0.0, joints(), joints(), joints())
FEEDBACK_EX_SLOTS = (
    JointFeedback(0, 6, 0.0, joints(0.5, -0.5), joints(0.25), joints()),
    JointFeedback(1, 6, 0.0, joints(-1.25), joints(0.0, 4.0), joints()),
    ZERO_SLOT,
    ZERO_SLOT,
)
FEEDBACK_EX_BLOCKS = (
    "00000000 00000006 00000000",  # group 0, valid 6, time 0
    array("3f000000 bf000000"),  # pos = 0.5, -0.5
    array("3e800000"),  # vel = 0.25
    zeros(10),
    "00000001 00000006 00000000",  # group 1, valid 6, time 0
    array("bfa00000"),  # pos = -1.25
    array("00000000 40800000"),  # vel = 0.0, 4.0
    zeros(10),
    zeros(2 * 33),  # slots 2 and 3 unused
)

EX_GROUP_A = JointTrajPtExGroup(1, 7, 0.5, joints(1.0, -1.25), joints(0.25), joints())
EX_GROUP_B = JointTrajPtExGroup(0, 15, 1.0, joints(2.0), joints(0.0, -0.5), joints(3.0))
EX_GROUP_C = JointTrajPtExGroup(2, 7, 1.5, joints(-4.0), joints(0.75), joints())
# group, valid_fields, time | pos[10] | vel[10] | acc[10]
EX_BLOCK_A = (
    "00000001 00000007 3f000000" + array("3f800000 bfa00000") + array("3e800000") + zeros(10)
)
EX_BLOCK_B = (
    "00000000 0000000f 3f800000" + array("40000000") + array(Z + "bf000000") + array("40400000")
)
EX_BLOCK_C = "00000002 00000007 3fc00000" + array("c0800000") + array("3f400000") + zeros(10)

GOLDEN = [
    Golden(
        "1 PING request",
        Role.CLIENT,
        frame("0000000c 00000001 00000002 00000000"),
        msg(1, REQ, Empty()),
    ),
    Golden(
        "1 PING reply",
        Role.CONTROLLER,
        frame("0000000c 00000001 00000003 00000001"),
        msg(1, REP, Empty()),
    ),
    Golden(
        "13 ROBOT_STATUS",
        Role.CONTROLLER,
        frame(
            "00000028 0000000d 00000001 00000000",
            # drives 1, e_stopped 0, error_code 4107, in_error 1, in_motion -1, mode 2, possible 1
            "00000001 00000000 0000100b 00000001 ffffffff 00000002 00000001",
        ),
        msg(13, TOPIC, RobotStatus(1, 0, 4107, 1, -1, 2, 1)),
    ),
    TRAJ_PT_FULL,
    Golden(
        "15 JOINT_FEEDBACK",
        Role.CONTROLLER,
        frame(
            "00000090 0000000f 00000001 00000000",
            "00000001 00000006 3e000000",  # group 1, valid 6, time 0.125
            array("3fc00000 bf000000"),  # pos@12 = 1.5, -0.5
            zeros(9) + "3f400000",  # vel@52 = 0.75 in slot 9
            array("40800000"),  # acc@92 = 4.0
        ),
        msg(
            15,
            TOPIC,
            JointFeedback(1, 6, 0.125, joints(1.5, -0.5), (*(0.0,) * 9, 0.75), joints(4.0)),
        ),
    ),
    Golden(
        "2001 MOTO_MOTION_CTRL",
        Role.CLIENT,
        frame(
            "00000040 000007d1 00000002 00000000",
            "00000001 00000007 00030db9",  # group 1, sequence 7, START_TRAJ_MODE
            zeros(9) + "bfa00000",  # data[9] = -1.25 (reserved, still decoded)
        ),
        msg(2001, REQ, MotoMotionCtrl(1, 7, 200121, (*(0.0,) * 9, -1.25))),
    ),
    Golden(
        "2002 MOTO_MOTION_REPLY",
        Role.CONTROLLER,
        frame(
            "00000048 000007d2 00000003 00000001",
            "00000001 00000007 0000000e 00000005 0000138e",  # to 14: NOT_READY / SERVO_OFF
            zeros(10),
        ),
        msg(2002, REP, MotoMotionReply(1, 7, 14, 5, 5006, joints())),
    ),
    Golden(
        "2003 READ_IO_BIT",
        Role.CLIENT,
        frame("00000010 000007d3 00000002 00000000 0000271a"),
        msg(2003, REQ, ReadIOBit(10010)),
    ),
    Golden(
        "2004 READ_IO_BIT_REPLY",
        Role.CONTROLLER,
        frame("00000014 000007d4 00000003 00000001 00000001 00000000"),
        msg(2004, REP, ReadIOBitReply(1, 0)),
    ),
    Golden(
        "2005 WRITE_IO_BIT (uint32 address)",
        Role.CLIENT,
        frame("00000014 000007d5 00000002 00000000 80000001 00000001"),
        msg(2005, REQ, WriteIOBit(0x80000001, 1)),
    ),
    Golden(
        "2006 WRITE_IO_BIT_REPLY",
        Role.CONTROLLER,
        frame("00000010 000007d6 00000003 00000002 000003ea"),
        msg(2006, (3, 2), WriteIOBitReply(1002)),
    ),
    Golden(
        "2007 READ_IO_GROUP",
        Role.CLIENT,
        frame("00000010 000007d7 00000002 00000000 000003e9"),
        msg(2007, REQ, ReadIOGroup(1001)),
    ),
    Golden(
        "2008 READ_IO_GROUP_REPLY",
        Role.CONTROLLER,
        frame("00000014 000007d8 00000003 00000001 000000a5 00000000"),
        msg(2008, REP, ReadIOGroupReply(165, 0)),
    ),
    Golden(
        "2009 WRITE_IO_GROUP",
        Role.CLIENT,
        frame("00000014 000007d9 00000002 00000000 000003e9 000000ff"),
        msg(2009, REQ, WriteIOGroup(1001, 255)),
    ),
    Golden(
        "2010 WRITE_IO_GROUP_REPLY",
        Role.CONTROLLER,
        frame("00000010 000007da 00000003 00000001 00000000"),
        msg(2010, REP, WriteIOGroupReply(0)),
    ),
    Golden(
        "2012 READ_MREGISTER request (4 bytes)",
        Role.CLIENT,
        frame("00000010 000007dc 00000002 00000000 000f4241"),
        msg(2012, REQ, ReadMRegister(1000001)),
    ),
    Golden(
        "2012 READ_MREGISTER reply (8 bytes)",
        Role.CONTROLLER,
        frame("00000014 000007dc 00000003 00000001 0000ffff 00000000"),
        msg(2012, REP, ReadMRegisterReply(0xFFFF, 0)),
    ),
    Golden(
        "2013 WRITE_MREGISTER request (8 bytes)",
        Role.CLIENT,
        frame("00000014 000007dd 00000002 00000000 0000022f 00001234"),
        msg(2013, REQ, WriteMRegister(559, 0x1234)),
    ),
    Golden(
        "2013 WRITE_MREGISTER reply (4 bytes)",
        Role.CONTROLLER,
        frame("00000010 000007dd 00000003 00000002 000003eb"),
        msg(2013, (3, 2), WriteMRegisterReply(1003)),
    ),
    Golden(
        "2016 n=1",
        Role.CLIENT,
        frame("00000098 000007e0 00000002 00000000", "00000001 00000007", EX_BLOCK_A),
        msg(2016, REQ, JointTrajPtFullEx(7, (EX_GROUP_A,))),
    ),
    Golden(
        "2016 n=3",
        Role.CLIENT,
        frame(
            "000001a0 000007e0 00000002 00000000",  # length 12 + 8 + 3 x 132 = 416
            "00000003 00000007",
            EX_BLOCK_B + EX_BLOCK_A + EX_BLOCK_C,
        ),
        msg(2016, REQ, JointTrajPtFullEx(7, (EX_GROUP_B, EX_GROUP_A, EX_GROUP_C))),
    ),
    Golden(
        "2016 n=2 padded to 552 bytes",
        Role.CLIENT,
        frame(
            "00000224 000007e0 00000002 00000000",  # length 548: the full 4-group size
            "00000002 00000007",
            EX_BLOCK_C + EX_BLOCK_B,
            "deadbeef" * 66,  # 2 unused blocks: ignored whatever they hold
        ),
        msg(2016, REQ, JointTrajPtFullEx(7, (EX_GROUP_C, EX_GROUP_B))),
        encodes=False,
    ),
    Golden(
        "2017 2 valid groups, 548 bytes",
        Role.CONTROLLER,
        frame("00000220 000007e1 00000001 00000000", "00000002", *FEEDBACK_EX_BLOCKS),
        msg(2017, TOPIC, JointFeedbackEx(2, FEEDBACK_EX_SLOTS)),
    ),
    Golden(
        "2018 SELECT_TOOL (group, tool, sequence)",
        Role.CLIENT,
        frame("00000018 000007e2 00000002 00000000 00000001 0000003f 00000007"),
        msg(2018, REQ, SelectTool(1, 63, 7)),
    ),
    Golden(
        "2020 request",
        Role.CLIENT,
        frame("0000000c 000007e4 00000002 00000000"),
        msg(2020, REQ, Empty()),
    ),
    Golden(
        "2020 reply, 528 bytes",
        Role.CONTROLLER,
        frame(
            "0000020c 000007e4 00000003 00000001",  # length 524
            "3f000000 3f800000 bfa00000 3e800000",  # group 0 link 0: theta, d, a, alpha
            zeros(6 * 4),
            "00000000 00000000 00000000 40000000",  # group 0 link 7: alpha 2.0
            zeros(2 * 4),
            "00000000 bf000000 00000000 00000000",  # group 1 link 2: d -0.5
            zeros(5 * 4),
            zeros(2 * 8 * 4),  # groups 2 and 3
        ),
        msg(
            2020,
            REP,
            GetDhParametersReply(
                (
                    (DhLink(0.5, 1.0, -1.25, 0.25), *(ZERO_LINK,) * 6, DhLink(0.0, 0.0, 0.0, 2.0)),
                    (ZERO_LINK, ZERO_LINK, DhLink(0.0, -0.5, 0.0, 0.0), *(ZERO_LINK,) * 5),
                    (ZERO_LINK,) * 8,
                    (ZERO_LINK,) * 8,
                )
            ),
        ),
    ),
    Golden(
        "I/O port error reply (result and subcode in the first two words)",
        Role.CONTROLLER,
        frame("00000048 000007d2 00000003 00000002", "00000003 00000bbb", zeros(13)),
        msg(2002, (3, 2), MotoMotionReply(3, 3003, 0, 0, 0, joints())),
    ),
    Golden(
        "INVALID/3003 reply to GET_VERSION",
        Role.CONTROLLER,
        frame(
            "00000048 000007d2 00000003 00000001",
            "ffffffff ffffffff 00000002 00000003 00000bbb",  # group -1, seq -1, type 2, 3/3003
            zeros(10),
        ),
        msg(2002, REP, MotoMotionReply(-1, -1, 2, 3, 3003, joints())),
    ),
]

LITTLE_ENDIAN_WRITTEN_OUT = {
    "2001 MOTO_MOTION_CTRL": frame(
        "40000000 d1070000 02000000 00000000", "01000000 07000000 b90d0300", zeros(9), "0000a0bf"
    ),
    "2005 WRITE_IO_BIT (uint32 address)": frame(
        "14000000 d5070000 02000000 00000000 01000080 01000000"
    ),
    "2016 n=1": frame(
        "98000000 e0070000 02000000 00000000",
        "01000000 07000000",
        "01000000 07000000 0000003f",
        array("0000803f 0000a0bf"),
        array("0000803e"),
        zeros(10),
    ),
}

KNOWN_TO_BOTH = {1, 13, 15, 2002, 2017}
"""Types whose golden frames also decode on the other side (motoros1 §2.7: MotoROS knows their
size)."""


def receiver(sender: Role) -> Role:
    return Role.CONTROLLER if sender is Role.CLIENT else Role.CLIENT


def wire(golden: Golden, order: ByteOrder) -> bytes:
    return golden.big_endian if order is ByteOrder.BIG else swap_words(golden.big_endian)


ids = [g.name for g in GOLDEN]
orders = pytest.mark.parametrize("order", list(ByteOrder))


@orders
@pytest.mark.parametrize("golden", GOLDEN, ids=ids)
def test_golden_decodes(golden: Golden, order: ByteOrder) -> None:
    assert decode_frames(wire(golden, order), receiver(golden.sender), order) == [golden.message]


@orders
@pytest.mark.parametrize(
    "golden", [g for g in GOLDEN if g.encodes], ids=[g.name for g in GOLDEN if g.encodes]
)
def test_golden_encodes(golden: Golden, order: ByteOrder) -> None:
    assert encode(golden.message, order, golden.sender) == wire(golden, order)


@orders
@pytest.mark.parametrize(
    "golden",
    [g for g in GOLDEN if g.message.msg_type in KNOWN_TO_BOTH and g.sender is Role.CONTROLLER],
    ids=lambda g: g.name,
)
def test_controller_decodes_what_only_it_sends(golden: Golden, order: ByteOrder) -> None:
    assert decode_frames(wire(golden, order), Role.CONTROLLER, order) == [golden.message]


def test_golden_sizes_match_the_catalogue() -> None:
    """Total bytes on the wire per motoros1 §1.2, so the hand-written vectors themselves are
    checked."""
    sizes = {g.name: len(g.big_endian) for g in GOLDEN}
    assert sizes["14 JOINT_TRAJ_PT_FULL"] == 152
    assert sizes["15 JOINT_FEEDBACK"] == 148
    assert sizes["13 ROBOT_STATUS"] == 44
    assert sizes["2001 MOTO_MOTION_CTRL"] == 68
    assert sizes["2002 MOTO_MOTION_REPLY"] == 76
    assert sizes["2016 n=1"] == 24 + 132
    assert sizes["2016 n=3"] == 24 + 3 * 132
    assert sizes["2016 n=2 padded to 552 bytes"] == 552
    assert sizes["2017 2 valid groups, 548 bytes"] == 548
    assert sizes["2018 SELECT_TOOL (group, tool, sequence)"] == 28
    assert sizes["2020 reply, 528 bytes"] == 528
    for g in GOLDEN:
        assert int.from_bytes(g.big_endian[:4], "big") == len(g.big_endian) - 4, g.name


@pytest.mark.parametrize("name", sorted(LITTLE_ENDIAN_WRITTEN_OUT))
def test_little_endian_is_the_words_byte_reversed(name: str) -> None:
    golden = next(g for g in GOLDEN if g.name == name)
    assert swap_words(golden.big_endian) == LITTLE_ENDIAN_WRITTEN_OUT[name]


def test_every_layout_has_a_golden_vector() -> None:
    towards = {Role.CLIENT: Direction.TO_CONTROLLER, Role.CONTROLLER: Direction.TO_CLIENT}
    covered = {(towards[g.sender], g.message.msg_type) for g in GOLDEN}
    covered |= {(Direction.TO_CONTROLLER, msg_type) for msg_type in KNOWN_TO_BOTH}
    assert covered == set(LAYOUTS)


def test_reply_builders_match_golden_replies() -> None:
    by_name = {g.name: g.message for g in GOLDEN}
    assert (
        motion_reply(TRAJ_PT_FULL.message, Result.NOT_READY, 5006)
        == by_name["2002 MOTO_MOTION_REPLY"]
    )
    assert (
        io_error_reply(InvalidSubcode.MSGTYPE)
        == by_name["I/O port error reply (result and subcode in the first two words)"]
    )
    get_version = UnknownMessage(int(MsgType.GET_VERSION), 2, 0, b"")
    assert invalid_reply(get_version) == by_name["INVALID/3003 reply to GET_VERSION"]
    point = traj_point(
        1,
        7,
        0.5,
        (1.0, -1.25, 0.5),
        (0.25, *(0.0,) * 8, -2.5),
        accelerations=joints(0.0, 0.0, 0.0, 0.0, 0.0, 3.0),
    )
    assert point == TRAJ_PT_FULL.message
