"""Reading channels from a service's own thread: a doorbell wakes a blocked ``recv`` in its own
session only, and decoding never lets a bad or empty sample through."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import pytest
import zenoh

from motocell.shared.bus.channels import Doorbell, Parking, decoded, is_doorbell, newest
from motocell.shared.bus.schemas import Decoder, Slot, encode
from motocell.shared.bus.session import open_session
from motocell.shared.service import StopFlag
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


def test_parked_a_thread_waits_on_a_pipe_that_each_sample_and_doorbell_tells(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    """On real sessions: a doorbell and another session's put each end a parked wait, and
    parking and unparking while samples pour in never blocks (the callback runs on Zenoh's
    thread and takes the GIL while this thread undeclares it)."""
    own, other = sessions
    stop = StopFlag()

    def subscribe(on_sample: Callable[[object], None]) -> zenoh.Subscriber[None]:
        return own.declare_subscriber(KEY, zenoh.handlers.Callback(on_sample, indirect=False))

    parking = Parking(subscribe, stop)
    doorbell = Doorbell(own, KEY)
    parking.park()
    doorbell.ring()
    assert waited(parking)
    pouring = threading.Event()

    def pour() -> None:
        while not pouring.is_set():
            other.put(KEY, encode(Slot(1, 2)))
            time.sleep(0.0005)

    pourer = threading.Thread(target=pour)
    pourer.start()
    try:
        assert waited(parking), "another session's put ends the wait"
        for _ in range(200):
            parking.unpark()
            parking.park()
    finally:
        pouring.set()
        pourer.join()
    parking.unpark()
    stop.set()
    assert waited(parking), "the stop ends a wait"
    parking.close()
    doorbell.close()


def waited(parking: Parking) -> bool:
    """Whether ``parking.wait()`` returned within a deadline (on a thread, so a hang fails)."""
    waiting = threading.Thread(target=parking.wait)
    waiting.start()
    waiting.join(10.0)
    return not waiting.is_alive()
