"""The robot's I/O signals and M-registers as Simple Message requests (the I/O port 50242, and
the bit and group ones on the motion port too): forwarded to the controller, which owns the I/O
table; the reply carries its result code (motoros1 §8)."""

from __future__ import annotations

from motocell.services.gateway.core.cell_port import CellPort
from motocell.services.gateway.core.response import Response
from motocell.shared.bus.schemas import CommandRequest
from motocell.shared.protocol.constants import InvalidSubcode, IoResult, MsgType
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import (
    Message,
    ReadIOBit,
    ReadIOGroup,
    ReadMRegister,
    UnknownMessage,
    WriteIOBit,
    WriteIOGroup,
    WriteMRegister,
)
from motocell.shared.protocol.replies import io_error_reply, io_reply

IO_TIMEOUT_S = 1.0
WRITES = (MsgType.MOTO_WRITE_IO_BIT, MsgType.MOTO_WRITE_IO_GROUP, MsgType.MOTO_WRITE_MREGISTER)


class RobotIoHandler:
    def __init__(self, cell: CellPort) -> None:
        self.cell = cell

    def respond(self, request: Message | UnknownMessage) -> Response:
        """The I/O port's response: always a reply, never a close (motoros1 §8)."""
        return Response(self.reply(request))

    @staticmethod
    def error_reply(error: PeerProtocolError) -> Message:
        """A frame the I/O port cannot read: its error reply, and the connection is kept."""
        return io_error_reply(error.subcode)

    def reply(self, request: Message | UnknownMessage) -> Message:
        """Every request is answered and the connection is always kept (motoros1 §8)."""
        if isinstance(request, UnknownMessage):
            return io_error_reply(InvalidSubcode.MSGTYPE)
        body = request.body
        match body:
            case ReadIOBit():
                verb, command = "read_bit", CommandRequest(value=body.address)
            case WriteIOBit():
                verb, command = "write_bit", CommandRequest(value=body.address, args=[body.value])
            case ReadIOGroup():
                verb, command = "read_group", CommandRequest(value=body.address)
            case WriteIOGroup():
                verb, command = "write_group", CommandRequest(value=body.address, args=[body.value])
            case ReadMRegister():
                verb, command = "read_register", CommandRequest(value=body.register)
            case WriteMRegister():
                verb, command = (
                    "write_register",
                    CommandRequest(value=body.register, args=[body.value]),
                )
            case _:
                # The I/O port handles only 2003-2013; PING and the motion types included get
                # the "unknown type" error reply here, as MotoROS does.
                return io_error_reply(InvalidSubcode.MSGTYPE)
        reply = self.cell.controller(verb, command, timeout=IO_TIMEOUT_S)
        if reply is None:
            is_write = request.msg_type in WRITES
            code = IoResult.WRITE_API_ERROR if is_write else IoResult.READ_API_ERROR
            return io_reply(request, code)
        return io_reply(request, reply.result, reply.value)
