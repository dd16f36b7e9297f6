"""What one state client has yet to receive, written without ever blocking the broadcaster.

A real controller sends its current state at its period; a client that cannot keep up misses
states, it does not get old ones later. So a client's backlog is at most two cycles: the rest
of the cycle already begun (finished first, so frames never interleave and a cycle stays whole
up to its ROBOT_STATUS) and the newest cycle not begun, which a newer one replaces.

Each message goes out in its own ``send``, as MotoROS writes each with its own ``mpSend`` on a
TCP_NODELAY socket: clients that read one message per ``recv`` (the ``moto`` Python client
reads ``recv(1024)`` per message) then find message boundaries where they expect them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence

STUCK_S = 2.0
"""A client that takes no byte of its backlog for this long is closed: it is gone or stopped,
and its slot is one of only four (motoros1 §6)."""

Send = Callable[[bytes | memoryview], int]
"""``socket.send`` of a non-blocking socket: the bytes taken; BlockingIOError when full."""

Cycle = Sequence[bytes]
"""One state cycle: its messages, each encoded whole, in the order they are sent."""


class Backlog:
    def __init__(self) -> None:
        self._rest: deque[bytes | memoryview] = deque()
        """What is left of the cycle begun: its unsent messages, the first maybe in part."""
        self._newest: Cycle | None = None
        self._stuck_since: float | None = None
        self.replaced = 0
        """Cycles this client never got because a newer one came before it could take them."""

    @property
    def pending(self) -> bool:
        return bool(self._rest) or self._newest is not None

    def offer(self, cycle: Cycle) -> None:
        """The newest cycle, to go after the one begun, instead of any older one not begun."""
        if self._newest is not None:
            self.replaced += 1
        self._newest = cycle

    def write(self, send: Send, now: float) -> bool:
        """Write what the socket takes now; False once the client has taken nothing for
        ``STUCK_S``. Errors other than a full socket are the caller's (the client is gone)."""
        progressed = False
        rest = self._rest
        while rest or self._newest is not None:
            if not rest:
                rest.extend(self._newest or ())
                self._newest = None
            message = rest[0]
            try:
                sent = send(message)
            except BlockingIOError:
                sent = 0
            progressed = progressed or sent > 0
            if sent < len(message):
                rest[0] = memoryview(message)[sent:]
                break  # the socket is full: the rest waits for the next cycle
            rest.popleft()
        if progressed or not self.pending:
            self._stuck_since = now if self.pending else None
            return True
        if self._stuck_since is None:
            self._stuck_since = now
        return now - self._stuck_since < STUCK_S
