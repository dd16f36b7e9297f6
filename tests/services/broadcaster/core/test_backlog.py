"""A state client's backlog: whole cycles in order, the newest instead of a burst of old ones,
and a client that takes nothing for STUCK_S is given up."""

from __future__ import annotations

from motocell.services.broadcaster.core.backlog import STUCK_S, Backlog


class Socket:
    """A non-blocking socket's ``send``: takes at most ``room`` bytes, then is full."""

    def __init__(self, room: int = 1 << 20) -> None:
        self.room = room
        self.received = bytearray()
        self.writes: list[bytes] = []

    def send(self, data: bytes | memoryview) -> int:
        if self.room == 0:
            raise BlockingIOError
        taken = bytes(data[: self.room])
        self.room -= len(taken)
        self.received += taken
        self.writes.append(taken)
        return len(taken)


def test_a_client_that_keeps_up_gets_every_cycle_whole() -> None:
    socket, backlog = Socket(), Backlog()
    for cycle in (b"one.", b"two.", b"three."):
        backlog.offer((cycle,))
        assert backlog.write(socket.send, 0.0)
        assert not backlog.pending
    assert socket.received == b"one.two.three."
    assert backlog.replaced == 0


def test_a_cycle_begun_is_finished_before_the_next_and_only_the_newest_waits() -> None:
    socket, backlog = Socket(room=3), Backlog()
    backlog.offer((b"AAAAAA",))
    assert backlog.write(socket.send, 0.0)
    for cycle in (b"BBBBBB", b"CCCCCC", b"DDDDDD"):
        backlog.offer((cycle,))
        assert backlog.write(socket.send, 0.1)
    assert socket.received == b"AAA"
    socket.room = 100
    assert backlog.write(socket.send, 0.2)
    assert socket.received == b"AAAAAADDDDDD"
    assert backlog.replaced == 2
    assert not backlog.pending


def test_a_client_that_takes_a_little_is_slow_not_stuck() -> None:
    socket, backlog = Socket(room=0), Backlog()
    backlog.offer((b"x" * 100,))
    for step in range(10):
        socket.room = 1
        assert backlog.write(socket.send, step * STUCK_S)
    assert len(socket.received) == 10


def test_a_client_that_takes_nothing_for_the_bound_is_given_up() -> None:
    socket, backlog = Socket(room=2), Backlog()
    backlog.offer((b"abcdef",))
    assert backlog.write(socket.send, 10.0)  # the last byte it took
    assert backlog.write(socket.send, 10.5)
    assert backlog.write(socket.send, 10.0 + STUCK_S - 0.01)
    assert not backlog.write(socket.send, 10.0 + STUCK_S)


def test_the_bound_starts_again_once_the_backlog_is_empty() -> None:
    socket, backlog = Socket(room=0), Backlog()
    backlog.offer((b"ab",))
    assert backlog.write(socket.send, 0.0)
    socket.room = 2
    assert backlog.write(socket.send, STUCK_S - 0.1)
    socket.room = 0
    backlog.offer((b"cd",))
    assert backlog.write(socket.send, STUCK_S + 1.0)
    assert not backlog.write(socket.send, 2 * STUCK_S + 1.0)


def test_each_message_is_written_on_its_own() -> None:
    """As MotoROS's one ``mpSend`` per message: a client reading one message per ``recv``
    finds the boundaries (the ``moto`` client does)."""
    socket, backlog = Socket(), Backlog()
    backlog.offer((b"feedback0", b"feedback1", b"status"))
    assert backlog.write(socket.send, 0.0)
    assert socket.writes == [b"feedback0", b"feedback1", b"status"]


def test_a_message_cut_by_a_full_socket_is_finished_before_the_next() -> None:
    socket, backlog = Socket(room=4), Backlog()
    backlog.offer((b"feedback", b"status"))
    assert backlog.write(socket.send, 0.0)
    socket.room = 100
    assert backlog.write(socket.send, 0.1)
    assert socket.writes == [b"feed", b"back", b"status"]
