"""The zygote's request loop with a scripted fork, no process started: one reply per request,
in order; a request too long for its room, or a line that is no request, is refused and the
loop goes on; in a forked service the loop returns that service's request; it ends when the
launcher closes the socket."""

from __future__ import annotations

import io

from motocell.services.launcher.core.forks import (
    Forked,
    ForkRefused,
    ForkRequest,
    command_line,
    decode_reply,
    encode,
)
from motocell.services.launcher.zygote import serve

PYTHON = "/usr/bin/python3"


class Lines(io.BytesIO):
    """What the launcher sent, to read; what the zygote writes back, kept apart."""

    def __init__(self, *requests: bytes) -> None:
        super().__init__(b"".join(requests))
        self.written = bytearray()

    def write(self, data: object, /) -> int:
        assert isinstance(data, bytes)
        self.written += data
        return len(data)

    def replies(self) -> list[Forked | ForkRefused]:
        return [decode_reply(line) for line in bytes(self.written).splitlines(keepends=True)]


class ScriptedFork:
    """Forks each request as pid 100, 101, ...; the service's side (None) for ``becomes``."""

    def __init__(self, becomes: ForkRequest | None = None) -> None:
        self.becomes = becomes
        self.forked: list[ForkRequest] = []

    def __call__(self, request: ForkRequest) -> Forked | ForkRefused | None:
        self.forked.append(request)
        if request == self.becomes:
            return None
        return Forked(99 + len(self.forked))


GATEWAY = ForkRequest("motocell.services.gateway", ("--port-base", "50240"))
EXECUTOR = ForkRequest("motocell.services.executor", ())


def test_each_request_is_forked_and_answered_in_order_until_the_socket_closes() -> None:
    lines = Lines(encode(GATEWAY), encode(EXECUTOR))
    fork = ScriptedFork()
    assert serve(lines, fork, 4096, PYTHON) is None
    assert fork.forked == [GATEWAY, EXECUTOR]
    assert lines.replies() == [Forked(100), Forked(101)]


def test_a_command_line_longer_than_the_room_is_refused_without_a_fork() -> None:
    room = len(command_line(PYTHON, EXECUTOR))
    lines = Lines(encode(GATEWAY), encode(EXECUTOR))
    fork = ScriptedFork()
    serve(lines, fork, room, PYTHON)
    assert fork.forked == [EXECUTOR]
    assert lines.replies() == [
        ForkRefused(f"its command line is longer than {room} bytes"),
        Forked(100),
    ]


def test_a_line_that_is_no_request_is_refused_and_the_next_served() -> None:
    lines = Lines(b"garbage\n", encode(EXECUTOR))
    serve(lines, ScriptedFork(), 4096, PYTHON)
    refused, forked = lines.replies()
    assert isinstance(refused, ForkRefused)
    assert refused.reason.startswith("not a fork request")
    assert forked == Forked(100)


def test_in_the_forked_service_the_loop_returns_its_request_and_answers_nothing() -> None:
    lines = Lines(encode(GATEWAY), encode(EXECUTOR), encode(GATEWAY))
    fork = ScriptedFork(becomes=EXECUTOR)
    assert serve(lines, fork, 4096, PYTHON) == EXECUTOR
    assert lines.replies() == [Forked(100)]
