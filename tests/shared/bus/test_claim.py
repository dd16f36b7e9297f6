"""Claiming a service name on a real router: refused when held or when the router does not
answer, one winner of a race, a holder that never gives way while it keeps its router, and one
that was cut off giving way to the one that claimed the name meanwhile (docs/topology.md, One
process per service name)."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator
from types import SimpleNamespace

import pytest
import zenoh

from motocell.shared.bus import claim
from motocell.shared.bus.claim import (
    ClaimLookupError,
    NameTakenError,
    claim_name,
    watch_claims,
)
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.session import open_session
from motocell.testing.processes import wait_until
from tests.shared.bus.relay import Mode, Relay, wait_for_connections

KEYS = CellKeys("c1")
SEEN_TIMEOUT_S = 10.0
"""A deadline for a hang: a claim reaches a watcher within milliseconds."""
REJOIN_TIMEOUT_S = 20.0
"""A Zenoh client tries its router again about once a second; generous for a loaded host."""


@pytest.fixture
def relay(endpoint: str) -> Iterator[Relay]:
    relay = Relay(endpoint)
    yield relay
    relay.close()


def ignored(caplog: pytest.LogCaptureFixture, session: str) -> bool:
    """Whether a holder logged that it ignores the claim of ``session``."""
    return any(
        "is ignored" in record.getMessage() and f"(session {session})" in record.getMessage()
        for record in caplog.records
    )


def test_a_held_name_is_refused(endpoint: str) -> None:
    first, second = (open_session("client", [endpoint], wait=False) for _ in range(2))
    try:
        held = claim_name(first, KEYS, "gateway", "0")
        with pytest.raises(NameTakenError, match="a gateway of cell c1 is already running"):
            claim_name(second, KEYS, "gateway", "0")
        held.undeclare()
        taken_over: list[claim.HeldName] = []

        def free_again() -> bool:
            # The undeclaration travels through the router: the name is free a moment later.
            try:
                taken_over.append(claim_name(second, KEYS, "gateway", "0"))
            except NameTakenError:
                return False
            return True

        wait_until(free_again, 5.0, "the released name to be claimable")
        taken_over[0].undeclare()
    finally:
        first.close()
        second.close()


def claimed_at_once(
    sessions: list[zenoh.Session],
    claim_with: Callable[[zenoh.Session], claim.HeldName],
    timeout: float,
) -> list[claim.HeldName | None]:
    """Each session's claim, all let go at once: for each that ended within ``timeout``, the
    name it holds, or None where it was refused."""
    outcomes: list[claim.HeldName | None] = []
    lock = threading.Lock()
    start = threading.Barrier(len(sessions))

    def race(session: zenoh.Session) -> None:
        start.wait()
        try:
            held: claim.HeldName | None = claim_with(session)
        except NameTakenError:
            held = None
        with lock:
            outcomes.append(held)

    threads = [threading.Thread(target=race, args=(session,)) for session in sessions]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout)
    return outcomes


def test_of_simultaneous_claims_exactly_one_wins(endpoint: str) -> None:
    sessions = [open_session("client", [endpoint], wait=False) for _ in range(4)]
    try:
        outcomes = claimed_at_once(
            sessions, lambda session: claim_name(session, KEYS, "interpolator", "1"), 10.0
        )
        results = ["lost" if held is None else "won" for held in outcomes]
        assert sorted(results) == ["lost", "lost", "lost", "won"]
    finally:
        for session in sessions:
            session.close()


def test_a_sole_claim_holds_without_settling_and_is_refused_when_the_name_is_held(
    endpoint: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    settled: list[float] = []
    # The claim module's clock only: the test's own waits still sleep.
    clock = SimpleNamespace(monotonic=time.monotonic, sleep=settled.append)
    monkeypatch.setattr("motocell.shared.bus.claim.time", clock)
    first, second, third = (open_session("client", [endpoint], wait=False) for _ in range(3))
    try:
        held = claim_name(first, KEYS, "gateway", "0", sole=True)
        assert settled == []
        # Its bid and hold reach the bus as a settled claim's do: a later start is refused.
        own = str(first.info.zid())
        wait_until(
            lambda: (
                sorted(c.chunk for c in claim._claims(second, KEYS, "gateway", "0"))
                == [own, own + claim.HELD]
            ),
            SEEN_TIMEOUT_S,
            "the sole claim's bid and hold on the router",
        )
        with pytest.raises(NameTakenError, match="a gateway of cell c1 is already running"):
            claim_name(second, KEYS, "gateway", "0", sole=True)
        with pytest.raises(NameTakenError, match="a gateway of cell c1 is already running"):
            claim_name(third, KEYS, "gateway", "0")
        held.undeclare()
    finally:
        for session in (first, second, third):
            session.close()


def after_first_look_up(
    monkeypatch: pytest.MonkeyPatch, session: zenoh.Session, then: Callable[[], None]
) -> None:
    """``then`` as soon as ``session``'s claim has made its first look-up: a start held up
    between that look-up and its tokens, played without timing. Other look-ups pass."""
    looked_up = claim._claims

    def intercepted(
        asking: zenoh.Session, keys: CellKeys, service: str, instance: str, *, first: bool = False
    ) -> list[claim.Claim]:
        found = looked_up(asking, keys, service, instance, first=first)
        if asking is session and first:
            then()
        return found

    monkeypatch.setattr(claim, "_claims", intercepted)


def test_a_start_that_slipped_past_a_sole_claims_look_up_loses_to_its_hold(
    endpoint: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    rival, sole, onlooker = (open_session("client", [endpoint], wait=False) for _ in range(3))
    holds: list[claim.HeldName] = []

    def the_sole_one_holds() -> None:  # the rival found the name free
        holds.append(claim_name(sole, KEYS, "executor", "0", sole=True))
        wait_until(  # on the router before the rival bids: the crossing, not its timing
            lambda: len(claim._claims(onlooker, KEYS, "executor", "0")) == 2,
            SEEN_TIMEOUT_S,
            "the sole claim's hold on the router",
        )

    after_first_look_up(monkeypatch, rival, the_sole_one_holds)
    try:
        with pytest.raises(NameTakenError, match="an executor of cell c1 is already running"):
            claim_name(rival, KEYS, "executor", "0")
        assert len(holds) == 1
        holds[0].undeclare()
    finally:
        for session in (rival, sole, onlooker):
            session.close()


def test_a_sole_start_that_a_settled_claim_overtook_after_its_look_up_withdraws(
    endpoint: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The sole start found the name free, then was held up (descheduled) while a settling
    start claimed it in full: its look-up after its own tokens finds the winner."""
    sole, rival, onlooker = (open_session("client", [endpoint], wait=False) for _ in range(3))
    holds: list[claim.HeldName] = []
    after_first_look_up(
        monkeypatch, sole, lambda: holds.append(claim_name(rival, KEYS, "gateway", "0"))
    )
    try:
        with pytest.raises(NameTakenError, match="a gateway of cell c1 is already running"):
            claim_name(sole, KEYS, "gateway", "0", sole=True)
        assert len(holds) == 1, "the settling start holds"
        rival_id = str(rival.info.zid())
        wait_until(  # the withdrawn tokens leave the router: one holder remains
            lambda: (
                {c.session for c in claim._claims(onlooker, KEYS, "gateway", "0")} == {rival_id}
            ),
            SEEN_TIMEOUT_S,
            "the sole start's tokens gone",
        )
        holds[0].undeclare()
    finally:
        for session in (sole, rival, onlooker):
            session.close()


def holders_of_a_sole_race(endpoint: str, instance: str, starts: int = 4) -> int:
    """How many of ``starts`` sole claims made at once hold the name."""
    sessions = [open_session("client", [endpoint], wait=False) for _ in range(starts)]
    holds: list[claim.HeldName] = []
    try:
        outcomes = claimed_at_once(
            sessions,
            lambda session: claim_name(session, KEYS, "interpolator", instance, sole=True),
            SEEN_TIMEOUT_S,
        )
        holds = [held for held in outcomes if held is not None]
        return len(holds)
    finally:
        for held in holds:
            held.undeclare()
        for session in sessions:
            session.close()


def test_of_sole_starts_at_once_at_most_one_holds(
    endpoint: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Rule 6's look-up alone, with no settle to hide behind: rounds of four."""
    # Bounds the losers' question to the holder, which has no service_info to answer.
    monkeypatch.setattr(claim, "QUERY_TIMEOUT_S", 0.2)
    for round_ in range(3):
        assert holders_of_a_sole_race(endpoint, str(round_)) <= 1, f"round {round_}"


def test_a_holder_never_gives_way_to_a_later_claim_however_low_its_id(
    endpoint: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger=claim.__name__)
    holder, newcomer = (open_session("client", [endpoint], wait=False) for _ in range(2))
    clashes: list[str] = []
    try:
        held = claim_name(holder, KEYS, "executor", "0")
        watcher = watch_claims(holder, KEYS, "executor", "0", clashes.append)
        forged = [
            newcomer.liveliness().declare_token(KEYS.claim("executor", "0", chunk))
            for chunk in ("0", "0.held")
        ]
        wait_until(lambda: ignored(caplog, "0"), SEEN_TIMEOUT_S, "the holder to see the claims")
        assert clashes == []
        for token in forged:
            token.undeclare()
        watcher.undeclare()
        held.undeclare()
    finally:
        holder.close()
        newcomer.close()


def test_an_unanswered_look_up_is_refused_not_read_as_no_claim(
    endpoint: str, relay: Relay, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(claim, "QUERY_TIMEOUT_S", 0.2)
    monkeypatch.setattr(claim, "LOOKUP_DEADLINE_S", 0.5)
    session = open_session("client", [relay.endpoint], wait=False)
    try:
        relay.set_mode(Mode.FROZEN)
        with pytest.raises(ClaimLookupError, match="left the look-up unanswered"):
            claim_name(session, KEYS, "gateway", "0")
        relay.set_mode(Mode.OPEN)
    finally:
        session.close()


@pytest.mark.cell  # waits for Zenoh to rejoin the router: tests/lanes.py
def test_a_holder_cut_off_gives_way_to_the_one_that_claimed_meanwhile(
    endpoint: str, relay: Relay, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger=claim.__name__)
    apart = open_session("client", [relay.endpoint], wait=False)
    stayed = open_session("client", [endpoint], wait=False)
    apart_clashes: list[str] = []
    stayed_clashes: list[str] = []
    try:
        apart_held = claim_name(apart, KEYS, "gateway", "0")
        apart_watch = watch_claims(apart, KEYS, "gateway", "0", apart_clashes.append)
        relay.set_mode(Mode.CUT)
        wait_until(
            lambda: not claim._claims(stayed, KEYS, "gateway", "0"),
            SEEN_TIMEOUT_S,
            "the router to drop the cut-off holder's claim",
        )
        stayed_held = claim_name(stayed, KEYS, "gateway", "0")
        stayed_watch = watch_claims(stayed, KEYS, "gateway", "0", stayed_clashes.append)
        relay.set_mode(Mode.OPEN)
        wait_for_connections(relay, 1, REJOIN_TIMEOUT_S)
        wait_until(lambda: bool(apart_clashes), REJOIN_TIMEOUT_S, "the cut-off one to give way")
        assert "while this gateway was apart from its router" in apart_clashes[0]
        apart_id = str(apart.info.zid())
        wait_until(lambda: ignored(caplog, apart_id), SEEN_TIMEOUT_S, "the holder to see it")
        assert stayed_clashes == []
        for undeclare in (apart_watch, apart_held, stayed_watch, stayed_held):
            undeclare.undeclare()
    finally:
        apart.close()
        stayed.close()
