"""What a request handler gives the TCP server to do."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from motocell.shared.protocol.messages import Message


@dataclass(frozen=True)
class Answer:
    reply: Message | None
    close: bool = False
    then: Callable[[], None] | None = None
    """Run once the reply is written."""
