"""``ZenohBus``, the thin adapter the executor's shells see the bus through, on a real Zenoh
router on loopback: it must behave as the scripted bus of the other tests does. And the
controller's token followed over it from the clock's thread: present if it was there before,
gone on its DELETE, present again when a new controller declares it."""

from __future__ import annotations

from collections.abc import Callable

import zenoh

from motocell.services.executor.bus import Query, Sample, ZenohBus
from motocell.services.executor.controller_token import ControllerToken
from motocell.shared.bus.liveness import ASK_AGAIN_S, QUERY_TIMEOUT_S
from motocell.shared.bus.schemas import CommandReply
from motocell.shared.bus.session import call, open_session
from motocell.shared.protocol.constants import Result
from motocell.testing.processes import wait_until
from tests.services.executor.fake_bus import WAIT_S

KEY = "motocell/test/group/0/point"
TOKEN = "@motocell/test/alive/controller/0"
PROBE = "@motocell/test/alive/probe/0"
TOKENS = "@motocell/test/alive/*/*"


def arrives(condition: Callable[[], bool], what: str) -> None:
    wait_until(condition, WAIT_S, what)


def matched(bus: ZenohBus, key: str) -> None:
    """Until a subscriber of ``key`` reaches the publishing side."""
    publication = bus.publisher(key)
    arrives(publication.observed, f"a subscriber of {key}")


def test_a_channel_keeps_every_sample_in_order(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    channel = ZenohBus(receiver).channel("motocell/test/group/*/point", 8)
    publication = ZenohBus(sender).publisher(KEY)
    arrives(publication.observed, "the channel matched")
    assert channel.try_recv() is None
    publication.put(b"\x91\x01")
    publication.put(b"\x91\x02")
    first = channel.recv()
    assert (str(first.key_expr), first.payload.to_bytes()) == (KEY, b"\x91\x01")
    second = channel.recv()
    assert second.payload.to_bytes() == b"\x91\x02"


def test_a_subscription_calls_back_and_a_publisher_knows_it_is_observed(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    publication = ZenohBus(sender).publisher(KEY, realtime=True, latest=True)
    assert not publication.observed()
    got: list[bytes] = []

    def on_sample(sample: Sample) -> None:
        got.append(sample.payload.to_bytes())

    subscription = ZenohBus(receiver).subscribe(KEY, on_sample)
    arrives(publication.observed, "the subscriber matched")
    publication.put(b"\x91\x07")
    arrives(lambda: got == [b"\x91\x07"], "the sample")
    subscription.undeclare()
    arrives(lambda: not publication.observed(), "the subscriber gone")


def test_a_doorbell_wakes_its_own_session_only(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    own, other = sessions
    bus = ZenohBus(own)
    channel = bus.channel(KEY, 64)
    elsewhere = ZenohBus(other).channel(KEY, 64)
    publication = bus.publisher(KEY)
    heard: list[bytes] = []

    def heard_elsewhere(payload: bytes) -> bool:
        publication.put(payload)
        while (sample := elsewhere.try_recv()) is not None:
            heard.append(sample.payload.to_bytes())
        return payload in heard

    arrives(lambda: heard_elsewhere(b"\x91\x00"), "the other session subscribed")
    doorbell = bus.doorbell(KEY)
    doorbell.ring()
    while channel.recv().payload.to_bytes() != b"":
        pass  # what this session published itself
    arrives(lambda: heard_elsewhere(b"\x91\x01"), "a sample after the doorbell")
    assert b"" not in heard, "the doorbell never left its session"
    doorbell.close()


def test_a_query_is_answered_through_the_queryable(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    asker, answerer = sessions
    asked: list[Query] = []

    def on_query(query: Query) -> None:
        asked.append(query)
        query.answer(CommandReply(Result.SUCCESS, value=5))

    queryable = ZenohBus(answerer).queryable("motocell/test/executor/cmd/stop", on_query)
    # The queryable's declaration reaches the asker some time after it returns.
    replies: list[CommandReply | None] = []

    def answered() -> bool:
        replies.append(call(asker, "motocell/test/executor/cmd/stop", timeout=WAIT_S))
        return replies[-1] is not None

    arrives(answered, "an answer")
    assert replies[-1] == CommandReply(Result.SUCCESS, value=5)
    queryable.undeclare()


def test_a_call_nobody_answers_is_none(sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    asker, _ = sessions
    assert ZenohBus(asker).call("motocell/test/broadcaster/cmd/positions", 0.2) is None


def test_token_answers(sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    watcher, service = sessions
    bus = ZenohBus(watcher)
    token = service.liveliness().declare_token(TOKEN)

    def answered() -> bool:
        """A query's answers, once it has finished: the token, once its declaration has
        reached the router."""
        answers = bus.ask_tokens(TOKENS, 8, QUERY_TIMEOUT_S)
        found: list[str] = []

        def finished() -> bool:
            tokens, done = answers.take()
            found.extend(tokens)
            return done

        arrives(finished, "the query's end")
        return found == [TOKEN]

    wait_until(answered, 2 * WAIT_S, "the token in an answer")
    token.undeclare()


def test_token_events(sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    watcher, service = sessions
    bus = ZenohBus(watcher)
    events = bus.token_events(TOKENS, 64)
    seen: list[tuple[str, bool]] = []

    def heard(expected: tuple[str, bool]) -> bool:
        while (event := events.try_recv()) is not None:
            seen.append((str(event.key_expr), bus.declared(event)))
        return expected in seen

    def subscribed() -> bool:
        """A probe's token, declared and undeclared until its events come: the subscription
        has reached the router."""
        service.liveliness().declare_token(PROBE).undeclare()
        return heard((PROBE, False))

    arrives(subscribed, "the subscription at the router")
    token = service.liveliness().declare_token(TOKEN)
    arrives(lambda: heard((TOKEN, True)), "the PUT")
    token.undeclare()
    arrives(lambda: heard((TOKEN, False)), "the DELETE")
    assert [entry for entry in seen if entry[0] == TOKEN] == [(TOKEN, True), (TOKEN, False)]


class Looks:
    """The clock's looks at the token, each at a time that steps past the re-asking period, so
    every look while the controller is absent asks again."""

    def __init__(self, watch: ControllerToken) -> None:
        self.watch = watch
        self.now_ns = 0

    def present(self) -> bool:
        self.now_ns += round((ASK_AGAIN_S + QUERY_TIMEOUT_S) * 1e9)
        return self.watch.looks(self.now_ns)[-1]


def test_the_controller_token_over_a_router(endpoint: str) -> None:
    executor = open_session("client", [endpoint], wait=False)
    first = open_session("client", [endpoint], wait=False)
    second = open_session("client", [endpoint], wait=False)
    try:
        tokens = [first.liveliness().declare_token(TOKEN)]  # a token lives while referenced
        looks = Looks(ControllerToken(ZenohBus(executor), TOKEN))
        arrives(looks.present, "the token declared before")

        first.close()
        arrives(lambda: not looks.present(), "the DELETE of a closed session")

        tokens.append(second.liveliness().declare_token(TOKEN))
        arrives(looks.present, "a new controller's token")
    finally:
        for session in (second, first, executor):
            session.close()
