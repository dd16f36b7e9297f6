"""The claim's rules without a bus (shared/bus/claim.py): what a bid and a fresh hold lose to,
and when a holder gives way."""

from __future__ import annotations

import pytest

from motocell.shared.bus.claim import (
    MAX_LOSERS,
    REJOIN_S,
    Claim,
    Standing,
    rival_of_bid,
    rival_of_hold,
)

OWN = "5"


def bid(session: str) -> Claim:
    return Claim(session, held=False)


def held(session: str) -> Claim:
    return Claim(session, held=True)


@pytest.mark.parametrize(
    ("session", "possible"),
    [
        ("ab12", True),
        ("1", True),
        ("f" * 32, True),
        ("0", False),
        ("0ab", False),
        ("AB12", False),
        ("f" * 33, False),
        ("", False),
        ("x", False),
    ],
)
def test_a_claim_names_a_zenoh_session_or_was_declared_by_hand(
    session: str, possible: bool
) -> None:
    assert held(session).possible is possible


def test_a_token_declared_by_hand_is_never_given_way_to() -> None:
    standing = Standing()
    standing.router_up("r1", 0.0)
    standing.router_down("r1")
    assert not standing.gives_way_to(held("0"), OWN, 1.0)
    standing.router_up("r1", 2.0)
    assert not standing.gives_way_to(held("0"), OWN, 2.5)


def test_a_claimant_seen_losing_never_wins_after_an_outage() -> None:
    standing = Standing()
    standing.router_up("r1", 0.0)
    assert not standing.gives_way_to(held("9"), OWN, 1.0)
    assert not standing.gives_way_to(bid("7"), OWN, 1.0)
    standing.router_down("r1")
    assert not standing.gives_way_to(held("9"), OWN, 2.0)
    standing.router_up("r1", 3.0)
    for session in ("9", "7"):
        assert not standing.gives_way_to(held(session), OWN, 3.1)
    assert standing.gives_way_to(held("8"), OWN, 3.1)


def test_a_claimant_first_seen_while_rejoining_is_not_taken_for_a_loser() -> None:
    """A start made while the holder was apart bids before it holds: its bid, seen in the
    rejoin window, must not make its hold look like a loser's."""
    standing = Standing()
    standing.router_up("r1", 0.0)
    standing.router_down("r1")
    standing.router_up("r1", 10.0)
    assert not standing.gives_way_to(bid("8"), OWN, 10.1)
    assert standing.gives_way_to(held("8"), OWN, 10.2)


def test_past_so_many_losers_a_holder_never_gives_way() -> None:
    standing = Standing()
    standing.router_up("r1", 0.0)
    for number in range(1, MAX_LOSERS + 2):
        assert not standing.gives_way_to(held(f"a{number:x}"), OWN, 1.0)
    standing.router_down("r1")
    assert not standing.gives_way_to(held("bcdef"), OWN, 2.0)


def test_a_claim_is_read_from_its_key_and_written_back() -> None:
    assert Claim.from_key("@motocell/c/claim/gateway/0/ab12") == bid("ab12")
    assert Claim.from_key("@motocell/c/claim/gateway/0/ab12.held") == held("ab12")
    assert held("ab12").chunk == "ab12.held"
    assert bid("ab12").chunk == "ab12"


@pytest.mark.parametrize(
    ("claims", "rival"),
    [
        ([bid(OWN)], None),
        ([bid(OWN), bid("7")], None),
        ([bid(OWN), bid("3")], bid("3")),
        ([bid(OWN), bid("3"), bid("1")], bid("1")),
        ([bid(OWN), bid("7"), held("7")], held("7")),
        ([bid(OWN), bid("3"), held("9")], held("9")),
        ([bid(OWN), held(OWN)], None),
    ],
)
def test_a_bid_loses_to_any_holder_else_to_a_lower_id(
    claims: list[Claim], rival: Claim | None
) -> None:
    assert rival_of_bid(OWN, claims) == rival


@pytest.mark.parametrize(
    ("claims", "rival"),
    [
        ([bid(OWN), held(OWN)], None),
        ([bid(OWN), held(OWN), bid("3")], None),
        ([bid(OWN), held(OWN), bid("7"), held("7")], None),
        ([bid(OWN), held(OWN), bid("3"), held("3")], held("3")),
    ],
)
def test_a_fresh_hold_withdraws_only_for_a_lower_id_that_holds_too(
    claims: list[Claim], rival: Claim | None
) -> None:
    assert rival_of_hold(OWN, claims) == rival


def test_a_holder_that_kept_its_router_never_gives_way() -> None:
    standing = Standing()
    standing.router_up("r1", 0.0)
    for claim in (held("0"), bid("0"), held("9"), held(OWN)):
        assert not standing.gives_way_to(claim, OWN, 1000.0)


def test_a_holder_apart_from_its_router_gives_way_to_a_holder_only() -> None:
    standing = Standing()
    standing.router_up("r1", 0.0)
    standing.router_down("r1")
    assert standing.gives_way_to(held("9"), OWN, 10.0)
    assert not standing.gives_way_to(bid("0"), OWN, 10.0)
    assert not standing.gives_way_to(held(OWN), OWN, 10.0)


def test_back_with_its_router_a_holder_gives_way_only_within_the_rejoin_window() -> None:
    standing = Standing()
    standing.router_up("r1", 0.0)
    standing.router_down("r1")
    standing.router_up("r1", 100.0)
    assert standing.gives_way_to(held("9"), OWN, 100.0 + REJOIN_S)
    assert not standing.gives_way_to(held("9"), OWN, 100.0 + REJOIN_S + 0.001)


def test_losing_one_of_two_routers_is_not_being_apart() -> None:
    standing = Standing()
    standing.router_up("r1", 0.0)
    standing.router_up("r2", 0.0)
    standing.router_down("r1")
    assert not standing.gives_way_to(held("9"), OWN, 1.0)
    standing.router_down("r2")
    assert standing.gives_way_to(held("8"), OWN, 2.0)
