"""The claim's rules without a bus (shared/bus/claim.py): what a bid and a fresh hold lose to,
and when a holder gives way."""

from __future__ import annotations

import pytest

from motocell.shared.bus.claim import (
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
    assert not standing.gives_way_to(held("0"), OWN, 1.0)
    standing.router_down("r2")
    assert standing.gives_way_to(held("0"), OWN, 2.0)
