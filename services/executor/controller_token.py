"""The controller's liveliness token as the executor's clock thread sees it.

No Python runs on Zenoh's threads in the executor (see ``Executor``): the token's events and the
answers to liveliness queries wait in Zenoh channels and are drained once per tick. What they
mean is ``shared.bus.liveness.Presence``'s: the controller is gone only on its token's DELETE
(its process exited, or it went unheard for the lease), never because a query went unanswered.
"""

from __future__ import annotations

from typing import Any

import zenoh

from motocell.shared.bus.liveness import Presence

CHANNEL_DEPTH = 64
"""Events and answers between two ticks: a handful at most."""
QUERY_TIMEOUT_S = 1.0


def _channel() -> zenoh.handlers.FifoChannel[Any]:
    return zenoh.handlers.FifoChannel(CHANNEL_DEPTH)


class ControllerToken:
    """Events from a subscriber without history (see ``shared.bus.session.Liveness`` for why)
    and a query asked after it for a token that was there before; while the controller is
    absent the query is asked again every ``ask_every`` ticks, for a declaration the events
    missed."""

    def __init__(self, session: zenoh.Session, key: str, ask_every: int) -> None:
        self._session = session
        self._key = key
        self._ask_every = ask_every
        self._presence = Presence()
        self._events = session.liveliness().declare_subscriber(key, _channel())
        self._asked = 0
        self._answers: zenoh.handlers.Handler[zenoh.Reply] | None = None
        """The last query's answers; None once it is finished."""
        self._ask()

    def _ask(self) -> None:
        self._asked = self._presence.asking()
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

    def present(self, tick: int) -> bool:
        """Whether the controller's token is present, from everything that arrived so far."""
        while (event := self._events.try_recv()) is not None:
            self._presence.on_event(str(event.key_expr), put=event.kind == zenoh.SampleKind.PUT)
        self._take_answers()
        alive = self._key in self._presence.present
        if not alive and tick % self._ask_every == 0:
            self._ask()
        return alive
