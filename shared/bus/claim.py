"""One process per service name on a cell's bus: a liveliness claim, final once settled.

A claim is a liveliness token ``@motocell/<cell>/claim/<service>/<instance>/<chunk>``. Its last
chunk is the claimant's Zenoh session id while it settles (a bid), and a second token adds
the id with ``.held`` once it holds the name. The rules (docs/topology.md, "One process per
service name"):

1. A start that finds any claim on its name is refused; so is one whose look-up the router
   leaves unanswered: "no answer" is never read as "no claim".
2. Only starts that both found none (truly simultaneous) settle it among themselves: each bids,
   waits ``SETTLE_S`` and loses to any held claim or a lower id's bid; the winner marks its
   claim held, waits again and withdraws if a lower id's held claim appeared meanwhile (two
   bids that crossed on the way to the router). Without settling, simultaneous starts can
   end with two winners (measured: docs/topology.md).
3. A held claim is final: its holder never gives way to a claim that appears later, however
   low its id (a second start whose look-up was slow, a token anyone with the password
   declares). It logs it and keeps running.
4. A holder that lost its router has been apart from the cell: whoever claimed the name
   meanwhile has been driving. It gives way to a held claim it finds there while it is apart
   or within ``REJOIN_S`` of being back; after that its claim is final again. A claimant it
   saw while it held the name with its router lost then, and stays lost: its claim, sent
   anew when the router comes back, is not one made meanwhile.
5. A token whose last chunk is no Zenoh session id was declared by hand: no claim at all.
6. A start that no other is expected to overlap, the first start of a launcher's services on
   the secured router it has just opened (``sole``), declares its bid and hold at once and
   looks up once more instead of settling: any other claim then found, and it withdraws.
"""

from __future__ import annotations

import logging
import re
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import zenoh

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, ServiceInfo
from motocell.shared.service_names import PER_GROUP

SETTLE_S = 0.05
"""How long a bid, then a fresh hold, waits for simultaneous claims to reach it (rule 2)."""
QUERY_TIMEOUT_S = 1.0
"""One look-up's bound; the router answers from its own token table within milliseconds."""
LOOKUP_DEADLINE_S = 5.0
"""How long a start asks again when the router leaves a look-up unanswered (a starved
process or router) before it is refused: the bound on each of a claim's three look-ups."""
REJOIN_S = 1.0
"""After its router comes back, how long a holder takes a held claim it finds as one made
while it was apart (rule 4): the router sends the claims it holds when the subscription is
declared again, within milliseconds."""
HELD = ".held"
SESSION_ID = re.compile(r"[1-9a-f][0-9a-f]{0,31}")
"""What Zenoh accepts as a session id: lowercase hex, no leading zero, at most 128 bits."""
MAX_LOSERS = 256
"""How many claimants a holder remembers as lost (rule 4). More than that on one name is a
flood of forged tokens: the holder then never gives way, which keeps a running cell whole
(docs/topology.md)."""
ZENOH_TIMEOUT = "Timeout"
"""The error reply Zenoh gives a query that ran out of time (whatever came before it is not
all there is)."""

log = logging.getLogger(__name__)
_info_decoder = Decoder(ServiceInfo)


class ClaimError(Exception):
    """The service cannot have its name; the message is one line saying why."""


class NameTakenError(ClaimError):
    """Another process holds, or is claiming, this service name on the cell's bus."""


class ClaimLookupError(ClaimError):
    """The look-up for claims failed, or the router left it unanswered for LOOKUP_DEADLINE_S."""


@dataclass(frozen=True)
class Claim:
    """One claim token: whose (a Zenoh session id) and whether it holds the name."""

    session: str
    held: bool

    @classmethod
    def from_key(cls, key: str) -> Claim:
        chunk = key.rsplit("/", 1)[-1]
        return cls(chunk.removesuffix(HELD), chunk.endswith(HELD))

    @property
    def chunk(self) -> str:
        return self.session + (HELD if self.held else "")

    @property
    def possible(self) -> bool:
        """Whether a claimant could have declared it: ``claim_name`` names its session's id;
        anything else was declared by hand (rule 5)."""
        return SESSION_ID.fullmatch(self.session) is not None


def rival_of_bid(own: str, claims: Iterable[Claim]) -> Claim | None:
    """What a settled bid of session ``own`` loses to (rule 2): another session's held claim,
    else a lower id's bid; None: the bid wins."""
    others = [claim for claim in claims if claim.session != own]
    held = [claim for claim in others if claim.held]
    lower = [claim for claim in others if claim.session < own]
    return min(held or lower, key=lambda claim: claim.session, default=None)


def rival_of_hold(own: str, claims: Iterable[Claim]) -> Claim | None:
    """What a fresh hold of session ``own`` withdraws for after settling (rule 2): a lower
    id's held claim, from a bid that crossed its own; None: the claim is final."""
    crossed = [c for c in claims if c.held and c.session != own and c.session < own]
    return min(crossed, key=lambda claim: claim.session, default=None)


def rival_of_sole(own: str, claims: Iterable[Claim]) -> Claim | None:
    """What a sole claim withdraws for, looked up after its own tokens (rule 6): any other
    session's claim, bid or hold. Its tokens went to the router before that look-up, on the
    same link; so of two starts that both found the name free, the one whose look-up the router
    answers second sees the other's and withdraws, sole or settling; both may withdraw."""
    others = [claim for claim in claims if claim.session != own]
    return min(others, key=lambda claim: claim.session, default=None)


_STAGES = ((False, rival_of_bid), (True, rival_of_hold))
"""A claim's two steps: bid, then hold; each settles and looks for what it loses to."""


class Standing:
    """Whether a holder must give way to a held claim it sees appear (rules 3 to 5): only
    while none of its routers is connected, or within REJOIN_S of one connecting again, and
    only to a claimant it has not seen lose. Fed from Zenoh's threads, so its state is behind
    a lock; times are monotonic seconds."""

    def __init__(self) -> None:
        self._routers: set[str] = set()
        self._apart = False
        self._back_at: float | None = None
        self._losers: set[str] = set()
        self._too_many = False
        self._lock = threading.Lock()

    def router_up(self, router: str, now: float) -> None:
        with self._lock:
            self._routers.add(router)
            if self._apart:
                self._apart, self._back_at = False, now

    def router_down(self, router: str) -> None:
        with self._lock:
            self._routers.discard(router)
            self._apart = not self._routers

    def gives_way_to(self, claim: Claim, own: str, now: float) -> bool:
        """Whether ``claim``, just seen, takes the name from this holder. A claimant seen
        while the holder has its router has lost (rule 3) and is remembered as such: a
        router that comes back sends every claim anew, and an old one must not pass for one
        made meanwhile (rule 4)."""
        if not claim.possible or claim.session == own:
            return False
        with self._lock:
            if self._too_many or claim.session in self._losers:
                return False
            rejoining = self._back_at is not None and now - self._back_at <= REJOIN_S
            if self._apart or rejoining:
                return claim.held
            if len(self._losers) < MAX_LOSERS:
                self._losers.add(claim.session)
            else:
                self._too_many = True
            return False


class HeldName:
    """A claim that holds the name: its bid and held tokens, for as long as the service runs."""

    def __init__(self, tokens: list[zenoh.LivelinessToken]) -> None:
        self._tokens = tokens

    def undeclare(self) -> None:
        for token in reversed(self._tokens):
            token.undeclare()


def claim_name(
    session: zenoh.Session, keys: CellKeys, service: str, instance: str, *, sole: bool = False
) -> HeldName:
    """The name held for this session (rules 1 and 2); ClaimError if it cannot be. ``sole``:
    no other start is expected to overlap this one (rule 6), so its bid and hold go out at
    once and one look-up after them stands for the settles: 1 ms instead of 100."""
    own = str(session.info.zid())
    found = _claims(session, keys, service, instance, first=True)
    if found:
        raise NameTakenError(_taken(session, keys, service, instance, found))
    tokens: list[zenoh.LivelinessToken] = []
    try:
        for held, rival_of in _STAGES:
            chunk = Claim(own, held).chunk
            tokens.append(session.liveliness().declare_token(keys.claim(service, instance, chunk)))
            if sole:
                continue
            time.sleep(SETTLE_S)
            rival = rival_of(own, _claims(session, keys, service, instance))
            if rival is not None:
                raise NameTakenError(_taken(session, keys, service, instance, [rival]))
        if sole:
            rival = rival_of_sole(own, _claims(session, keys, service, instance))
            if rival is not None:
                raise NameTakenError(_taken(session, keys, service, instance, [rival]))
    except BaseException:
        HeldName(tokens).undeclare()
        raise
    return HeldName(tokens)


class ClaimWatch:
    """What ``watch_claims`` declared: the claims' subscriber and the router events' listener."""

    def __init__(self, undeclare: list[Callable[[], None]]) -> None:
        self._undeclare = undeclare

    def undeclare(self) -> None:
        for step in self._undeclare:
            step()


def watch_claims(
    session: zenoh.Session,
    keys: CellKeys,
    service: str,
    instance: str,
    on_clash: Callable[[str], None],
) -> ClaimWatch:
    """Calls ``on_clash`` (on a Zenoh thread) when this holder must give way (rule 4): a held
    claim of another session found while apart from its routers or just back. Any other claim
    that appears is logged and changes nothing (rule 3)."""
    own = str(session.info.zid())
    standing = Standing()
    name = _name(service, instance)

    def transport(event: zenoh.TransportEvent) -> None:
        if event.transport.whatami != zenoh.WhatAmI.ROUTER:
            return
        router = str(event.transport.zid)
        if event.kind == zenoh.SampleKind.PUT:
            standing.router_up(router, time.monotonic())
        else:
            standing.router_down(router)
            log.info(
                "lost router %s: this %s gives way if its name is taken meanwhile", router, name
            )

    def seen(sample: zenoh.Sample) -> None:
        claim = Claim.from_key(str(sample.key_expr))
        if sample.kind != zenoh.SampleKind.PUT or claim.session == own:
            return
        if standing.gives_way_to(claim, own, time.monotonic()):
            on_clash(
                f"while this {name} was apart from its router, another (session "
                f"{claim.session}) took the name of cell {keys.cell}"
            )
        else:
            log.warning(
                "a later claim on %s of cell %s (session %s) is ignored: this one holds it",
                name,
                keys.cell,
                claim.session,
            )

    listener = session.info.declare_transport_events_listener(transport, history=True)
    # With history: a claim declared while this subscription is on its way is reported too.
    subscriber = session.liveliness().declare_subscriber(
        keys.claims(service, instance), seen, history=True
    )
    return ClaimWatch([subscriber.undeclare, listener.undeclare])


def _name(service: str, instance: str) -> str:
    """As an operator names it: the gateway, interpolator/1."""
    return f"{service}/{instance}" if service == PER_GROUP else service


def _claims(
    session: zenoh.Session, keys: CellKeys, service: str, instance: str, *, first: bool = False
) -> list[Claim]:
    """Every claim on the name, from a look-up the router answered in full (rule 1); a token
    no claimant could have declared is none (rule 5), said once, in the ``first`` look-up."""
    name = _name(service, instance)
    deadline = time.monotonic() + LOOKUP_DEADLINE_S
    while True:
        key = keys.claims(service, instance)
        replies = list(session.liveliness().get(key, timeout=QUERY_TIMEOUT_S))
        errors = [reply.err.payload.to_string() for reply in replies if reply.err]
        if not errors:
            found = [Claim.from_key(str(reply.ok.key_expr)) for reply in replies if reply.ok]
            for claim in found:
                if first and not claim.possible:
                    log.warning(
                        "a token on the claim of %s of cell %s names no Zenoh session (%s): "
                        "declared by hand, it is ignored",
                        name,
                        keys.cell,
                        claim.chunk,
                    )
            return [claim for claim in found if claim.possible]
        if any(error != ZENOH_TIMEOUT for error in errors):
            raise ClaimLookupError(f"cannot look up the claims on {name}: {errors[0]}")
        if time.monotonic() >= deadline:
            raise ClaimLookupError(
                f"cannot tell whether another {name} of cell {keys.cell} runs: its router left "
                f"the look-up unanswered for {LOOKUP_DEADLINE_S:.0f} s; start it again once "
                "the router's host is less busy"
            )


def _taken(
    session: zenoh.Session, keys: CellKeys, service: str, instance: str, claims: list[Claim]
) -> str:
    """Who holds the name: the host and pid its info queryable gives, else the session that
    claims it and what that can be."""
    name = _name(service, instance)
    article = "an" if name[0] in "aeiou" else "a"
    holder = f"{article} {name} of cell {keys.cell} is already running on this Zenoh network"
    for reply in session.get(keys.service_info(service, instance), timeout=QUERY_TIMEOUT_S):
        if reply.ok:
            info = _info_decoder.decode(reply.ok.payload.to_bytes())
            return f"{holder} (host {info.host}, pid {info.pid})"
    claimant = min(claims, key=lambda claim: (not claim.held, claim.session))
    return (
        f"{holder} as session {claimant.session}, which does not answer (still starting, "
        f"stopped, or a claim token declared with the {name}'s credentials): stop that "
        "process or session, or give this cell another name"
    )
