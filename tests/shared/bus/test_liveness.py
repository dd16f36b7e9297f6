"""A service is gone only on evidence: its token's DELETE. Queries only find what events missed.

The pure tests drive ``Presence`` with events and answers in the orders Zenoh can deliver them;
the last test runs ``Liveness`` against a real router.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from motocell.shared.bus.liveness import Presence
from motocell.shared.bus.session import Liveness, open_session
from motocell.testing.ports import listening
from motocell.testing.processes import wait_until

A = "@motocell/c/alive/executor/0"
B = "@motocell/c/alive/gateway/0"


def test_put_and_delete_events_say_what_is_present() -> None:
    presence = Presence()
    assert presence.on_event(A, put=True)
    assert presence.on_event(B, put=True)
    assert not presence.on_event(A, put=True)
    assert presence.on_event(A, put=False)
    assert presence.present == {B}
    assert not presence.on_event(A, put=False)


def test_a_token_that_went_and_came_back_between_looks_still_departed() -> None:
    """Its holder's link broke and came back: what it sent meanwhile may be lost."""
    presence = Presence()
    presence.on_event(A, put=True)
    assert presence.take_departed() == frozenset()
    presence.on_event(A, put=False)
    presence.on_event(A, put=True)
    assert presence.present == {A}
    assert presence.take_departed() == {A}
    assert presence.take_departed() == frozenset(), "told once"


def test_an_answer_finds_what_the_events_missed() -> None:
    presence = Presence()
    asked = presence.asking()
    assert presence.on_answer([A, B], asked) == {A, B}
    assert presence.present == {A, B}
    assert presence.on_answer([A, B], presence.asking()) == set()


def test_an_answer_that_lacks_a_token_removes_nothing() -> None:
    """A slow, lost or empty answer is no evidence that a service is gone."""
    presence = Presence()
    presence.on_event(A, put=True)
    for _ in range(10):
        presence.on_answer([], presence.asking())
    assert presence.present == {A}


def test_a_delete_that_overtakes_the_answer_wins() -> None:
    """The token was there when the query was answered and gone before the answer arrived."""
    presence = Presence()
    presence.on_event(A, put=True)
    asked = presence.asking()
    presence.on_event(A, put=False)
    assert presence.on_answer([A], asked) == set()
    assert presence.present == frozenset()


def test_a_delete_before_the_query_was_asked_does_not_hide_a_new_token() -> None:
    """A service that left and came back while its PUT event was missed is found again."""
    presence = Presence()
    presence.on_event(A, put=True)
    presence.on_event(A, put=False)
    asked = presence.asking()
    presence.on_event(B, put=True)
    assert presence.on_answer([A, B], asked) == {A}
    assert presence.present == {A, B}


@pytest.fixture
def router() -> Iterator[str]:
    endpoint, session = listening(lambda at: open_session("router", listen=[at], wait=False))
    yield endpoint
    session.close()


def test_liveness_over_a_router(router: str) -> None:
    """Tokens there before it are present at once; a later one within milliseconds; a closed
    session's token is gone (its DELETE)."""
    watcher = open_session("client", [router], wait=False)
    early = open_session("client", [router], wait=False)
    late = open_session("client", [router], wait=False)
    try:
        tokens = [early.liveliness().declare_token(A)]  # a token lives while referenced
        wait_until(lambda: _queried(watcher) == {A}, 5.0, "the first token at the router")
        liveness = Liveness(watcher, "@motocell/c/alive/*/*")
        assert liveness.present() == frozenset()  # nothing asked yet, no event yet
        finished: list[frozenset[str]] = []
        assert liveness.ask(lambda: finished.append(liveness.present())).wait(5.0)
        assert finished == [{A}]  # told once the answers count
        assert liveness.present() == {A}

        tokens.append(late.liveliness().declare_token(B))
        wait_until(lambda: liveness.present() == {A, B}, 5.0, "the later token")
        late.close()
        wait_until(lambda: liveness.present() == {A}, 5.0, "the closed session's token gone")
    finally:
        for session in (late, early, watcher):
            session.close()


def _queried(session: zenoh.Session) -> set[str]:
    replies = session.liveliness().get("@motocell/c/alive/*/*", timeout=1.0)
    return {str(reply.ok.key_expr) for reply in replies if reply.ok is not None}
