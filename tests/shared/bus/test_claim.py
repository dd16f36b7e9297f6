"""Claiming a service name on a real router: refused when held, one winner of a race, and a
later clash noticed by the one that must give way."""

from __future__ import annotations

import threading

import pytest
import zenoh

from motocell.shared.bus.claim import NameTakenError, claim_name, watch_claims
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.session import open_session
from motocell.testkit.processes import wait_until

KEYS = CellKeys("c1")


def test_a_held_name_is_refused(endpoint: str) -> None:
    first, second = (open_session("client", [endpoint], wait=False) for _ in range(2))
    try:
        token = claim_name(first, KEYS, "gateway", "0")
        with pytest.raises(NameTakenError, match="a gateway of cell c1 is already running"):
            claim_name(second, KEYS, "gateway", "0")
        token.undeclare()
        taken_over: list[zenoh.LivelinessToken] = []

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


def test_of_simultaneous_claims_exactly_one_wins(endpoint: str) -> None:
    sessions = [open_session("client", [endpoint], wait=False) for _ in range(4)]
    outcomes: list[str] = []
    lock = threading.Lock()
    start = threading.Barrier(len(sessions))

    def claim(session: zenoh.Session) -> None:
        start.wait()
        try:
            claim_name(session, KEYS, "interpolator", "1")
            result = "won"
        except NameTakenError:
            result = "lost"
        with lock:
            outcomes.append(result)

    threads = [threading.Thread(target=claim, args=(s,)) for s in sessions]
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(10.0)
        assert sorted(outcomes) == ["lost", "lost", "lost", "won"]
    finally:
        for session in sessions:
            session.close()


def test_a_later_claim_with_a_lower_id_makes_the_holder_give_way(endpoint: str) -> None:
    holder, newcomer = (open_session("client", [endpoint], wait=False) for _ in range(2))
    clashes: list[str] = []
    try:
        token = claim_name(holder, KEYS, "executor", "0")
        watcher = watch_claims(holder, KEYS, "executor", "0", clashes.append)
        lower = newcomer.liveliness().declare_token(KEYS.claim("executor", "0", "0"))
        wait_until(lambda: bool(clashes), 5.0, "the holder to see the clash")
        assert "another executor of cell c1" in clashes[0]
        lower.undeclare()
        watcher.undeclare()
        token.undeclare()
    finally:
        holder.close()
        newcomer.close()
