"""The motion port's connection thread at the reply priority, held only while it waits for its
client between requests (docs/reply-path.md, The reply's priority).

At ``REPLY_PRIORITY`` the thread preempts every other thread of the cell but the clock. That
is what a request-reply client needs, and it is bounded by the client's own pace: the thread
sleeps in ``recv`` between requests. A client that pipelines or floods requests would keep a
request waiting every time the thread reads, and so keep a CPU from the cell's other threads,
which at one priority would take turns with it. So a thread that has found a request already
waiting at every read for ``BUSY_S`` drops back to the services' priority, and takes the reply
priority again the next time it has to wait.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from motocell.shared.realtime import (
    REPLY_PRIORITY,
    SERVICE_PRIORITY,
    enter_reply_priority,
    round_robin,
)

BUSY_S = 0.02
"""How long a connection thread may read without once waiting before it gives way: five
interpolation periods, far above a request-reply client's turn (a fraction of a millisecond),
far below the stall bound of a cell it would starve (docs/timing.md)."""


class ReplyPriority:
    """One connection thread's priority; ``enter`` from that thread, then ``waiting`` or
    ``busy`` before each read. Off (never entered, or refused) it does nothing."""

    def __init__(
        self,
        *,
        clock: Callable[[], float] = time.monotonic,
        set_priority: Callable[[int], None] = round_robin,
    ) -> None:
        self._clock = clock
        self._set_priority = set_priority
        self.raised = False
        """Whether the thread was granted the reply priority: only then is it watched."""
        self._gave_way = False
        self._busy_since: float | None = None

    def enter(self) -> None:
        self.raised = enter_reply_priority()

    def waiting(self) -> None:
        """Nothing was there to read: the thread waits for its client."""
        self._busy_since = None
        if self._gave_way:
            self._set_priority(REPLY_PRIORITY)
            self._gave_way = False

    def busy(self) -> None:
        """A request was there already: the thread read without waiting."""
        if self._gave_way:
            return
        now = self._clock()
        if self._busy_since is None:
            self._busy_since = now
        elif now - self._busy_since > BUSY_S:
            self._set_priority(SERVICE_PRIORITY)
            self._gave_way = True
