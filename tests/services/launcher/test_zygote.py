"""The zygote's request loop with a scripted fork, no process started: one reply per request,
in order; a request too long for its room, or a line that is no request, is refused and the
loop goes on; in a forked service the loop returns that service's request; it ends when the
launcher closes the socket. A forked service gets its go only once its reply is written, and
end of file instead when the reply cannot be; a service whose zygote is gone ends. The real
``fork_service`` with a fork told to fail: a failed first fork is a refusal, and the first
child ends whatever its write to a zygote gone raises."""

from __future__ import annotations

import errno
import io
import os
from collections.abc import Iterator

import pytest

from motocell.services.launcher.core.forks import (
    Forked,
    ForkRefused,
    ForkRequest,
    command_line,
    decode_reply,
    encode,
)
from motocell.services.launcher.zygote import Held, await_go, fork_service, serve

PYTHON = "/usr/bin/python3"


class Lines(io.BytesIO):
    """What the launcher sent, to read; what the zygote writes back, kept apart.
    ``closed_by_launcher``: writing raises, as on a socket whose other end is closed."""

    def __init__(self, *requests: bytes, closed_by_launcher: bool = False) -> None:
        super().__init__(b"".join(requests))
        self.written = bytearray()
        self.closed_by_launcher = closed_by_launcher
        self.before_each_write: list[bytes] = []
        self.watched: int | None = None
        """A go pipe's read end: what it held at each write goes to ``before_each_write``."""

    def write(self, data: object, /) -> int:
        assert isinstance(data, bytes)
        if self.watched is not None:
            self.before_each_write.append(read_now(self.watched))
        if self.closed_by_launcher:
            raise BrokenPipeError(errno.EPIPE, "the launcher closed its end")
        self.written += data
        return len(data)

    def replies(self) -> list[Forked | ForkRefused]:
        return [decode_reply(line) for line in bytes(self.written).splitlines(keepends=True)]


def read_now(fd: int) -> bytes:
    """What the pipe holds now: b"" at end of file, b"(empty)" when nothing is there yet."""
    os.set_blocking(fd, False)
    try:
        return os.read(fd, 16)
    except BlockingIOError:
        return b"(empty)"


class ScriptedFork:
    """Forks each request as pid 100, 101, ...; the service's side (None) for ``becomes``.
    Keeps the read end of each service's go pipe."""

    def __init__(self, becomes: ForkRequest | None = None) -> None:
        self.becomes = becomes
        self.forked: list[ForkRequest] = []
        self.go: list[int] = []

    def __call__(self, request: ForkRequest) -> Held | ForkRefused | None:
        self.forked.append(request)
        if request == self.becomes:
            return None
        go_read, go_write = os.pipe()
        self.go.append(go_read)
        return Held(99 + len(self.forked), go_write)

    def close(self) -> None:
        for fd in self.go:
            os.close(fd)


@pytest.fixture
def fork() -> Iterator[ScriptedFork]:
    scripted = ScriptedFork()
    yield scripted
    scripted.close()


GATEWAY = ForkRequest("motocell.services.gateway", ("--port-base", "50240"))
EXECUTOR = ForkRequest("motocell.services.executor", ())


def test_each_request_is_forked_and_answered_in_order_until_the_socket_closes(
    fork: ScriptedFork,
) -> None:
    lines = Lines(encode(GATEWAY), encode(EXECUTOR))
    assert serve(lines, fork, 4096, PYTHON) is None
    assert fork.forked == [GATEWAY, EXECUTOR]
    assert lines.replies() == [Forked(100), Forked(101)]


def test_a_command_line_longer_than_the_room_is_refused_without_a_fork(
    fork: ScriptedFork,
) -> None:
    room = len(command_line(PYTHON, EXECUTOR))
    lines = Lines(encode(GATEWAY), encode(EXECUTOR))
    serve(lines, fork, room, PYTHON)
    assert fork.forked == [EXECUTOR]
    assert lines.replies() == [
        ForkRefused(f"its command line is longer than {room} bytes"),
        Forked(100),
    ]


def test_a_line_that_is_no_request_is_refused_and_the_next_served(fork: ScriptedFork) -> None:
    lines = Lines(b"garbage\n", encode(EXECUTOR))
    serve(lines, fork, 4096, PYTHON)
    refused, forked = lines.replies()
    assert isinstance(refused, ForkRefused)
    assert refused.reason.startswith("not a fork request")
    assert forked == Forked(100)


def test_in_the_forked_service_the_loop_returns_its_request_and_answers_nothing() -> None:
    lines = Lines(encode(GATEWAY), encode(EXECUTOR), encode(GATEWAY))
    fork = ScriptedFork(becomes=EXECUTOR)
    try:
        assert serve(lines, fork, 4096, PYTHON) == EXECUTOR
    finally:
        fork.close()
    assert lines.replies() == [Forked(100)]


def test_a_service_gets_its_go_only_once_its_reply_is_written(fork: ScriptedFork) -> None:
    lines = Lines(encode(GATEWAY))

    def forking(request: ForkRequest) -> Held | ForkRefused | None:
        held = fork(request)
        lines.watched = fork.go[-1]
        return held

    serve(lines, forking, 4096, PYTHON)
    assert lines.before_each_write == [b"(empty)"]  # not yet let go while the reply was sent
    assert read_now(fork.go[0]) == b"!"
    assert read_now(fork.go[0]) == b""  # and the zygote's end closed


def test_a_reply_the_launcher_no_longer_reads_ends_the_loop_and_the_service(
    fork: ScriptedFork,
) -> None:
    lines = Lines(encode(GATEWAY), encode(EXECUTOR), closed_by_launcher=True)
    assert serve(lines, fork, 4096, PYTHON) is None
    assert fork.forked == [GATEWAY]  # no further request served
    assert read_now(fork.go[0]) == b""  # end of file: the service ends (``await_go``)


def test_await_go_says_whether_the_zygote_let_the_service_go() -> None:
    go_read, go_write = os.pipe()
    Held(100, go_write).release()
    assert await_go(go_read)
    go_read, go_write = os.pipe()
    Held(100, go_write).abandon()  # as when the zygote dies: its end closes
    assert not await_go(go_read)


class EndedError(Exception):
    """What the fake ``os._exit`` raises: the process would end here."""


def end(status: int) -> None:
    raise EndedError(status)


class Forks:
    """A fork told what to return (a pid, 0 for the child) or raise, call after call."""

    def __init__(self, *results: int | OSError) -> None:
        self.results = list(results)

    def __call__(self) -> int:
        result = self.results.pop(0)
        if isinstance(result, OSError):
            raise result
        return result


@pytest.fixture
def pipes(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[int]]:
    """Every pipe end ``fork_service`` opens; those a real process would close by ending are
    closed after the test."""
    opened: list[int] = []
    real_pipe = os.pipe

    def pipe() -> tuple[int, int]:
        ends = real_pipe()
        opened.extend(ends)
        return ends

    monkeypatch.setattr(os, "pipe", pipe)
    yield opened
    for fd in opened:
        try:
            os.close(fd)
        except OSError:  # closed already, as it should be
            continue


def test_a_first_fork_that_fails_is_refused_and_leaves_no_pipe_open(pipes: list[int]) -> None:
    refused = fork_service(EXECUTOR, fork=Forks(OSError(errno.EAGAIN, "try again")), end=end)
    assert isinstance(refused, ForkRefused)
    assert "fork failed" in refused.reason and "try again" in refused.reason
    for fd in pipes:
        with pytest.raises(OSError, match="Bad file descriptor"):
            os.fstat(fd)


@pytest.mark.parametrize("second", [4242, OSError(errno.EAGAIN, "try again")])
def test_the_first_child_ends_even_when_its_zygote_is_gone(
    pipes: list[int], second: int | OSError
) -> None:
    """Its write to the pid pipe whose reader is closed raises BrokenPipeError (as when the
    zygote is gone): the first child still ends, instead of unwinding through the zygote."""
    with pytest.raises(EndedError):
        fork_service(EXECUTOR, fork=Forks(0, second), end=end)


def test_a_service_whose_zygote_is_gone_before_its_go_ends(pipes: list[int]) -> None:
    """Both forks return 0: this is the service; the go pipe's writer is closed (no zygote
    holds it), so it reads end of file and ends."""
    with pytest.raises(EndedError):
        fork_service(EXECUTOR, fork=Forks(0, 0), end=end)
