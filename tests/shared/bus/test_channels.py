"""Reading channels from a service's own thread: a doorbell wakes a blocked ``recv`` in its own
session only, and decoding never lets a bad or empty sample through."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
import zenoh

from motocell.shared.bus.channels import Doorbell, decoded, is_doorbell, newest
from motocell.shared.bus.schemas import Decoder, Slot, encode
from motocell.shared.bus.session import open_session
from motocell.testing.ports import listening

KEY = "motocell/test/channels"


@pytest.fixture
def sessions() -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    endpoint, first = listening(lambda at: open_session("peer", [], listen=[at], wait=False))
    second = open_session("peer", [endpoint], wait=False)
    yield first, second
    second.close()
    first.close()


def test_a_doorbell_wakes_its_own_session_only(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    own, other = sessions
    mine = own.declare_subscriber(KEY, zenoh.handlers.FifoChannel(1024))
    theirs = other.declare_subscriber(KEY, zenoh.handlers.FifoChannel(1024))
    doorbell = Doorbell(own, KEY)
    doorbell.ring()
    rung = mine.recv()
    assert is_doorbell(rung)
    assert decoded(rung, Decoder(Slot)) is None
    mine.undeclare()  # its FIFO would fill with the puts below and block Zenoh
    # Until the other session has the subscription, a put may not reach it: put until it does.
    deadline = time.monotonic() + 10.0
    sample: zenoh.Sample | None
    while (sample := theirs.try_recv()) is None and time.monotonic() < deadline:
        own.put(KEY, encode(Slot(1, 2)))
        time.sleep(0.01)
    received = []
    while sample is not None:
        received.append(sample)
        sample = theirs.try_recv()
    assert received
    assert all(decoded(s, Decoder(Slot)) == Slot(1, 2) for s in received)  # no doorbell
    doorbell.close()
    theirs.undeclare()


def test_newest_reads_the_latest_value_and_drops_what_does_not_decode(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    own, _ = sessions
    channel = own.declare_subscriber(KEY, zenoh.handlers.RingChannel(1))
    decoder = Decoder(Slot)
    assert newest(channel, decoder) is None
    own.put(KEY, encode(Slot(1, 2)))
    own.put(KEY, encode(Slot(3, 4)))
    assert newest(channel, decoder) == Slot(3, 4)
    own.put(KEY, b"\xc1")  # never valid msgpack
    assert newest(channel, decoder) is None
    channel.undeclare()
