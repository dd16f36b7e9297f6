"""IoTable: MotoROS 1.9 I/O address rules (motoros1 §8), per controller model.

The range table below is transcribed from motoros1 §8 independently of io_table.py."""

from __future__ import annotations

import pytest

from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import OT_ROS_DONE, Controller
from motocell.services.controller.core.states import JobState
from motocell.shared.config import ControllerModel

OK, READ_BAD, WRITE_ADDRESS_BAD, WRITE_VALUE_BAD = 0, 1001, 1002, 1003

M = ControllerModel
ROWS = [
    "general in", "general out", "external in", "external out", "network in", "network out",
    "specific in", "specific out", "IF panel", "aux relay", "control status", "pseudo in",
]  # fmt: skip
# motoros1 §8 "Readable ranges", one column per model, rows in the order of ROWS.
SPEC: dict[ControllerModel, list[tuple[int, int]]] = {
    M.DX100: [
        (10, 2567), (10010, 12567), (20010, 22567), (30010, 32567), (25010, 27567),
        (35010, 37567), (40010, 41607), (50010, 52007), (60010, 60647), (70010, 79997),
        (80010, 80647), (82010, 82207),
    ],
    M.FS100: [
        (10, 1287), (10010, 11287), (20010, 21287), (30010, 31287), (25010, 26287),
        (35010, 36287), (40010, 41607), (50010, 52007), (60010, 60647), (70010, 79997),
        (80010, 80647), (82010, 82207),
    ],
    M.DX200: [
        (10, 5127), (10010, 15127), (20010, 25127), (30010, 35127), (27010, 29567),
        (37010, 39567), (40010, 41607), (50010, 53007), (60010, 60647), (70010, 79997),
        (80010, 82007), (82010, 82207),
    ],
    M.YRC1000: [
        (10, 5127), (10010, 15127), (20010, 25127), (30010, 35127), (27010, 29567),
        (37010, 39567), (40010, 42567), (50010, 55127), (60010, 60647), (70010, 79997),
        (80010, 85127), (87010, 87207),
    ],
    M.YRC1000MICRO: [
        (10, 5127), (10010, 15127), (20010, 21287), (30010, 31287), (27010, 29567),
        (37010, 39567), (40010, 42567), (50010, 55127), (60010, 60647), (70010, 79997),
        (80010, 85127), (87010, 87207),
    ],
}  # fmt: skip
WRITABLE_ROWS = ("general out", "network in", "IF panel")
MODELS = list(ControllerModel)


def in_spec(model: ControllerModel, address: int, rows: tuple[str, ...] | None = None) -> bool:
    return address % 10 not in (8, 9) and any(
        low <= address <= high
        for name, (low, high) in zip(ROWS, SPEC[model], strict=True)
        if rows is None or name in rows
    )


def table(model: ControllerModel = M.YRC1000) -> IoTable:
    return IoTable(model, {})


@pytest.mark.parametrize("model", MODELS)
def test_readable_ranges_match_the_spec_table(model: ControllerModel) -> None:
    io = table(model)
    for name, (low, high) in zip(ROWS, SPEC[model], strict=True):
        assert io.read_bit(low) == (0, OK), (name, low)
        assert io.read_bit(high) == (0, OK), (name, high)
        for outside in (low - 10, high + 3):
            expected = OK if in_spec(model, outside) else READ_BAD
            assert io.read_bit(outside)[1] == expected, (name, outside)


@pytest.mark.parametrize("model", MODELS)
def test_every_address_follows_the_spec_table(model: ControllerModel) -> None:
    io = table(model)
    for address in range(0, 90_000):
        assert io.readable(address) is in_spec(model, address), address
        assert io.writable(address) is in_spec(model, address, WRITABLE_ROWS), address


def test_model_differences() -> None:
    # Network inputs moved on DX200 and later; YRC1000micro has fewer external I/O.
    assert table(M.DX100).read_bit(25010)[1] == OK
    assert table(M.DX200).read_bit(25010)[1] == OK  # external in there, up to 25127
    assert table(M.DX200).read_bit(27010)[1] == OK
    assert table(M.FS100).read_bit(27010)[1] == READ_BAD
    assert table(M.YRC1000).read_bit(22000)[1] == OK
    assert table(M.YRC1000MICRO).read_bit(22000)[1] == READ_BAD
    assert table(M.YRC1000).read_bit(87010)[1] == OK
    assert table(M.DX200).read_bit(87010)[1] == READ_BAD
    assert table(M.DX200).read_bit(82010)[1] == OK
    assert table(M.YRC1000).read_bit(82010)[1] == OK  # control status 80010-85127
    assert table(M.DX100).read_bit(82010)[1] == OK  # pseudo input


def test_last_digit_8_or_9_is_no_signal() -> None:
    io = table()
    io.bits[10017] = 1
    assert io.read_bit(10017) == (1, OK)
    assert io.read_bit(10018) == (0, READ_BAD)
    assert io.read_bit(10019) == (0, READ_BAD)
    assert io.read_bit(10020) == (0, OK)
    assert io.write_bit(10018, 1) == WRITE_ADDRESS_BAD
    assert io.write_bit(10029, 0) == WRITE_ADDRESS_BAD
    assert 10018 not in io.bits


def test_read_bit_returns_the_stored_value() -> None:
    io = IoTable(M.YRC1000, {11120: 1, 50070: 1})
    assert io.read_bit(11120) == (1, OK)
    assert io.read_bit(50070) == (1, OK)
    assert io.read_bit(11121) == (0, OK)


@pytest.mark.parametrize("model", MODELS)
def test_write_bit_only_in_writable_areas(model: ControllerModel) -> None:
    io = table(model)
    general_out, network_in = SPEC[model][1], SPEC[model][4]
    for address in (general_out[0], general_out[1], network_in[0], network_in[1], 60010, 60647):
        assert io.write_bit(address, 1) == OK, address
        assert io.bits[address] == 1
        assert io.read_bit(address) == (1, OK)
        assert io.write_bit(address, 0) == OK
        assert io.bits[address] == 0
    read_only = [low for name, (low, _) in zip(ROWS, SPEC[model], strict=True)]
    read_only = [a for a in read_only if a not in (general_out[0], network_in[0], 60010)]
    assert len(read_only) == 9
    for address in read_only:
        assert io.read_bit(address)[1] == OK
        assert io.write_bit(address, 1) == WRITE_ADDRESS_BAD, address
        assert address not in io.bits


def test_write_bit_value_must_be_0_or_1() -> None:
    io = table()
    for value in (2, -1, 255):
        assert io.write_bit(10010, value) == WRITE_VALUE_BAD
    assert 10010 not in io.bits


def test_write_address_error_wins_over_value_error() -> None:
    io = table()
    assert io.write_bit(50010, 7) == WRITE_ADDRESS_BAD  # read-only and a bad value
    assert io.write_bit(10019, 7) == WRITE_ADDRESS_BAD  # last digit 9 and a bad value
    assert io.write_group(5001, 300) == WRITE_ADDRESS_BAD
    assert io.write_register(560, 0x10000) == WRITE_ADDRESS_BAD


def test_read_group_is_eight_bits_lsb_first() -> None:
    io = table()
    io.bits.update({10010: 1, 10012: 1, 10017: 1, 10018: 1, 10020: 1})
    assert io.read_group(1001) == (0b1000_0101, OK)  # 10018 and 10020 are not in the byte
    assert io.read_group(1002) == (1, OK)
    assert io.read_group(1) == (0, OK)  # general in, bits 10..17


@pytest.mark.parametrize("model", MODELS)
def test_group_validity_is_checked_on_address_times_ten(model: ControllerModel) -> None:
    io = table(model)
    high = SPEC[model][0][1]  # general in ends at ...7: its byte is (high - 7) / 10
    last_byte = (high - 7) // 10
    assert io.read_group(last_byte)[1] == OK
    assert io.read_group(last_byte + 1)[1] == READ_BAD
    assert io.read_group(0) == (0, READ_BAD)  # bit 0 is not an I/O
    assert io.read_group(-1) == (0, READ_BAD)
    assert io.read_group(5001)[1] == OK  # specific out: readable ...
    assert io.write_group(5001, 1) == WRITE_ADDRESS_BAD  # ... but not writable
    assert io.write_group(-1, 1) == WRITE_ADDRESS_BAD


def test_write_group_sets_eight_bits() -> None:
    io = table()
    io.bits[10027] = 1
    assert io.write_group(1002, 0b1010_0101) == OK
    assert [io.bits[10020 + b] for b in range(8)] == [1, 0, 1, 0, 0, 1, 0, 1]
    assert io.read_group(1002) == (0b1010_0101, OK)
    assert io.write_group(1002, 0) == OK
    assert io.read_group(1002) == (0, OK)
    assert io.write_group(1002, 255) == OK
    assert io.read_group(1002) == (255, OK)


def test_write_group_value_at_most_255() -> None:
    io = table()
    assert io.write_group(1002, 256) == WRITE_VALUE_BAD
    assert io.write_group(1002, -1) == WRITE_VALUE_BAD
    assert not io.bits


def test_register_numbering_and_ranges() -> None:
    io = table()
    assert io.write_register(5, 1234) == OK
    assert io.read_register(1_000_005) == (1234, OK)
    assert io.read_register(5) == (1234, OK)
    assert io.write_register(1_000_005, 4321) == OK
    assert io.read_register(5) == (4321, OK)
    assert io.registers == {5: 4321}
    for readable in (0, 999, 1_000_000, 1_000_999):
        assert io.read_register(readable) == (0, OK), readable
    for unreadable in (1000, 1_001_000, -1, 2_000_000):
        assert io.read_register(unreadable) == (0, READ_BAD), unreadable
    for writable in (0, 559, 1_000_000, 1_000_559):
        assert io.write_register(writable, 1) == OK, writable
    for unwritable in (560, 999, 1_000_560, 1_000_999, -1):
        assert io.write_register(unwritable, 1) == WRITE_ADDRESS_BAD, unwritable
    assert io.read_register(999) == (0, OK)  # readable even though not writable


def test_register_value_is_one_16_bit_word() -> None:
    io = table()
    assert io.write_register(10, 0xFFFF) == OK
    assert io.read_register(10) == (0xFFFF, OK)
    assert io.write_register(10, 0x10000) == WRITE_VALUE_BAD
    assert io.write_register(10, -1) == WRITE_VALUE_BAD
    assert io.read_register(10) == (0xFFFF, OK)


def test_register_ranges_are_the_same_on_every_model() -> None:
    for model in MODELS:
        io = table(model)
        assert io.write_register(559, 1) == OK
        assert io.write_register(560, 1) == WRITE_ADDRESS_BAD
        assert io.read_register(999)[1] == OK
        assert io.read_register(1000)[1] == READ_BAD


def test_writes_go_through_set_bit() -> None:
    bits: dict[int, int] = {}
    calls: list[tuple[int, int]] = []
    io = IoTable(M.DX200, bits, set_bit=lambda a, v: calls.append((a, v)))
    assert io.write_bit(10010, 1) == OK
    assert io.write_group(1002, 0b11) == OK
    assert io.write_bit(50010, 1) == WRITE_ADDRESS_BAD
    assert io.write_bit(10010, 5) == WRITE_VALUE_BAD
    assert calls == [(10010, 1), *[(10020 + b, int(b < 2)) for b in range(8)]]
    assert bits == {}  # only set_bit writes


def test_writing_ot890_through_the_table_releases_the_init_ros_job() -> None:
    controller = Controller(1)
    controller.begin_start_traj_mode(0.0)
    controller.advance(0.05)
    controller.advance(0.10)
    assert controller.motion_ready()
    io = IoTable(M.YRC1000, controller.outputs, controller.set_output)
    assert io.read_bit(11120) == (1, OK)  # OT#889
    assert io.write_bit(OT_ROS_DONE, 1) == OK
    controller.advance(0.2)
    assert controller.job is JobState.IDLE
    assert io.read_bit(11120) == (0, OK)
    assert not controller.motion_ready()
