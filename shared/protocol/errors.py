"""The two ways a Simple Message exchange can go wrong: our bug, or the peer's garbage."""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from shared.protocol.constants import InvalidSubcode, Result

if TYPE_CHECKING:
    from shared.protocol.messages import Message


class LocalProtocolError(Exception):
    """We tried to build or send something the protocol cannot carry: a bug on our side."""


class PeerProtocolError(Exception):
    """The peer sent bytes we cannot accept; carries the INVALID reply MotoROS would send.

    ``msg_type`` is the offending frame's type, or 0 when the framing itself was unreadable.
    """

    result: Final = Result.INVALID

    def __init__(self, detail: str, subcode: InvalidSubcode, msg_type: int = 0) -> None:
        super().__init__(detail)
        self.subcode = subcode
        self.msg_type = msg_type

    def reply(self) -> Message:
        """The MOTO_MOTION_REPLY a motion port answers with (motoros1-behaviour.md §1.4, §2.7).

        The I/O port answers in its own form instead: ``replies.io_error_reply(self.subcode)``.
        """
        # Imported here because replies (through layouts) imports this module.
        from shared.protocol.replies import invalid_reply

        return invalid_reply(self)
