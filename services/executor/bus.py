"""The executor's bus as its shells see it, in two layers.

The clock's loop is written against ``InputPort`` and ``OutputPort``: what it drains before each
tick and what it publishes after (``loop``). ``inputs.Inputs`` (with
``controller_token.ControllerToken``) and ``outputs.Outputs`` implement them over a ``Bus``:
the few things they need of a Zenoh session. ``ZenohBus`` is the thin adapter over a real one;
their unit tests script a fake instead, as the gateway's do.

Nothing on the tick's path passes through a Python layer of the adapter's: a channel's
``try_recv`` and a publication's ``put`` are Zenoh's own calls, and samples reach their readers
as Zenoh delivers them (``Sample``), so draining an empty channel or publishing a tick costs
what it costs on the session itself.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Protocol

import zenoh

from motocell.shared.bus.adapters import (
    Declared,
    Publication,
    ZenohPublication,
    callback_subscriber,
)
from motocell.shared.bus.channels import Doorbell as ZenohDoorbell
from motocell.shared.bus.schemas import (
    CommandReply,
    ControllerStatus,
    ExecutorMetrics,
    IncrementBatch,
    LateTicks,
    Point,
    QueueState,
    Tick,
)
from motocell.shared.bus.session import answer, call, publisher

# -- what the loop needs ---------------------------------------------------------------------


class Query(Protocol):
    """A question another service asked the executor (STOP_MOTION), answered once."""

    def answer(self, reply: CommandReply) -> None:
        """Reply and end the query."""
        ...


class ControllerPresence(Protocol):
    def looks(self, now_ns: int) -> tuple[bool, ...]:
        """The controller's liveliness token since the last look, from everything that arrived
        by ``now_ns`` (CLOCK_MONOTONIC): False for a departure, even one it came back from,
        then whether it is present now."""
        ...


class InputPort(Protocol):
    """Everything that reaches the executor, drained by the clock's thread."""

    @property
    def controller(self) -> ControllerPresence: ...

    executor_ready: bool
    """What the clock's thread last made of readiness: while it rests, a status saying
    otherwise wakes it."""

    def rest(self, deadline_s: float) -> None:
        """Block until a point arrives, a status changes what may move, STOP_MOTION is asked,
        ``deadline_s`` (CLOCK_MONOTONIC) passes, or the service stops."""
        ...

    def awake(self) -> None:
        """The rest is over: the clock runs."""
        ...

    def statuses(self) -> Iterable[tuple[int, ControllerStatus]]:
        """Every controller status since the last call, in order, with when it arrived."""
        ...

    def points(self) -> Iterable[tuple[int, Point]]:
        """The points the gateway published since the last call, with their group."""
        ...

    def batches(self, group: int) -> Iterable[IncrementBatch | None]:
        """``group``'s increment batches since the last call; None for one that does not
        decode."""
        ...

    def stop_queries(self) -> Iterable[Query]:
        """STOP_MOTION's queries since the last call."""
        ...


class OutputPort(Protocol):
    """What the executor publishes."""

    def tick(self, tick: Tick) -> None: ...

    def queues(self, updates: Iterable[tuple[int, QueueState]]) -> None: ...

    def notices(self, replies: Iterable[CommandReply]) -> None:
        """To the controller's increment path (``controller/cmd/incmove_error``)."""
        ...

    def late(self, late: LateTicks) -> None:
        """Periods the clock missed, as ``core.late_ticks`` gathers them."""
        ...

    def metrics_wanted(self) -> bool:
        """Whether anyone subscribes to the metrics: nothing is summarised for nobody."""
        ...

    def metrics(self, metrics: ExecutorMetrics) -> None: ...

    def stopped(self, queries: Iterable[Query]) -> None:
        """STOP_MOTION done: the rings were cleared before the next tick."""
        ...


# -- what the adapters need of a session -----------------------------------------------------


class Payload(Protocol):
    def to_bytes(self) -> bytes: ...


class Sample(Protocol):
    """A sample as the bus delivers it (a Zenoh ``Sample``)."""

    @property
    def key_expr(self) -> object:
        """Its key; ``str`` gives it as text."""
        ...

    @property
    def payload(self) -> Payload: ...


class Channel(Protocol):
    """Samples of a subscription waiting for the thread that reads them (a Zenoh
    ``FifoChannel``): no Python runs on the bus's threads for them."""

    def try_recv(self) -> Sample | None: ...

    def recv(self) -> Sample:
        """Block until a sample comes (a doorbell's too)."""
        ...


class TokenEvent(Protocol):
    """A liveliness token declared or undeclared (``Bus.declared`` says which)."""

    @property
    def key_expr(self) -> object: ...

    @property
    def kind(self) -> object: ...


class TokenEvents(Protocol):
    """A liveliness subscription's events, waiting in a channel like ``Channel``'s."""

    def try_recv(self) -> TokenEvent | None: ...


class TokenAnswers(Protocol):
    """The answers to one liveliness query, as they come."""

    def take(self) -> tuple[list[str], bool]:
        """The tokens answered since the last call, and whether the query has finished."""
        ...


class Doorbell(Protocol):
    """Wakes the reader blocked in ``Channel.recv`` on its key, in this session only
    (``shared.bus.channels.Doorbell``)."""

    def ring(self) -> None: ...

    def close(self) -> None: ...


class Bus(Protocol):
    def channel(self, key: str, depth: int) -> Channel:
        """Subscribe to ``key``; its samples wait in a channel of ``depth`` samples."""
        ...

    def subscribe(self, key: str, on_sample: Callable[[Sample], None]) -> Declared:
        """``on_sample`` runs on the bus's threads, once per sample: it must only hand the
        sample on."""
        ...

    def queryable(self, key: str, on_query: Callable[[Query], None]) -> Declared:
        """``on_query`` runs on the bus's threads, once per query: it must only hand it on."""
        ...

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        """As ``shared.bus.session.publisher``."""
        ...

    def doorbell(self, key: str) -> Doorbell: ...

    def token_events(self, key: str, depth: int) -> TokenEvents:
        """The liveliness tokens' events under ``key`` from now on (no history)."""
        ...

    def declared(self, event: TokenEvent) -> bool:
        """Whether ``event`` declares its token (else it undeclares it)."""
        ...

    def ask_tokens(self, key: str, depth: int, timeout: float) -> TokenAnswers:
        """Ask which tokens under ``key`` are present; returns at once. The bus ends the query
        by ``timeout`` seconds."""
        ...

    def call(self, key: str, timeout: float) -> CommandReply | None:
        """One command query, blocking until it is answered; None when nobody answered by
        ``timeout`` seconds."""
        ...


# -- over Zenoh ------------------------------------------------------------------------------


class _ZenohQuery:
    def __init__(self, query: zenoh.Query) -> None:
        self._query = query

    def answer(self, reply: CommandReply) -> None:
        answer(self._query, reply)


class _ZenohTokenAnswers:
    def __init__(self, answers: zenoh.handlers.Handler[zenoh.Reply]) -> None:
        self._answers = answers

    def take(self) -> tuple[list[str], bool]:
        """Zenoh closes the channel once the query is finished and its answers read."""
        tokens = []
        try:
            while (reply := self._answers.try_recv()) is not None:
                if reply.ok is not None:
                    tokens.append(str(reply.ok.key_expr))
        except zenoh.ZError:
            return tokens, True
        return tokens, False


class ZenohBus:
    """``Bus`` over a Zenoh session."""

    def __init__(self, session: zenoh.Session) -> None:
        self._session = session

    def channel(self, key: str, depth: int) -> Channel:
        return self._session.declare_subscriber(key, zenoh.handlers.FifoChannel(depth))

    def subscribe(self, key: str, on_sample: Callable[[Sample], None]) -> Declared:
        return callback_subscriber(self._session, key, on_sample)

    def queryable(self, key: str, on_query: Callable[[Query], None]) -> Declared:
        def on_zenoh_query(query: zenoh.Query) -> None:
            on_query(_ZenohQuery(query))

        return self._session.declare_queryable(
            key, zenoh.handlers.Callback(on_zenoh_query, indirect=False)
        )

    def publisher(self, key: str, *, realtime: bool = False, latest: bool = False) -> Publication:
        return ZenohPublication(publisher(self._session, key, realtime=realtime, latest=latest))

    def doorbell(self, key: str) -> Doorbell:
        return ZenohDoorbell(self._session, key)

    def token_events(self, key: str, depth: int) -> TokenEvents:
        return self._session.liveliness().declare_subscriber(key, zenoh.handlers.FifoChannel(depth))

    def declared(self, event: TokenEvent) -> bool:
        return event.kind == zenoh.SampleKind.PUT

    def ask_tokens(self, key: str, depth: int, timeout: float) -> TokenAnswers:
        return _ZenohTokenAnswers(
            self._session.liveliness().get(key, zenoh.handlers.FifoChannel(depth), timeout=timeout)
        )

    def call(self, key: str, timeout: float) -> CommandReply | None:
        return call(self._session, key, timeout=timeout)
