"""Opening Zenoh sessions the same way in every process, and the small patterns all use.

Multicast scouting is always off: two cells (or two test runs) on one machine must never find
each other by accident (docs/topology.md). Processes meet through explicit endpoints instead: a
local cell's launcher runs a router on loopback that every service connects to; in containers
the services are clients of a zenohd router.
"""

from __future__ import annotations

import json
import logging
import re
import socket
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import msgspec
import zenoh

from motocell.shared.bus.credentials import Credentials
from motocell.shared.bus.liveness import QUERY_TIMEOUT_S, Presence
from motocell.shared.bus.schemas import CommandReply, CommandRequest, Decoder, encode

log = logging.getLogger(__name__)


LEASE_MS = 5000
"""Transport lease: how long a process may go unheard before its router closes its session and
deletes its liveliness tokens, which is when the cell counts it gone. A crash closes the socket
and is noticed in milliseconds whatever the lease (docs/liveness.md, section 1); the lease
only bounds how long a hung (stopped, starved) process passes for alive. Five times the stalls
a loaded host causes (docs/liveness.md, section 2); motion does not wait for it, the executor
bounds its own lateness (docs/liveness.md)."""
CONNECT_WAIT_S = 30.0
"""How long a service waits for its router to come up (compose starts them together)."""
CONNECT_RETRY_S = 0.2
REFUSED_GRACE_S = 2.0
"""How long a waiting service retries a router that accepts TCP but refuses the session."""
ENCODING = zenoh.Encoding("application/msgpack")
"""What every sample and reply of a cell carries: msgpack (schemas.py). Set on every put and
reply so Zenoh tools show the format rather than plain bytes; the payload type follows from
the key (catalog.py). Zenoh 1.x predefines no msgpack encoding (docs/payloads.md), so this is
its free-form MIME type (a few bytes more per sample)."""
BLOCK_WAIT_US = 500_000
"""A link whose queue stays full this long is closed: one stalled observer (a suspended
`motocell watch`, a slow callback) must not hold back the cell's BLOCK streams for Zenoh's
default 5 s."""
SHARED_MEMORY = False
"""Zenoh's shared-memory transport, off in every session and router of a cell. A cell's
payloads are small and go over loopback TCP (nothing here allocates from a shared-memory
provider), and with it on every session keeps a hand-off task that wakes its network thread
ten times a second for nothing: half of an idle cell's wake-ups and CPU (docs/timing.md,
"At rest")."""


def bus_config(
    mode: str = "client",
    connect: Sequence[str] = (),
    listen: Sequence[str] = (),
    *,
    credentials: Credentials | None = None,
) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("transport/link/tx/lease", str(LEASE_MS))
    config.insert_json5("transport/shared_memory/enabled", json.dumps(SHARED_MEMORY))
    config.insert_json5(
        "transport/link/tx/queue/congestion_control/block/wait_before_close", str(BLOCK_WAIT_US)
    )
    if mode == "client":
        # Fail at once and let open_session decide whether to try again: with Zenoh's own
        # endless retry a refused credential would look like a router that is not up yet.
        config.insert_json5("connect/timeout_ms", "0")
    if credentials is not None:
        _insert_credentials(config, credentials)
    return config


def _insert_credentials(config: zenoh.Config, credentials: Credentials) -> None:
    config.insert_json5("transport/auth/usrpwd/user", json.dumps(credentials.user))
    config.insert_json5("transport/auth/usrpwd/password", json.dumps(credentials.password))
    if credentials.ca is not None:
        config.insert_json5(
            "transport/link/tls/root_ca_certificate", json.dumps(str(credentials.ca))
        )
    if credentials.certificate is not None and credentials.key is not None:
        tls = {
            "enable_mtls": True,
            "connect_certificate": str(credentials.certificate),
            "connect_private_key": str(credentials.key),
        }
        for field, value in tls.items():
            config.insert_json5(f"transport/link/tls/{field}", json.dumps(value))


class NoRouterError(ConnectionError):
    """Nothing listens at the endpoints: no router there (yet), as opposed to one that
    refused the session."""


class StoppedWaiting(Exception):  # noqa: N818 (not an error: what the user asked)
    """A stop was asked while a start waited: ``open_session`` for its router, or a service
    before its claim (``running_service``)."""


def open_session(
    mode: str = "client",
    connect: Sequence[str] = (),
    listen: Sequence[str] = (),
    *,
    wait: bool = True,
    credentials: Credentials | None = None,
    stop: Callable[[float], bool] | None = None,
) -> zenoh.Session:
    """A session; ConnectionError with one line saying what to do when it cannot join
    (NoRouterError when nothing listens there).

    ``wait``: keep trying for CONNECT_WAIT_S while nothing listens at ``connect`` (a router
    starting alongside, as under compose). A router that is there but refuses us is answered
    soon: Zenoh reports both the same way, so a plain TCP probe tells them apart. A router
    that is still starting accepts TCP before it accepts sessions, so a waiting service gives
    a refusal REFUSED_GRACE_S before believing it. ``stop`` (``StopFlag.wait``) waits between
    tries, True when a stop was asked meanwhile: the wait then ends with StoppedWaiting, so a
    Ctrl-C does not wait for CONNECT_WAIT_S.
    """
    try:
        config = bus_config(mode, connect, listen, credentials=credentials)
    except zenoh.ZError as exc:
        raise ConnectionError(zenoh_problem(exc)) from None
    started = time.monotonic()
    refused_since: float | None = None
    told = False
    while True:
        try:
            return zenoh.open(config)
        except zenoh.ZError as exc:
            advice = _advice(exc)
            if advice is not None:
                # Not a router that is missing or refuses us: waiting would not help.
                raise ConnectionError(advice) from None
            now = time.monotonic()
            listening = [endpoint for endpoint in connect if _accepts(endpoint)]
            if listening:
                refused_since = now if refused_since is None else refused_since
                waited, limit = now - refused_since, REFUSED_GRACE_S
            else:
                waited, limit = now - started, CONNECT_WAIT_S
            if not wait or waited >= limit:
                error = ConnectionError if listening else NoRouterError
                raise error(_why_not(connect, listening, credentials)) from None
            if not listening and not told:
                told = True
                log.info("waiting up to %.0f s for a Zenoh router at %s", limit, ", ".join(connect))
            if stop is None:
                time.sleep(CONNECT_RETRY_S)
            elif stop(CONNECT_RETRY_S):
                raise StoppedWaiting from None


_RUST_SOURCE = re.compile(r"\s*\bat /\S+\.rs:\d+\.?")
"""Where in Zenoh's Rust source an error was made (` at /root/.cargo/git/checkouts/...
/orchestrator.rs:447.`): of use to Zenoh's developers, noise to a user."""
_JSON5_MESSAGE = re.compile(r'Json5Err\(Message \{ msg: "(.*)", location')
_EXPLANATIONS = (
    (
        re.compile(r"Endpoints must be of the form .*: (\S+)$"),
        "{0} is not a Zenoh endpoint: write tcp/HOST:PORT (tls/HOST:PORT on a TLS cell)",
    ),
    (re.compile(r"Address already in use"), "the port is taken by another process"),
    (
        re.compile(r"Cannot assign requested address"),
        "that address is not one of this machine's: use 127.0.0.1, 0.0.0.0 or an address of "
        "this host",
    ),
    (re.compile(r"invalid port value"), "a port is a number from 1 to 65535: tcp/HOST:PORT"),
    (re.compile(r"invalid socket address"), "write an endpoint as tcp/HOST:PORT"),
    (
        re.compile(r"Unicast not supported for (\S+) protocol"),
        "Zenoh has no protocol {0}: write tcp/HOST:PORT (tls/HOST:PORT on a TLS cell)",
    ),
    (
        re.compile(r"failed to lookup address"),
        "the host name does not resolve: check it, or give an IP address",
    ),
    (
        re.compile(r"--> (\d+):(\d+).*= (.*)", re.DOTALL),
        "not valid JSON5 at line {0}, column {1}: {2}",
    ),
)
"""What a user should do about the Zenoh errors a mistyped or taken endpoint gives."""


def zenoh_problem(error: zenoh.ZError) -> str:
    """One line for the user about ``error``: what to do when the cause is a known one (a
    taken port, a malformed endpoint), else Zenoh's own words without its source locations."""
    return _advice(error) or zenoh_reason(error)


def zenoh_reason(error: zenoh.ZError) -> str:
    """Zenoh's words for ``error``, without Rust source locations and parser wrappers."""
    text = _RUST_SOURCE.sub("", str(error)).strip()
    wrapped = _JSON5_MESSAGE.search(text)
    return wrapped.group(1) if wrapped else text


def _advice(error: zenoh.ZError) -> str | None:
    reason = zenoh_reason(error)
    for pattern, advice in _EXPLANATIONS:
        found = pattern.search(reason)
        if found:
            return advice.format(*found.groups())
    return None


def _accepts(endpoint: str) -> bool:
    """Something accepts TCP at a ``tcp/`` or ``tls/`` endpoint."""
    protocol, _, address = endpoint.partition("/")
    host, _, port = address.rpartition(":")
    if protocol not in ("tcp", "tls") or not port.isdigit():
        return False
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=1.0):
            return True
    except OSError:
        return False


def _why_not(
    connect: Sequence[str], listening: Sequence[str], credentials: Credentials | None
) -> str:
    if not listening:
        return (
            f"no Zenoh router answers at {', '.join(connect) or '(no endpoint)'}: is the cell "
            "running there? (`motocell ps` lists the cells on this machine)"
        )
    # ssl and the probe only once refused: nothing for a session that opens.
    from motocell.shared.bus.refusal import tls_problem  # noqa: PLC0415

    problem = tls_problem(listening[0], credentials)
    if problem is not None:
        return problem
    if credentials is None:
        return (
            f"the Zenoh router at {listening[0]} refused this session: it requires "
            "credentials (give the cell's credentials directory with --credentials DIR)"
        )
    return (
        f"the Zenoh router at {listening[0]} refused {credentials.user}: wrong password, or a "
        "user it does not know (a router reads its users at start: restart it after adding "
        "an identity). Use the credentials of the cell that runs there (`motocell up` writes "
        "new ones at every start; `motocell ps` shows each cell's)"
    )


def publisher(
    session: zenoh.Session, key: str, *, realtime: bool = False, latest: bool = False
) -> zenoh.Publisher:
    """Streams whose every sample matters (points, increments, status, slots, commands) block
    rather than drop: DROP loses data under load even on loopback (docs/payloads.md).
    ``latest`` streams (ticks, queue states, state, metrics) are superseded by the next sample
    within milliseconds, so they drop instead: a slow observer then loses samples, never
    stalls the cell."""
    congestion = zenoh.CongestionControl.DROP if latest else zenoh.CongestionControl.BLOCK
    return session.declare_publisher(
        key,
        encoding=ENCODING,
        congestion_control=congestion,
        priority=zenoh.Priority.REAL_TIME if realtime else zenoh.Priority.DATA,
    )


def observed(publisher: zenoh.Publisher) -> bool:
    """Whether any subscriber on the bus matches ``publisher``'s key now (well under a
    microsecond). zenoh's stubs type ``matching_status`` as a bool; 1.10.2 returns a
    ``MatchingStatus``, whose ``matching`` is the answer."""
    status: Any = publisher.matching_status
    return bool(status.matching)


_reply_decoder = Decoder(CommandReply)


def call(
    session: zenoh.Session,
    key: str,
    request: CommandRequest | None = None,
    timeout: float = 2.0,
) -> CommandReply | None:
    """One command query; ``None`` when nobody answered in time."""
    payload = encode(request or CommandRequest())
    for reply in session.get(key, payload=payload, encoding=ENCODING, timeout=timeout):
        if reply.ok is not None:
            try:
                return _reply_decoder.decode(reply.ok.payload.to_bytes())
            except msgspec.DecodeError:
                log.warning("undecodable reply on %s", key)
    return None


_request_decoder = Decoder(CommandRequest)


def command_of(query: zenoh.Query) -> CommandRequest:
    payload = query.payload
    if payload is None:
        return CommandRequest()
    return _request_decoder.decode(payload.to_bytes())


def answer(query: zenoh.Query, reply: CommandReply) -> None:
    """Reply and finalise the query at once: the asker's ``get`` ends only when the query is
    dropped, which a lingering Python reference would otherwise delay until its timeout."""
    query.reply(query.key_expr, encode(reply), encoding=ENCODING)
    query.drop()


class Liveness:
    """The liveliness tokens present under a key expression (``Presence``), current within
    milliseconds of a change, with no thread of its own: Zenoh's threads deliver the events
    and the answers, and only update ``Presence`` under a lock.

    The subscriber takes no history: a query (``ask``) asked after it is declared gives the
    tokens that were there before. With history a token's DELETE can arrive before its
    history PUT and leave a departed service present for good (docs/liveness.md). The owner
    asks once when it starts, and again only while it waits for a token it needs (a
    declaration the events might have missed), never periodically: a token that stays is news
    to nobody, and its DELETE is an event.
    """

    def __init__(
        self,
        session: zenoh.Session,
        key_expr: str,
        on_change: Callable[[], None] | None = None,
    ) -> None:
        """Declares the subscriber only; nothing is asked until ``ask``."""
        self._presence = Presence()
        self._lock = threading.Lock()
        self._on_change = on_change
        self._session = session
        self._key_expr = key_expr
        self._subscriber = session.liveliness().declare_subscriber(key_expr, self._on_sample)

    def ask(self, on_finished: Callable[[], None] | None = None) -> threading.Event:
        """Ask which tokens are there; returns at once, with an event set once the answers
        are in. They count when the query is finished (``Presence.on_answer``), and
        ``on_change`` runs if they found any new, then ``on_finished`` (on Zenoh's thread)."""
        with self._lock:
            asked = self._presence.asking()
        tokens: list[str] = []
        answered = threading.Event()

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                tokens.append(str(reply.ok.key_expr))

        def on_end() -> None:
            with self._lock:
                found = self._presence.on_answer(tokens, asked)
            if found and self._on_change is not None:
                self._on_change()
            if on_finished is not None:
                on_finished()
            answered.set()

        self._session.liveliness().get(
            self._key_expr,
            zenoh.handlers.Callback(on_reply, on_end),
            timeout=QUERY_TIMEOUT_S,
        )
        return answered

    def _on_sample(self, sample: zenoh.Sample) -> None:
        with self._lock:
            changed = self._presence.on_event(
                str(sample.key_expr), put=sample.kind == zenoh.SampleKind.PUT
            )
        if changed and self._on_change is not None:
            self._on_change()

    def present(self) -> frozenset[str]:
        with self._lock:
            return self._presence.present

    def take_departed(self) -> frozenset[str]:
        """``Presence.take_departed``: the tokens deleted since the last call."""
        with self._lock:
            return self._presence.take_departed()

    def close(self) -> None:
        self._subscriber.undeclare()
