"""The controller's liveliness token as the executor's clock thread sees it: its
``ControllerPresence`` over the ``Bus``.

No Python runs on the bus's threads for it (see ``inputs``): the token's events and the answers
to liveliness queries wait in channels and are drained with the other inputs. What they mean is
``shared.bus.liveness.Presence``'s: the controller is gone only on its token's DELETE (its
process exited, or it went unheard for the lease), never because a query went unanswered.
"""

from __future__ import annotations

from motocell.services.executor.bus import Bus, TokenAnswers
from motocell.shared.bus.liveness import QUERY_TIMEOUT_S, Asking, Presence

_PRESENT, _ABSENT = (True,), (False,)
"""A tick's usual answers, made once."""
CHANNEL_DEPTH = 64
"""Events and answers between two drains: a handful at most."""


class ControllerToken:
    """Events from a subscription without history (see ``shared.bus.session.Liveness`` for
    why), and a query asked after it for a token that was there before: at the first look, then
    as ``Asking`` says while the controller is absent."""

    def __init__(self, bus: Bus, key: str) -> None:
        self._bus = bus
        self._key = key
        self._presence = Presence()
        self._events = bus.token_events(key, CHANNEL_DEPTH)
        self._asking = Asking()
        self._asked = 0
        self._answers: TokenAnswers | None = None
        """The last query's answers; None once it is finished."""

    def _ask(self, now_s: float) -> None:
        self._asked = self._presence.asking()
        self._asking.asked(now_s)
        self._answers = self._bus.ask_tokens(self._key, CHANNEL_DEPTH, QUERY_TIMEOUT_S)

    def _take_answers(self, now_ns: int) -> None:
        """The last query's answers so far."""
        if self._answers is None:
            return
        tokens, finished = self._answers.take()
        if tokens:
            self._presence.on_answer(tokens, self._asked)
        if finished:
            self._answers = None
            self._asking.finished(now_ns / 1e9)

    def looks(self, now_ns: int) -> tuple[bool, ...]:
        """What the controller's token did, from everything that arrived since the last look,
        in order: False for a DELETE, even one its PUT followed before this look (the link
        broke and came back within a period: statuses sent meanwhile, a not-ready one among
        them, are lost), then whether it is present now. ``Asking`` counts in seconds, the
        clock in nanoseconds: converted only while the controller is absent or a query is
        open, never on a moving tick's path."""
        while (event := self._events.try_recv()) is not None:
            self._presence.on_event(str(event.key_expr), put=self._bus.declared(event))
        self._take_answers(now_ns)
        alive = self._key in self._presence.present
        if not alive and self._asking.due(now_ns / 1e9):
            self._ask(now_ns / 1e9)
        if self._presence.take_departed():
            return (False, alive)
        return _PRESENT if alive else _ABSENT
