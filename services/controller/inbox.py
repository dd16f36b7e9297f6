"""What arrives for the controller's one thread, and the queue it waits in.

Zenoh's callbacks (``bus``) turn each command, fault, notice and liveliness change into one of
the frozen items here, its payload already decoded, and only queue it; the loop takes them in
order and matches on their type. A query arrives with its ``ReplyTo``: where its reply goes.
"""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass
from typing import Protocol

from motocell.services.controller.core.dispatch import FaultKind, Verb
from motocell.shared.bus.schemas import CommandReply, CommandRequest

INBOX_SIZE = 10_000
"""What a producer that outruns the loop can have waiting before more is dropped."""


class ReplyTo(Protocol):
    """Where a query's reply goes."""

    def send(self, reply: CommandReply) -> None:
        """Reply and end the query."""
        ...


@dataclass(frozen=True, slots=True)
class CommandQuery:
    """A command on ``controller/cmd/<verb>``."""

    verb: Verb
    request: CommandRequest
    reply_to: ReplyTo


@dataclass(frozen=True, slots=True)
class FaultQuery:
    """An injected fault on ``controller/fault/<kind>``."""

    kind: FaultKind
    request: CommandRequest
    reply_to: ReplyTo


@dataclass(frozen=True, slots=True)
class ConnectionCounts:
    """The gateway's or the broadcaster's client counts (``controller/cmd/connections``)."""

    counts: CommandRequest


@dataclass(frozen=True, slots=True)
class IncMoveError:
    """The executor stopped motion (``controller/cmd/incmove_error``)."""

    notice: CommandReply


@dataclass(frozen=True, slots=True)
class BadPayload:
    """A query or notice whose payload did not decode."""

    source: str
    """The key it came on, after ``controller/`` (``cmd/select_tool``, ``connections``)."""
    reason: str
    reply_to: ReplyTo | None
    """Where the refusal goes; None for a notice, which gets no reply."""


@dataclass(frozen=True, slots=True)
class TokensChanged:
    """Liveliness tokens came or went (an event, or what a question found)."""


@dataclass(frozen=True, slots=True)
class TokensAnswered:
    """The last question for liveliness tokens is finished."""


@dataclass(frozen=True, slots=True)
class Stop:
    """The service is stopping: ends the loop's wait at once."""


Arrival = (
    CommandQuery
    | FaultQuery
    | ConnectionCounts
    | IncMoveError
    | BadPayload
    | TokensChanged
    | TokensAnswered
    | Stop
)


class Inbox:
    """One queue that several Zenoh callbacks feed, drained by the controller's own thread.

    Zenoh callbacks run on Zenoh's threads; they only append here, so no service logic ever
    runs on them. Bounded: what a producer that outruns the consumer sends is dropped and
    counted (``dropped``) rather than growing memory without limit.
    """

    def __init__(self, size: int = INBOX_SIZE) -> None:
        self._queue: queue.Queue[Arrival] = queue.Queue(size)
        self._dropped = 0
        self._dropped_lock = threading.Lock()
        """Several Zenoh threads may find the queue full at once."""

    @property
    def dropped(self) -> int:
        with self._dropped_lock:
            return self._dropped

    def offer(self, arrival: Arrival) -> None:
        """Queue ``arrival``, or drop and count it when the queue is full."""
        try:
            self._queue.put_nowait(arrival)
        except queue.Full:
            with self._dropped_lock:
                self._dropped += 1

    def put(self, arrival: Arrival) -> None:
        """Queue ``arrival``, waiting for room: for what must not be lost."""
        self._queue.put(arrival)

    def get(self, timeout: float) -> Arrival | None:
        """The next arrival, waiting up to ``timeout`` s; None if none came."""
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def get_nowait(self) -> Arrival | None:
        try:
            return self._queue.get_nowait()
        except queue.Empty:
            return None
