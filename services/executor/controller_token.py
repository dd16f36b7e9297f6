"""The controller's liveliness token as the executor's clock thread sees it.

No Python runs on Zenoh's threads for it (see ``inputs``): the token's events and the answers to
liveliness queries wait in Zenoh channels and are drained with the other inputs. What they mean
is ``shared.bus.liveness.Presence``'s: the controller is gone only on its token's DELETE (its
process exited, or it went unheard for the lease), never because a query went unanswered.
"""

from __future__ import annotations

from typing import Any

import zenoh

from motocell.shared.bus.liveness import Presence

CHANNEL_DEPTH = 64
"""Events and answers between two drains: a handful at most."""
QUERY_TIMEOUT_S = 1.0
ASK_EVERY_NS = 1_000_000_000
"""While the controller is absent, how often to ask again for a declaration the events missed."""


def _channel() -> zenoh.handlers.FifoChannel[Any]:
    return zenoh.handlers.FifoChannel(CHANNEL_DEPTH)


class ControllerToken:
    """Events from a subscriber without history (see ``shared.bus.session.Liveness`` for why),
    and a query asked after it for a token that was there before: at the first look, then
    every ``ASK_EVERY_NS`` while the controller is absent."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self._session = session
        self._key = key
        self._presence = Presence()
        self._events = session.liveliness().declare_subscriber(key, _channel())
        self._asked = 0
        self._asked_at_ns: int | None = None
        self._answers: zenoh.handlers.Handler[zenoh.Reply] | None = None
        """The last query's answers; None once it is finished."""

    def _ask(self, now_ns: int) -> None:
        self._asked = self._presence.asking()
        self._asked_at_ns = now_ns
        self._answers = self._session.liveliness().get(
            self._key, _channel(), timeout=QUERY_TIMEOUT_S
        )

    def _take_answers(self) -> None:
        """The last query's answers so far; its channel closes when it is finished."""
        if self._answers is None:
            return
        try:
            while (reply := self._answers.try_recv()) is not None:
                if reply.ok is not None:
                    self._presence.on_answer([str(reply.ok.key_expr)], self._asked)
        except zenoh.ZError:
            self._answers = None

    def present(self, now_ns: int) -> bool:
        """Whether the controller's token is present, from everything that arrived so far."""
        while (event := self._events.try_recv()) is not None:
            self._presence.on_event(str(event.key_expr), put=event.kind == zenoh.SampleKind.PUT)
        self._take_answers()
        alive = self._key in self._presence.present
        if not alive and (self._asked_at_ns is None or now_ns - self._asked_at_ns >= ASK_EVERY_NS):
            self._ask(now_ns)
        return alive
