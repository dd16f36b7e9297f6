"""The two ways a Simple Message exchange can go wrong: our bug, or the peer's garbage."""

from __future__ import annotations

from typing import Final

from motocell.shared.protocol.constants import InvalidSubcode, Result


class LocalProtocolError(Exception):
    """We tried to build or send something the protocol cannot carry: a bug on our side."""


class PeerProtocolError(Exception):
    """The peer sent bytes we cannot accept; carries what the INVALID reply MotoROS sends needs.

    ``msg_type`` is the offending frame's type, or 0 when the framing itself was unreadable.
    ``shared.protocol.replies`` turns it into the reply: ``invalid_reply`` on the motion port,
    ``io_error_reply`` on the I/O port.
    """

    result: Final = Result.INVALID

    def __init__(self, detail: str, subcode: InvalidSubcode, msg_type: int = 0) -> None:
        super().__init__(detail)
        self.subcode = subcode
        self.msg_type = msg_type
