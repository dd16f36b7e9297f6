"""The Simple Message codec: bytes in, events out; messages in, bytes out.

Pure, in the manner of h11: no sockets, tasks or clocks. The caller feeds what it read to
``receive_data`` (``b""`` when the peer closed), calls ``next_event`` until it returns
``NEED_DATA`` (or ``CLOSED``), and writes what ``send`` returns.

Unlike MotoROS, which ignores the length prefix and reads one ``recv`` at a time
(motoros1 §1.1), the decoder frames by the prefix, so a frame split across reads
reassembles and several frames in one read all come out.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping
from enum import Enum
from typing import Final

from motocell.shared.protocol import layouts
from motocell.shared.protocol.constants import HEADER_SIZE, PREFIX_SIZE, InvalidSubcode
from motocell.shared.protocol.errors import LocalProtocolError, PeerProtocolError
from motocell.shared.protocol.layouts import (
    FRAME_HEAD,
    HEADER,
    PREFIX,
    ByteOrder,
    Direction,
    Encode,
)
from motocell.shared.protocol.messages import Message, UnknownMessage

__all__ = [
    "CLOSED",
    "NEED_DATA",
    "ByteOrder",
    "Closed",
    "Event",
    "NeedData",
    "Role",
    "SimpleMessageCodec",
    "decode_frames",
    "encode",
    "max_frame_length",
    "readable_byte_order",
]


class Role(Enum):
    """Which side of the connection we are."""

    CONTROLLER = "controller"
    CLIENT = "client"


_RECEIVES: Final = {Role.CONTROLLER: Direction.TO_CONTROLLER, Role.CLIENT: Direction.TO_CLIENT}
_SENDS: Final = {Role.CONTROLLER: Direction.TO_CLIENT, Role.CLIENT: Direction.TO_CONTROLLER}


class NeedData(Enum):
    NEED_DATA = "NEED_DATA"


class Closed(Enum):
    CLOSED = "CLOSED"


NEED_DATA: Final = NeedData.NEED_DATA
"""No whole frame is buffered: feed more bytes."""
CLOSED: Final = Closed.CLOSED
"""The peer closed and every whole frame has been returned; a partial one is dropped."""

Event = Message | UnknownMessage | NeedData | Closed


def max_frame_length(direction: Direction) -> int:
    """The largest length prefix a receiver of ``direction`` accepts: header + largest body."""
    return HEADER_SIZE + layouts.max_body_size(direction)


def readable_byte_order(prefix: bytes, direction: Direction) -> ByteOrder | None:
    """The byte order in which ``prefix``, the first four bytes of a frame, is a length that a
    receiver of ``direction`` accepts; None if it is one in neither.

    A real length is below 2**16, so swapping its bytes gives one of at least 2**16: at most
    one byte order can read it. A peer of the other byte order shows up as a length of about
    a gigabyte in ours (the state port of an FS100 to a little-endian client: -1879048192).
    """
    for byte_order in ByteOrder:
        (length,) = PREFIX[byte_order].unpack_from(prefix)
        if HEADER_SIZE <= length <= max_frame_length(direction):
            return byte_order
    return None


class SimpleMessageCodec:
    """One connection's framing state, for the side named by ``role``."""

    def __init__(self, role: Role, byte_order: ByteOrder = ByteOrder.LITTLE) -> None:
        self.role = role
        self.byte_order = byte_order
        receives = _RECEIVES[role]
        self._decoders = layouts.decoders(receives, byte_order)
        self._encoders = layouts.encoders(_SENDS[role], byte_order)
        self._max_length = max_frame_length(receives)
        self.max_frame_size: Final = PREFIX_SIZE + self._max_length
        self._unpack_prefix = PREFIX[byte_order].unpack_from
        self._unpack_header = HEADER[byte_order].unpack_from
        self._buf = bytearray()
        self._pos = 0
        self._closed = False

    @property
    def buffered_bytes(self) -> int:
        """Bytes received and not yet returned as events."""
        return len(self._buf) - self._pos

    def receive_data(self, data: bytes) -> None:
        if not data:
            self._closed = True
            return
        if self._closed:
            raise LocalProtocolError("receive_data() after the peer closed")
        # A buffer that is never drained would grow without bound. After NEED_DATA fewer than
        # max_frame_size bytes are pending (any longer length prefix is rejected at once), so
        # the buffer stays within max_frame_size + one read.
        if self.buffered_bytes >= self.max_frame_size:
            raise LocalProtocolError("call next_event() until NEED_DATA before receive_data()")
        # Drop consumed frames once per read, not once per frame.
        del self._buf[: self._pos]
        self._pos = 0
        self._buf += data

    def next_event(self) -> Event:
        buf = self._buf
        pos = self._pos
        if len(buf) - pos < PREFIX_SIZE:
            return self._out_of_data()
        (length,) = self._unpack_prefix(buf, pos)
        if length < HEADER_SIZE or length > self._max_length:
            self._discard_buffer()
            raise self._bad_length(length)
        end = pos + PREFIX_SIZE + length
        if end > len(buf):
            return self._out_of_data()
        msg_type, comm_type, reply_type = self._unpack_header(buf, pos + PREFIX_SIZE)
        body_at = pos + PREFIX_SIZE + HEADER_SIZE
        # Consumed before decoding: a body of the wrong size is skipped, as framed by its prefix.
        self._pos = end
        decode = self._decoders.get(msg_type)
        if decode is None:
            # The caller answers INVALID/3003 (motoros1 §2.7), so this is an event, not an error.
            return UnknownMessage(msg_type, comm_type, reply_type, bytes(buf[body_at:end]))
        return Message(msg_type, comm_type, reply_type, decode(buf, body_at, end - body_at))

    def send(self, message: Message | UnknownMessage) -> bytes:
        return _encode(message, self.byte_order, self._encoders, _SENDS[self.role])

    def _out_of_data(self) -> NeedData | Closed:
        if self._closed:
            self._discard_buffer()
            return CLOSED
        return NEED_DATA

    def _discard_buffer(self) -> None:
        # A bad length leaves no way to find the next frame; MotoROS also throws the read away.
        self._buf.clear()
        self._pos = 0

    def _bad_length(self, length: int) -> PeerProtocolError:
        if length < HEADER_SIZE:
            # Too short to hold even the header (motoros1 §1.1): the header is what is broken.
            return PeerProtocolError(
                f"length prefix {length} is shorter than the {HEADER_SIZE}-byte header",
                InvalidSubcode.MSGHEADER,
            )
        # MotoROS reads at most one 552-byte message per recv (motoros1 §1.1), so nothing
        # longer than the largest body this side receives can be a real message.
        return PeerProtocolError(
            f"length prefix {length} exceeds the largest message ({self._max_length})",
            InvalidSubcode.MSGSIZE,
        )


def encode(message: Message | UnknownMessage, byte_order: ByteOrder, role: Role) -> bytes:
    """One whole frame (prefix, header, body) as ``role`` sends ``message``.

    An ``UnknownMessage`` is sent as its raw body, for types the peer does not know (e.g. a
    client's GET_VERSION); it round-trips through the peer's decoder unchanged.
    """
    direction = _SENDS[role]
    return _encode(message, byte_order, layouts.encoders(direction, byte_order), direction)


def _encode(
    message: Message | UnknownMessage,
    byte_order: ByteOrder,
    encoders: Mapping[int, Encode],
    direction: Direction,
) -> bytes:
    if isinstance(message, UnknownMessage):
        body = _raw_body(message, encoders, direction)
    else:
        encode_body = encoders.get(message.msg_type)
        if encode_body is None:
            raise LocalProtocolError(f"type {message.msg_type} is not sent {direction.value}")
        body = encode_body(message.body)
    try:
        head = FRAME_HEAD[byte_order].pack(
            HEADER_SIZE + len(body), message.msg_type, message.comm_type, message.reply_type
        )
    except struct.error as err:
        raise LocalProtocolError(f"cannot encode header of {message!r}: {err}") from err
    return head + body


def _raw_body(
    message: UnknownMessage, encoders: Mapping[int, Encode], direction: Direction
) -> bytes:
    if message.msg_type in encoders:
        raise LocalProtocolError(f"type {message.msg_type} has a layout: send it as a Message")
    if HEADER_SIZE + len(message.body) > max_frame_length(direction):
        raise LocalProtocolError(
            f"{len(message.body)}-byte body is longer than a receiver {direction.value} accepts"
        )
    return message.body


def decode_frames(
    data: bytes, role: Role, byte_order: ByteOrder = ByteOrder.LITTLE
) -> list[Message | UnknownMessage]:
    """Every frame in ``data``, which must hold whole frames only (e.g. a captured payload)."""
    codec = SimpleMessageCodec(role, byte_order)
    codec.receive_data(data)
    frames: list[Message | UnknownMessage] = []
    while isinstance(event := codec.next_event(), Message | UnknownMessage):
        frames.append(event)
    if codec.buffered_bytes:
        raise PeerProtocolError(
            f"{codec.buffered_bytes} bytes of a truncated frame at the end", InvalidSubcode.MSGSIZE
        )
    return frames
