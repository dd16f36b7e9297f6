"""Every sample and reply says it is msgpack, so Zenoh tools show the format, not bytes."""

from __future__ import annotations

import queue

import zenoh

from motocell.shared.bus.schemas import CommandReply, CommandRequest, Slot, encode
from motocell.shared.bus.session import ENCODING, answer, call, command_of, publisher
from motocell.shared.protocol.constants import Result
from motocell.testing.processes import wait_until

KEY = "motocell/c1/group/0/slot"


def test_the_encoding_is_msgpack() -> None:
    assert str(ENCODING) == "application/msgpack"


def test_a_publication_carries_the_encoding(sessions: tuple[zenoh.Session, zenoh.Session]) -> None:
    sender, receiver = sessions
    received: queue.Queue[zenoh.Sample] = queue.Queue()
    subscriber = receiver.declare_subscriber(KEY, received.put)
    slot_publisher = publisher(sender, KEY)
    try:
        # The subscription travels through the router: publish until a sample arrives.
        wait_until(
            lambda: slot_publisher.put(encode(Slot(1, 0))) or not received.empty(),
            10.0,
            "a sample",
        )
        sample = received.get_nowait()
    finally:
        slot_publisher.undeclare()
        subscriber.undeclare()
    assert sample.encoding == ENCODING


def test_a_query_and_its_reply_carry_the_encoding(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    asker, server = sessions
    asked: list[zenoh.Encoding | None] = []

    def serve(query: zenoh.Query) -> None:
        asked.append(query.encoding)
        answer(query, CommandReply(Result.SUCCESS, value=command_of(query).value))

    queryable = server.declare_queryable("motocell/c1/controller/cmd/*", serve)
    try:
        # A plain query, as any Zenoh tool asks (again until the queryable's declaration has
        # travelled through the router): the reply says what it is.
        encodings: list[zenoh.Encoding] = []

        def answered() -> bool:
            replies = asker.get("motocell/c1/controller/cmd/positions", timeout=1.0)
            encodings.extend(reply.ok.encoding for reply in replies if reply.ok is not None)
            return bool(encodings)

        wait_until(answered, 10.0, "the queryable")
        reply = call(asker, "motocell/c1/controller/cmd/positions", CommandRequest(value=7), 10.0)
    finally:
        queryable.undeclare()
    assert encodings == [ENCODING]
    assert reply == CommandReply(Result.SUCCESS, value=7)
    assert asked[-1] == ENCODING
