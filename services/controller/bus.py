"""What the controller's loop needs of the bus (``ControllerBus``), and
``ZenohControllerBus``, the adapter over a Zenoh session.

The loop is written against the Protocol, so its unit tests script what arrives and read what
it published, asked and replied. The Zenoh side declares a queryable per verb and fault kind,
a subscriber per notice and one for the cell's liveliness tokens; their callbacks only decode
the payload into an item of ``inbox`` and queue it. The decoding (``command_arrival`` and its
siblings) takes bytes, so it is tested without a router.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import msgspec
import zenoh

from motocell.services.controller.core.dispatch import FaultKind, Verb
from motocell.services.controller.inbox import (
    Arrival,
    BadPayload,
    CommandQuery,
    ConnectionCounts,
    FaultQuery,
    Inbox,
    IncMoveError,
    ReplyTo,
    Stop,
    TokensAnswered,
    TokensChanged,
)
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import (
    CommandReply,
    CommandRequest,
    ControllerStatus,
    Decoder,
    encode,
)
from motocell.shared.bus.session import Liveness, answer, publisher
from motocell.shared.config import Cell
from motocell.shared.service import required_alive_keys

CONNECTIONS = "connections"
"""The notice key (after ``controller/cmd/``) of the client counts."""
INCMOVE_ERROR = "incmove_error"
"""The notice key (after ``controller/cmd/``) of the executor's stopped motion."""

_request_decoder = Decoder(CommandRequest)
_notice_decoder = Decoder(CommandReply)


class ControllerBus(Protocol):
    def wait(self, timeout: float) -> Arrival | None:
        """The next arrival, waiting up to ``timeout`` s for one; None if none came."""
        ...

    def poll(self) -> Arrival | None:
        """The next arrival if one is there; never blocks."""
        ...

    def stop_waiting(self) -> None:
        """Deliver ``Stop``, so that a ``wait`` ends at once; from any thread."""
        ...

    def publish(self, status: ControllerStatus) -> None: ...

    def ask_tokens(self) -> None:
        """Ask which liveliness tokens are there; returns at once. What the answers find
        arrives as ``TokensChanged``, the question's end as ``TokensAnswered``."""
        ...

    def tokens_present(self) -> frozenset[str]:
        """The cell's liveliness tokens present now."""
        ...

    def tokens_departed(self) -> frozenset[str]:
        """The tokens deleted since the last call, back since or not."""
        ...


def others_alive_keys(cell: Cell, keys: CellKeys) -> list[str]:
    """The liveliness tokens of the services the controller waits for: all the cell's but
    its own."""
    own = keys.alive("controller", "0")
    return [key for key in required_alive_keys(cell) if key != own]


def not_on_its_key(name: str, asked_on: str, own_key: str, reply_to: ReplyTo) -> Arrival | None:
    """A bad request when a command or fault was asked on any key but its own: a query on a
    wildcard (``controller/cmd/*``) reaches every verb's queryable, and obeying it would run
    every command at once with one payload. None when it was asked on its own key."""
    if asked_on == own_key:
        return None
    return BadPayload(name, f"asked on {asked_on}: ask a command on its own key", reply_to)


def command_arrival(verb: Verb, payload: bytes | None, reply_to: ReplyTo) -> Arrival:
    """A command query, its payload decoded (none is an empty request)."""
    try:
        request = _request(payload)
    except msgspec.DecodeError as error:
        return BadPayload(f"cmd/{verb}", str(error), reply_to)
    return CommandQuery(verb, request, reply_to)


def fault_arrival(kind: FaultKind, payload: bytes | None, reply_to: ReplyTo) -> Arrival:
    """A fault query, its payload decoded (none is an empty request)."""
    try:
        request = _request(payload)
    except msgspec.DecodeError as error:
        return BadPayload(f"fault/{kind}", str(error), reply_to)
    return FaultQuery(kind, request, reply_to)


def connections_arrival(payload: bytes) -> Arrival:
    try:
        return ConnectionCounts(_request_decoder.decode(payload))
    except msgspec.DecodeError as error:
        return BadPayload(CONNECTIONS, str(error), None)


def incmove_error_arrival(payload: bytes) -> Arrival:
    try:
        return IncMoveError(_notice_decoder.decode(payload))
    except msgspec.DecodeError as error:
        return BadPayload(INCMOVE_ERROR, str(error), None)


def _request(payload: bytes | None) -> CommandRequest:
    return CommandRequest() if payload is None else _request_decoder.decode(payload)


class _QueryReplyTo:
    """A Zenoh query as ``ReplyTo``."""

    __slots__ = ("_query",)

    def __init__(self, query: zenoh.Query) -> None:
        self._query = query

    def send(self, reply: CommandReply) -> None:
        answer(self._query, reply)


def _payload_of(query: zenoh.Query) -> bytes | None:
    payload = query.payload
    return None if payload is None else payload.to_bytes()


class ZenohControllerBus:
    """``ControllerBus`` over a Zenoh session. Everything is declared here; nothing is asked
    until ``ask_tokens``."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self._inbox = Inbox()
        self._status = publisher(session, keys.controller_status, realtime=True)
        self._tokens = Liveness(session, keys.alive_all, self._tokens_changed)
        self._declared: list[object] = [
            session.declare_queryable(
                keys.controller_cmd(verb), self._on_command(verb, keys.controller_cmd(verb))
            )
            for verb in Verb
        ]
        self._declared += [
            session.declare_queryable(
                keys.controller_fault(kind), self._on_fault(kind, keys.controller_fault(kind))
            )
            for kind in FaultKind
        ]
        self._declared += [
            session.declare_subscriber(keys.controller_cmd(CONNECTIONS), self._on_connections),
            session.declare_subscriber(keys.controller_cmd(INCMOVE_ERROR), self._on_incmove_error),
        ]

    # -- ControllerBus ---------------------------------------------------------------------
    def wait(self, timeout: float) -> Arrival | None:
        return self._inbox.get(timeout)

    def poll(self) -> Arrival | None:
        return self._inbox.get_nowait()

    def stop_waiting(self) -> None:
        self._inbox.put(Stop())

    def publish(self, status: ControllerStatus) -> None:
        self._status.put(encode(status))

    def ask_tokens(self) -> None:
        self._tokens.ask(on_finished=self._tokens_answered)

    def tokens_present(self) -> frozenset[str]:
        return self._tokens.present()

    def tokens_departed(self) -> frozenset[str]:
        return self._tokens.take_departed()

    # -- Zenoh's callbacks: decode and queue, nothing else ---------------------------------
    def _on_command(self, verb: Verb, key: str) -> Callable[[zenoh.Query], None]:
        def on_query(query: zenoh.Query) -> None:
            reply_to = _QueryReplyTo(query)
            self._inbox.offer(
                not_on_its_key(f"cmd/{verb}", str(query.key_expr), key, reply_to)
                or command_arrival(verb, _payload_of(query), reply_to)
            )

        return on_query

    def _on_fault(self, kind: FaultKind, key: str) -> Callable[[zenoh.Query], None]:
        def on_query(query: zenoh.Query) -> None:
            reply_to = _QueryReplyTo(query)
            self._inbox.offer(
                not_on_its_key(f"fault/{kind}", str(query.key_expr), key, reply_to)
                or fault_arrival(kind, _payload_of(query), reply_to)
            )

        return on_query

    def _on_connections(self, sample: zenoh.Sample) -> None:
        self._inbox.offer(connections_arrival(sample.payload.to_bytes()))

    def _on_incmove_error(self, sample: zenoh.Sample) -> None:
        self._inbox.offer(incmove_error_arrival(sample.payload.to_bytes()))

    def _tokens_changed(self) -> None:
        self._inbox.put(TokensChanged())

    def _tokens_answered(self) -> None:
        self._inbox.put(TokensAnswered())
