"""The controller's I/O and M-registers with MotoROS 1.9's address rules (motoros1 §8):
readable and writable ranges per controller model, result codes 0 and 1001-1005."""

from __future__ import annotations

from collections.abc import Callable

from motocell.shared.config import ControllerModel
from motocell.shared.protocol.constants import IoResult

M_REGISTER_BASE = 1_000_000
M_REGISTER_READ_MAX = 999
M_REGISTER_WRITE_MAX = 559

Range = tuple[int, int]

_COMMON_TAIL: list[Range] = [(60010, 60647), (70010, 79997)]
"""IF panel and auxiliary relays: the same on every model."""

# Readable ranges (general in/out, external in/out, network in/out, specific in/out, IF panel,
# aux relay, control status, pseudo in), from the motoros1 §8 table.
READABLE: dict[ControllerModel, list[Range]] = {
    ControllerModel.DX100: [
        (10, 2567),
        (10010, 12567),
        (20010, 22567),
        (30010, 32567),
        (25010, 27567),
        (35010, 37567),
        (40010, 41607),
        (50010, 52007),
        *_COMMON_TAIL,
        (80010, 80647),
        (82010, 82207),
    ],
    ControllerModel.FS100: [
        (10, 1287),
        (10010, 11287),
        (20010, 21287),
        (30010, 31287),
        (25010, 26287),
        (35010, 36287),
        (40010, 41607),
        (50010, 52007),
        *_COMMON_TAIL,
        (80010, 80647),
        (82010, 82207),
    ],
    ControllerModel.DX200: [
        (10, 5127),
        (10010, 15127),
        (20010, 25127),
        (30010, 35127),
        (27010, 29567),
        (37010, 39567),
        (40010, 41607),
        (50010, 53007),
        *_COMMON_TAIL,
        (80010, 82007),
        (82010, 82207),
    ],
    ControllerModel.YRC1000: [
        (10, 5127),
        (10010, 15127),
        (20010, 25127),
        (30010, 35127),
        (27010, 29567),
        (37010, 39567),
        (40010, 42567),
        (50010, 55127),
        *_COMMON_TAIL,
        (80010, 85127),
        (87010, 87207),
    ],
    ControllerModel.YRC1000MICRO: [
        (10, 5127),
        (10010, 15127),
        (20010, 21287),
        (30010, 31287),
        (27010, 29567),
        (37010, 39567),
        (40010, 42567),
        (50010, 55127),
        *_COMMON_TAIL,
        (80010, 85127),
        (87010, 87207),
    ],
}


def _writable(model: ControllerModel) -> list[Range]:
    """v1.9.2: general out, network in and the IF panel are writable."""
    general_out, network_in = READABLE[model][1], READABLE[model][4]
    return [general_out, network_in, (60010, 60647)]


def _in(address: int, ranges: list[Range]) -> bool:
    return any(low <= address <= high for low, high in ranges)


def _bit_address_ok(address: int) -> bool:
    # I/O numbers are octal-like: a last digit of 8 or 9 names no signal (motoros1 §8).
    return address % 10 not in (8, 9)


class IoTable:
    def __init__(
        self,
        model: ControllerModel,
        bits: dict[int, int],
        set_bit: Callable[[int, int], None] | None = None,
    ) -> None:
        """``bits`` is the controller's output table; writes go through ``set_bit`` so that
        a client writing OT#890 releases the INIT_ROS job as on a real controller."""
        self.model = model
        self.bits = bits
        self._set_bit = set_bit or bits.__setitem__
        self.registers: dict[int, int] = {}
        self._readable = READABLE[model]
        self._writable = _writable(model)

    def readable(self, address: int) -> bool:
        return _bit_address_ok(address) and _in(address, self._readable)

    def writable(self, address: int) -> bool:
        return _bit_address_ok(address) and _in(address, self._writable)

    def read_bit(self, address: int) -> tuple[int, int]:
        if not self.readable(address):
            return 0, int(IoResult.READ_ADDRESS_INVALID)
        return self.bits.get(address, 0), int(IoResult.OK)

    def write_bit(self, address: int, value: int) -> int:
        # With both address and value wrong, the address error is reported (motoros1 §8).
        if not self.writable(address):
            return int(IoResult.WRITE_ADDRESS_INVALID)
        if value not in (0, 1):
            return int(IoResult.WRITE_VALUE_INVALID)
        self._set_bit(address, value)
        return int(IoResult.OK)

    def read_group(self, address: int) -> tuple[int, int]:
        """``address`` is the byte number: bits address*10 + 0..7, LSB first."""
        base = address * 10
        if address < 0 or not self.readable(base):
            return 0, int(IoResult.READ_ADDRESS_INVALID)
        value = sum(self.bits.get(base + bit, 0) << bit for bit in range(8))
        return value, int(IoResult.OK)

    def write_group(self, address: int, value: int) -> int:
        base = address * 10
        if address < 0 or not self.writable(base):
            return int(IoResult.WRITE_ADDRESS_INVALID)
        if not 0 <= value <= 255:
            return int(IoResult.WRITE_VALUE_INVALID)
        for bit in range(8):
            self._set_bit(base + bit, (value >> bit) & 1)
        return int(IoResult.OK)

    @staticmethod
    def _register(number: int) -> int:
        # Both "5" and "1000005" name M005: numbers below 1 000 000 get it added
        # (motoros1 §8).
        return number - M_REGISTER_BASE if number >= M_REGISTER_BASE else number

    def read_register(self, number: int) -> tuple[int, int]:
        register = self._register(number)
        if not 0 <= register <= M_REGISTER_READ_MAX:
            return 0, int(IoResult.READ_ADDRESS_INVALID)
        return self.registers.get(register, 0), int(IoResult.OK)

    def write_register(self, number: int, value: int) -> int:
        register = self._register(number)
        if not 0 <= register <= M_REGISTER_WRITE_MAX:
            return int(IoResult.WRITE_ADDRESS_INVALID)
        if not 0 <= value <= 0xFFFF:
            return int(IoResult.WRITE_VALUE_INVALID)
        self.registers[register] = value
        return int(IoResult.OK)
