"""The motion port's reply priority, held while the connection waits for its client and given
up by one that always finds a request waiting (a client that pipelines or floods)."""

from __future__ import annotations

import socket

from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.reply_priority import BUSY_S, ReplyPriority
from motocell.services.gateway.tcp import serve_requests
from motocell.shared.realtime import REPLY_PRIORITY, SERVICE_PRIORITY
from tests.services.gateway.test_tcp import ORDER, Responder, ScriptedStream, replies, request


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def raised(clock: Clock, set_to: list[int]) -> ReplyPriority:
    """A priority as the thread had it granted, its changes kept in ``set_to``."""
    priority = ReplyPriority(clock=clock, set_priority=set_to.append)
    priority.raised = True
    return priority


def test_a_client_that_is_waited_for_keeps_the_reply_priority() -> None:
    clock, set_to = Clock(), list[int]()
    priority = raised(clock, set_to)
    for _ in range(100):
        priority.busy()  # a pipelined pair now and then
        clock.now += BUSY_S / 4
        priority.waiting()
        clock.now += BUSY_S / 4
    assert set_to == []


def test_a_thread_that_never_waits_gives_way_and_takes_it_again_when_it_waits() -> None:
    clock, set_to = Clock(), list[int]()
    priority = raised(clock, set_to)
    priority.busy()
    clock.now += BUSY_S
    priority.busy()
    assert set_to == [], "not beyond the bound yet"
    clock.now += 0.001
    priority.busy()
    priority.busy()
    assert set_to == [SERVICE_PRIORITY]
    priority.waiting()
    assert set_to == [SERVICE_PRIORITY, REPLY_PRIORITY]
    priority.waiting()
    assert set_to == [SERVICE_PRIORITY, REPLY_PRIORITY]


class PipelinedStream(ScriptedStream):
    """A client whose requests are all in the socket at once: a read without waiting finds the
    next one every time, until the last; each read moves the clock on."""

    def __init__(self, clock: Clock, *reads: bytes) -> None:
        super().__init__(*reads)
        self.clock = clock
        self.waits = 0

    def recv(self, size: int, flags: int = 0, /) -> bytes:
        self.clock.now += BUSY_S / 2
        if flags & socket.MSG_DONTWAIT and not self.reads:
            self.waits += 1
            raise BlockingIOError
        return super().recv(size)


def test_serving_a_pipelining_client_gives_the_priority_up_and_a_wait_takes_it_back() -> None:
    clock, set_to = Clock(), list[int]()
    stream = PipelinedStream(clock, *(request(k) for k in range(8)))
    serve_requests(
        stream, ORDER, Responder(), MotionHandler.error_reply, priority=raised(clock, set_to)
    )
    assert len(replies(bytes(stream.sent))) == 8, "every request answered"
    assert stream.waits == 1
    assert set_to == [SERVICE_PRIORITY, REPLY_PRIORITY]


def test_without_the_reply_priority_a_read_just_waits() -> None:
    clock, set_to = Clock(), list[int]()
    stream = PipelinedStream(clock, *(request(k) for k in range(8)))
    serve_requests(stream, ORDER, Responder(), MotionHandler.error_reply)
    assert len(replies(bytes(stream.sent))) == 8
    assert stream.waits == 0
    assert set_to == []
