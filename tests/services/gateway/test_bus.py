"""``ZenohBus``, the thin adapter the gateway's shells see the bus through, on a real Zenoh
router on loopback: it must behave as the scripted bus of the other tests does."""

from __future__ import annotations

import threading
from collections.abc import Callable

import zenoh

from motocell.services.gateway.bus import ZenohBus
from motocell.testing.processes import wait_until
from tests.services.gateway.fake_bus import WAIT_S

KEY = "motocell/test/group/0/slot"


def arrives(condition: Callable[[], bool], what: str) -> None:
    wait_until(condition, WAIT_S, what)


def test_a_latest_value_channel_keeps_only_the_newest(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    bus = ZenohBus(receiver)
    channel = bus.latest(KEY)
    seen: list[bytes] = []
    # Delivered in the same order in the same session: once it has the second sample, so
    # has the channel.
    barrier = bus.subscribe(KEY, seen.append)
    publisher = ZenohBus(sender).publisher(KEY)
    arrives(publisher.observed, "the subscribers matched")
    assert channel.take() is None
    publisher.put(b"\x91\x01")
    publisher.put(b"\x91\x02")
    arrives(lambda: len(seen) == 2, "both samples")
    assert channel.take() == b"\x91\x02"
    assert channel.take() is None
    channel.undeclare()
    barrier.undeclare()


def test_a_subscription_delivers_payloads_and_a_publisher_knows_it_is_observed(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    publisher = ZenohBus(sender).publisher(KEY, latest=True)
    assert not publisher.observed()
    got: list[bytes] = []
    subscription = ZenohBus(receiver).subscribe(KEY, got.append)
    arrives(publisher.observed, "the subscriber matched")
    publisher.put(b"\x91\x07")
    arrives(lambda: got == [b"\x91\x07"], "the sample")
    subscription.undeclare()
    arrives(lambda: not publisher.observed(), "the subscriber gone")


def test_a_query_gets_its_answers_then_ends(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    asker, answerer = sessions

    def answer(query: zenoh.Query) -> None:
        query.reply(query.key_expr, b"\x91\x05")
        query.drop()

    queryable = answerer.declare_queryable(KEY, answer)

    def ask() -> list[bytes]:
        answers: list[bytes] = []
        done = threading.Event()
        ZenohBus(asker).query(KEY, b"\x90", answers.append, done.set, timeout=WAIT_S)
        assert done.wait(WAIT_S), "the query never ended"
        return answers

    # The queryable's declaration reaches the asker's session some time after it returns; a
    # query asked before then ends unanswered, which is the next test's case, not this one's.
    asked: list[list[bytes]] = []

    def answered() -> bool:
        asked.append(ask())
        return bool(asked[-1])

    arrives(answered, "an answer")
    assert asked[-1] == [b"\x91\x05"]
    queryable.undeclare()


def test_a_query_nobody_answers_ends_unanswered(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    asker, _ = sessions
    answers: list[bytes] = []
    done = threading.Event()
    ZenohBus(asker).query(KEY, None, answers.append, done.set, timeout=WAIT_S)
    assert done.wait(2 * WAIT_S)
    assert answers == []


def test_tokens_are_seen_once_asked(sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    watcher, service = sessions
    token = service.liveliness().declare_token("@motocell/test/alive/controller/0")
    changed = threading.Event()
    tokens = ZenohBus(watcher).tokens("@motocell/test/alive/*/*", changed.set)
    assert tokens.ask().wait(WAIT_S)
    assert tokens.present() == {"@motocell/test/alive/controller/0"}
    tokens.close()
    token.undeclare()
