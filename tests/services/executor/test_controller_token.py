"""``ControllerToken`` on a scripted bus: present from its token's declaration or a query's
answer, gone only on its DELETE, and asked again while absent as ``Asking`` says (times in the
clock's nanoseconds, ``Asking``'s seconds)."""

from __future__ import annotations

from motocell.services.executor.controller_token import ControllerToken
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.liveness import ASK_AGAIN_S, QUERY_TIMEOUT_S
from tests.services.executor.fake_bus import FakeBus

KEY = CellKeys("cell1").alive("controller", "0")
NS = 1_000_000_000
T0 = 50 * NS
ASK_AGAIN_NS = round(ASK_AGAIN_S * NS)
QUERY_TIMEOUT_NS = round(QUERY_TIMEOUT_S * NS)


def watching() -> tuple[FakeBus, ControllerToken]:
    bus = FakeBus()
    return bus, ControllerToken(bus, KEY)


def present(token: ControllerToken, now_ns: int) -> bool:
    """Whether the token is present at this look (its last word)."""
    return token.looks(now_ns)[-1]


def test_the_first_look_asks_for_a_token_declared_before() -> None:
    bus, token = watching()
    assert bus.token_queries == []
    assert not present(token, T0)
    [query] = bus.token_queries
    assert (query.key, query.timeout) == (KEY, QUERY_TIMEOUT_S)
    query.reply(KEY)
    assert present(token, T0 + 1)


def test_events_decide_from_then_on() -> None:
    bus, token = watching()
    present(token, T0)
    bus.token(KEY, declared=True)
    assert present(token, T0 + 1)
    bus.token(KEY, declared=False)
    assert not present(token, T0 + 2)
    bus.token(KEY, declared=True)
    assert present(token, T0 + 3)


def test_a_delete_and_a_put_between_two_looks_are_a_departure() -> None:
    bus, token = watching()
    bus.token(KEY, declared=True)
    assert token.looks(T0) == (True,)
    bus.token(KEY, declared=False)
    bus.token(KEY, declared=True)
    assert token.looks(T0 + 1) == (False, True)
    assert token.looks(T0 + 2) == (True,)
    bus.token(KEY, declared=False)
    assert token.looks(T0 + 3) == (False, False)
    assert token.looks(T0 + 4) == (False,)


def test_an_answer_older_than_a_delete_proves_nothing() -> None:
    """The query was asked before the DELETE arrived: its answer may predate it."""
    bus, token = watching()
    present(token, T0)
    [query] = bus.token_queries
    bus.token(KEY, declared=True)
    bus.token(KEY, declared=False)
    query.reply(KEY)
    assert not present(token, T0 + 1)


def test_an_unanswered_query_removes_nothing() -> None:
    bus, token = watching()
    present(token, T0)
    bus.token(KEY, declared=True)
    bus.token_queries[0].finish()
    assert present(token, T0 + 1)


def test_while_absent_it_asks_again_after_each_finished_query() -> None:
    bus, token = watching()
    present(token, T0)
    bus.token_queries[0].finish()
    finished = T0 + 10
    present(token, finished)
    present(token, finished + ASK_AGAIN_NS - 1)
    assert len(bus.token_queries) == 1
    present(token, finished + ASK_AGAIN_NS)
    assert len(bus.token_queries) == 2


def test_a_query_that_never_finishes_is_asked_again_after_its_timeout() -> None:
    bus, token = watching()
    present(token, T0)
    present(token, T0 + QUERY_TIMEOUT_NS + ASK_AGAIN_NS - 1)
    assert len(bus.token_queries) == 1
    present(token, T0 + QUERY_TIMEOUT_NS + ASK_AGAIN_NS)
    assert len(bus.token_queries) == 2


def test_nothing_is_asked_while_the_controller_is_present() -> None:
    bus, token = watching()
    present(token, T0)
    bus.token(KEY, declared=True)
    bus.token_queries[0].finish()
    for second in range(1, 10):
        assert present(token, T0 + second * NS)
    assert len(bus.token_queries) == 1
    bus.token(KEY, declared=False)
    assert not present(token, T0 + 10 * NS)
    assert len(bus.token_queries) == 2, "gone again: asked, the last question long past"
