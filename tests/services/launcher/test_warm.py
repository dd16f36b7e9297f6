"""The launcher's side of its warm parent, no process started: the channel over a socket pair
whose other end the test plays (a stop ends its wait, so does a zygote that does not answer
in time, and a reply that came after it stopped waiting is found); the starter with a
scripted zygote: it forks what the zygote holds, starts the rest plainly, once the zygote
fails starts everything plainly, and on a stop gives the zygote up and starts nothing."""

from __future__ import annotations

import socket
from collections.abc import Iterator, Sequence

import pytest

from motocell.services.launcher import warm
from motocell.services.launcher.core.forks import (
    Forked,
    ForkRefused,
    ForkRequest,
    decode_request,
    encode,
)
from motocell.services.launcher.warm import (
    NotForkedError,
    Process,
    Starter,
    ZygoteChannel,
    ZygoteGoneError,
)
from motocell.shared.bus.session import StoppedWaiting
from motocell.shared.service import StopFlag

GATEWAY = "motocell.services.gateway"
FACE = "motocell.services.ros2"


@pytest.fixture
def stop() -> StopFlag:
    return StopFlag()


@pytest.fixture
def pair(stop: StopFlag) -> Iterator[tuple[ZygoteChannel, socket.socket]]:
    ours, theirs = socket.socketpair()
    channel = ZygoteChannel(ours, stop)
    try:
        yield channel, theirs
    finally:
        channel.close()
        theirs.close()


def test_the_channel_sends_the_request_and_returns_the_pid(
    pair: tuple[ZygoteChannel, socket.socket],
) -> None:
    channel, zygote = pair
    zygote.sendall(encode(Forked(4242)))  # waits in the socket for the request's reply
    assert channel.fork(GATEWAY, ["--port-base", "50240"]) == 4242
    assert decode_request(zygote.recv(4096)) == ForkRequest(GATEWAY, ("--port-base", "50240"))


def test_a_refusal_is_not_forked(pair: tuple[ZygoteChannel, socket.socket]) -> None:
    channel, zygote = pair
    zygote.sendall(encode(ForkRefused("too long")))
    with pytest.raises(NotForkedError, match="too long"):
        channel.fork(GATEWAY, [])


def test_a_closed_socket_is_a_zygote_gone(pair: tuple[ZygoteChannel, socket.socket]) -> None:
    channel, zygote = pair
    zygote.shutdown(socket.SHUT_WR)
    with pytest.raises(ZygoteGoneError, match="closed"):
        channel.fork(GATEWAY, [])


def test_an_answer_that_is_no_reply_is_a_zygote_gone(
    pair: tuple[ZygoteChannel, socket.socket],
) -> None:
    channel, zygote = pair
    zygote.sendall(b"nonsense\n")
    with pytest.raises(ZygoteGoneError, match="not a reply"):
        channel.fork(GATEWAY, [])


def test_a_stop_ends_the_wait_for_a_zygote_that_does_not_answer(
    pair: tuple[ZygoteChannel, socket.socket], stop: StopFlag
) -> None:
    channel, _ = pair
    stop.set()  # as the SIGTERM handler does; the zygote, stuck, never answers
    with pytest.raises(StoppedWaiting):
        channel.fork(GATEWAY, [])


def test_no_answer_in_time_is_a_zygote_gone(
    pair: tuple[ZygoteChannel, socket.socket], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(warm, "REPLY_S", 0.01)
    channel, _ = pair
    with pytest.raises(ZygoteGoneError, match="no answer"):
        channel.fork(GATEWAY, [])


def test_a_reply_split_across_reads_is_one_line(
    pair: tuple[ZygoteChannel, socket.socket],
) -> None:
    channel, zygote = pair
    reply = encode(Forked(4242))
    zygote.sendall(reply[:3])
    zygote.sendall(reply[3:])
    assert channel.fork(GATEWAY, []) == 4242


def test_a_reply_after_the_launcher_stopped_waiting_is_found_once(
    pair: tuple[ZygoteChannel, socket.socket], stop: StopFlag
) -> None:
    channel, zygote = pair
    stop.set()
    with pytest.raises(StoppedWaiting):
        channel.fork(GATEWAY, [])
    zygote.sendall(encode(Forked(4242)))  # the zygote answered, then was killed
    zygote.close()
    assert channel.late_reply() == 4242
    assert channel.late_reply() is None


def test_no_late_reply_when_the_zygote_said_nothing(
    pair: tuple[ZygoteChannel, socket.socket],
) -> None:
    channel, zygote = pair
    zygote.sendall(b'{"type":"Forked"')  # cut off mid-line by its death
    assert channel.late_reply() is None


class Started:
    """A ``Process`` that only names how it was started."""

    def __init__(self, how: str, argv: Sequence[str]) -> None:
        self.how = how
        self.argv = tuple(argv)
        self.pid = 1
        self.returncode: int | None = None

    def poll(self) -> int | None:
        return None

    def wait(self, timeout: float | None = None) -> int:
        raise AssertionError("not waited for")

    def send_signal(self, sig: int) -> None:
        raise AssertionError("not signalled")

    def kill(self) -> None:
        raise AssertionError("not killed")


class ScriptedZygote:
    def __init__(self, *failures: Exception) -> None:
        self.modules = frozenset({GATEWAY})
        self.failures = list(failures)
        self.closed = False
        self.retired = False

    def pids(self) -> set[int]:
        return set() if self.closed or self.retired else {7}

    def retire(self) -> None:
        self.retired = True

    def close(self) -> None:
        self.closed = True

    def fork(self, module: str, args: Sequence[str]) -> Process:
        assert not (self.closed or self.retired)
        if self.failures:
            raise self.failures.pop(0)
        return Started("forked", (module, *args))


def plain(argv: Sequence[str]) -> Process:
    return Started("spawned", argv)


def how(process: Process) -> str:
    assert isinstance(process, Started)
    return process.how


def command(module: str) -> list[str]:
    return ["/py", "-m", module, "--config", "cell.toml"]


def test_what_the_zygote_holds_is_forked_and_the_rest_spawned() -> None:
    start = Starter(ScriptedZygote(), plain)
    forked = start(command(GATEWAY))
    assert how(forked) == "forked"
    assert isinstance(forked, Started) and forked.argv == (GATEWAY, "--config", "cell.toml")
    assert how(start(command(FACE))) == "spawned"


def test_a_refused_fork_is_spawned_and_the_zygote_kept() -> None:
    zygote = ScriptedZygote(NotForkedError("too long"))
    start = Starter(zygote, plain)
    assert how(start(command(GATEWAY))) == "spawned"
    assert how(start(command(GATEWAY))) == "forked"


def test_once_the_zygote_is_gone_everything_is_spawned(caplog: pytest.LogCaptureFixture) -> None:
    zygote = ScriptedZygote(ZygoteGoneError("it exited"))
    start = Starter(zygote, plain)
    assert how(start(command(GATEWAY))) == "spawned"
    assert how(start(command(GATEWAY))) == "spawned"
    assert "the warm parent failed (it exited)" in caplog.text
    assert zygote.closed  # asked once, then never again


def test_a_stop_while_waiting_gives_the_zygote_up_and_starts_nothing() -> None:
    zygote = ScriptedZygote(StoppedWaiting())
    start = Starter(zygote, plain)
    assert start.pids() == {7}
    with pytest.raises(StoppedWaiting):
        start(command(GATEWAY))
    assert zygote.closed
    assert start.pids() == set()


def test_a_retired_zygote_is_let_go_and_every_later_start_spawned() -> None:
    zygote = ScriptedZygote()
    start = Starter(zygote, plain)
    assert how(start(command(GATEWAY))) == "forked"
    start.retire()
    assert zygote.retired and not zygote.closed  # it ends by itself, not killed
    assert start.pids() == set()
    assert how(start(command(GATEWAY))) == "spawned"
    start.close()
    assert not zygote.closed  # retired: nothing left to close


def test_without_a_zygote_everything_is_spawned() -> None:
    assert how(Starter(None, plain)(command(GATEWAY))) == "spawned"
