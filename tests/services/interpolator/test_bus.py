"""``ZenohBus``, the thin adapter the interpolator's shells see the bus through, on a real Zenoh
router on loopback: it must behave as the scripted bus of the other tests does."""

from __future__ import annotations

import threading

import zenoh

from motocell.services.interpolator.bus import ZenohBus
from motocell.testing.processes import wait_until
from tests.services.interpolator.fake_bus import WAIT_S

KEY = "motocell/test/group/0/point"


def test_a_fifo_channel_keeps_every_sample_in_order(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    channel = ZenohBus(receiver).fifo(KEY, 8)
    publisher = ZenohBus(sender).publisher(KEY, realtime=True)
    wait_until(publisher.observed, WAIT_S, "the subscriber matched")
    assert channel.try_recv() is None
    publisher.put(b"\x91\x01")
    publisher.put(b"\x91\x02")
    assert channel.recv() == b"\x91\x01"
    assert channel.recv() == b"\x91\x02"
    assert channel.try_recv() is None
    channel.undeclare()
    wait_until(lambda: not publisher.observed(), WAIT_S, "the subscriber gone")


def test_a_latest_value_channel_keeps_only_the_newest(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    bus = ZenohBus(receiver)
    channel = bus.latest(KEY)
    # Delivered in the same order in the same session: once the FIFO has the second sample,
    # so has the latest-value channel.
    barrier = bus.fifo(KEY, 8)
    publisher = ZenohBus(sender).publisher(KEY, latest=True)
    wait_until(publisher.observed, WAIT_S, "the subscribers matched")
    publisher.put(b"\x91\x01")
    publisher.put(b"\x91\x02")
    assert [barrier.recv(), barrier.recv()] == [b"\x91\x01", b"\x91\x02"]
    assert channel.try_recv() == b"\x91\x02"
    assert channel.try_recv() is None
    channel.undeclare()
    barrier.undeclare()


def test_a_doorbell_wakes_its_own_session_only(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    other, own = sessions
    bus = ZenohBus(own)
    elsewhere = ZenohBus(other).fifo(KEY, 8)
    publisher = bus.publisher(KEY)
    # Before the own session subscribes, which would match at once: only the other one's
    # subscription, once it has reached this session, makes the publication observed.
    wait_until(publisher.observed, WAIT_S, "the other session's subscriber matched")
    channel = bus.fifo(KEY, 8)
    doorbell = bus.doorbell(KEY)
    doorbell.ring()
    assert channel.recv() == b""
    publisher.put(b"\x91\x03")  # after the doorbell, from the same session
    assert channel.recv() == b"\x91\x03"
    assert elsewhere.recv() == b"\x91\x03"  # the doorbell never reached it
    doorbell.close()
    channel.undeclare()
    elsewhere.undeclare()


def test_a_query_is_answered_with_the_payload_of_the_moment(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    asker, answerer = sessions
    now = [b"\x91\x04"]
    answering = ZenohBus(answerer).answer(KEY, lambda: now[0])

    def ask() -> list[bytes]:
        return [
            reply.ok.payload.to_bytes()
            for reply in asker.get(KEY, timeout=WAIT_S)
            if reply.ok is not None
        ]

    # The queryable's declaration reaches the asker's session some time after it returns.
    wait_until(lambda: ask() != [], WAIT_S, "an answer")
    now[0] = b"\x91\x05"
    assert ask() == [b"\x91\x05"]
    answering.undeclare()


def test_a_callback_subscriber_is_called_for_each_sample_until_undeclared(
    sessions: tuple[zenoh.Session, zenoh.Session],
) -> None:
    sender, receiver = sessions
    called = threading.Semaphore(0)
    subscriber = ZenohBus(receiver).subscribe(KEY, lambda _sample: called.release())
    publisher = ZenohBus(sender).publisher(KEY, realtime=True)
    wait_until(publisher.observed, WAIT_S, "the subscriber matched")
    publisher.put(b"\x91\x01")
    publisher.put(b"\x91\x02")
    assert called.acquire(timeout=WAIT_S)
    assert called.acquire(timeout=WAIT_S)
    subscriber.undeclare()
    wait_until(lambda: not publisher.observed(), WAIT_S, "the subscriber gone")
