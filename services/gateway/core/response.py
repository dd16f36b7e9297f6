"""What the TCP server does for one request, as a handler decides it: the Simple Message reply
to write (None: none is sent), whether to close the connection after it, and what to run once
the reply is written."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from motocell.shared.protocol.messages import Message


@dataclass(frozen=True)
class Response:
    reply: Message | None
    close: bool = False
    then: Callable[[], None] | None = None
    """Run once the reply is written."""
