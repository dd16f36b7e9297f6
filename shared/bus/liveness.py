"""What counts as alive on the bus, without Zenoh: the evidence that a service is there or gone
(``Presence``), and how often republished state comes (``heartbeat_ms``). Pure, so the
services' cores can use it; ``shared.bus.session.Liveness`` feeds a ``Presence`` from Zenoh.
See docs/liveness.md.
"""

from __future__ import annotations

from collections.abc import Iterable

HEARTBEAT_S = 0.1
"""State that is republished while unchanged (the controller status, each group's queue state)
goes out at least this often while motion is possible, so a subscriber can tell a stream that
stopped reaching it from a value that stays the same within a few of these: the executor stops
motion after ``SILENT_HEARTBEATS`` unheard, the gateway says NOT_READY after
``STALE_HEARTBEATS``."""
AT_REST_HEARTBEAT_S = 1.0
"""The same while nothing can move (not motion-ready, or the executor's clock at rest): a
stream found stopped a few seconds late then delays nothing and moves nothing, and an idle cell
is not woken ten times a second to be told that nothing changed."""
SILENT_HEARTBEATS = 4
"""Heartbeats the executor may miss from the controller before it stops motion: fewer than
``STALE_HEARTBEATS``, so motion has stopped before a client can be told NOT_READY."""
STALE_HEARTBEATS = 5
"""Heartbeats a subscriber may miss before it takes a stream as stopped."""
QUERY_TIMEOUT_S = 1.0
"""How long a service's query on the bus (a liveliness token, a slot) may take: Zenoh ends it
then, answered or not."""
ASK_AGAIN_S = AT_REST_HEARTBEAT_S
"""While something a service needs is missing (a token its events missed, a slot), how long
after the last question it asks again: as often as the at-rest heartbeat, so asking costs an
idle cell no more than its state streams do."""


def heartbeat_ms(motion_possible: bool) -> int:
    """The heartbeat a stream announces in its samples (``heartbeat_ms`` fields)."""
    return round(1000 * (HEARTBEAT_S if motion_possible else AT_REST_HEARTBEAT_S))


def silence_bound_s(heartbeat: int, heartbeats: int) -> float:
    """How long ``heartbeats`` of a stream that announced ``heartbeat`` ms last."""
    return heartbeats * heartbeat / 1000


NONE_DEPARTED: frozenset[str] = frozenset()


class Presence:
    """Which liveliness tokens are present, on evidence only. Pure.

    A token is present from its PUT event, or from a liveliness query's answer when no event
    for it has arrived since the query was asked: an event is the newer news, and a DELETE can
    overtake an answer. A token is gone only on its DELETE, which Zenoh sends when the session
    holding it undeclared it or closed: its process exited or was killed (the socket closed),
    or it went unheard for the lease (``shared.bus.session.LEASE_MS``). An answer that lacks a
    token, comes late or never comes proves nothing, so it removes nothing.

    A token that went and came back between two looks still went: its holder's samples in
    flight meanwhile may be lost, so ``take_departed`` tells of every departure once.
    """

    def __init__(self) -> None:
        self._present: set[str] = set()
        self._departed: set[str] = set()
        self._events = 0
        self._last_event: dict[str, int] = {}
        """Per token, the number of its newest event (events are numbered from 1)."""

    def on_event(self, key: str, *, put: bool) -> bool:
        """A PUT or DELETE; whether it changed what is present."""
        self._events += 1
        self._last_event[key] = self._events
        if put == (key in self._present):
            return False
        if put:
            self._present.add(key)
        else:
            self._present.discard(key)
            self._departed.add(key)
        return True

    def take_departed(self) -> frozenset[str]:
        """The tokens deleted since the last call, present again or not (nothing allocated
        when none was: the executor asks every tick)."""
        if not self._departed:
            return NONE_DEPARTED
        departed = frozenset(self._departed)
        self._departed.clear()
        return departed

    def asking(self) -> int:
        """Call as a query is asked; give the result to ``on_answer`` with the query's tokens."""
        return self._events

    def on_answer(self, tokens: Iterable[str], asked: int) -> set[str]:
        """The tokens a query found that events had not shown and have not spoken of since
        the query was asked; they are present now."""
        found = {
            key
            for key in tokens
            if key not in self._present and self._last_event.get(key, 0) <= asked
        }
        self._present |= found
        return found

    @property
    def present(self) -> frozenset[str]:
        return frozenset(self._present)


class Asking:
    """When to ask again for something a service needs and lacks (a group's slot, a
    liveliness token its events missed): at once, then at most once per ``every`` s after the
    last question finished. A question never finished counts as finished after ``timeout``
    (the bus ends every query by then), so one lost answer cannot stop the asking. The one
    rule for every service's re-asking; times in seconds of any monotonic clock."""

    def __init__(self, every: float = ASK_AGAIN_S, timeout: float = QUERY_TIMEOUT_S) -> None:
        self.every = every
        self.timeout = timeout
        self.next = 0.0
        """The earliest moment to ask again."""

    def due(self, now: float) -> bool:
        return now >= self.next

    def asked(self, now: float) -> None:
        self.next = now + self.timeout + self.every

    def finished(self, now: float) -> None:
        self.next = now + self.every

    def renew(self) -> None:
        """An answer has become likely (whoever answers came back): ask at once."""
        self.next = 0.0
