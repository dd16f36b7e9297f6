"""What the protocol tells a person: replies by name, and a peer of the other byte order."""

from __future__ import annotations

import pytest

from motocell.shared.protocol.codec import ByteOrder, Role, encode, readable_byte_order
from motocell.shared.protocol.constants import (
    SUBCODE_MEANINGS,
    InvalidSubcode,
    NotReadySubcode,
    Result,
    describe_reply,
)
from motocell.shared.protocol.layouts import Direction
from motocell.shared.protocol.messages import RobotStatus
from motocell.shared.protocol.replies import motion_ctrl, state_message


@pytest.mark.parametrize(
    ("result", "subcode", "shown"),
    [
        (Result.SUCCESS, 0, "SUCCESS"),
        (Result.BUSY, 0, "BUSY"),
        (Result.NOT_READY, NotReadySubcode.ESTOP, "NOT_READY 5003 (E-stop)"),
        (Result.INVALID, InvalidSubcode.DATA_SPEED, "INVALID 3013 (too fast)"),
        (Result.SUCCESS, 12, "SUCCESS 12"),
        (Result.FAILURE, -1, "FAILURE -1"),
        (9, 0, "result 9"),
        (9, 5003, "result 9 5003 (E-stop)"),
    ],
)
def test_replies_are_shown_by_name(result: int, subcode: int, shown: str) -> None:
    assert describe_reply(result, subcode) == shown


def test_every_invalid_and_not_ready_subcode_has_a_meaning() -> None:
    assert set(SUBCODE_MEANINGS) == set(InvalidSubcode) | set(NotReadySubcode)


@pytest.mark.parametrize("order", list(ByteOrder))
def test_a_frame_is_readable_in_its_own_byte_order_only(order: ByteOrder) -> None:
    status = encode(state_message(13, RobotStatus(1, 0, 0, 0, 0, 2, 1)), order, Role.CONTROLLER)
    assert readable_byte_order(status[:4], Direction.TO_CLIENT) is order
    request = encode(motion_ctrl(200101), order, Role.CLIENT)
    assert readable_byte_order(request[:4], Direction.TO_CONTROLLER) is order


@pytest.mark.parametrize("prefix", [b"\x00\x00\x00\x00", b"\xff\xff\xff\xff", b"\x00\x10\x10\x00"])
def test_a_length_absurd_in_both_orders_is_readable_in_neither(prefix: bytes) -> None:
    assert readable_byte_order(prefix, Direction.TO_CLIENT) is None
