"""The delay line's decisions (``tools.delay_line.Line``): the TAP devices and the root it
needs are scripts/multihost's, run by tests/e2e/test_multihost.py."""

from __future__ import annotations

from motocell.tools.delay_line import FRAMES_PER_LINK, Line

HOST, PORT, OTHER_HOST, OTHER_PORT = 3, 4, 5, 6
MS = 1_000_000


def test_a_frame_from_a_host_waits_the_delay_and_one_towards_it_passes_at_once() -> None:
    line = Line([(HOST, PORT)], delay_ns=10 * MS)
    assert line.take(HOST, b"out", now_ns=0) is None
    assert line.take(PORT, b"in", now_ns=0) == (HOST, b"in")
    assert line.timeout_s(now_ns=4 * MS) == 0.006
    assert line.due(now_ns=10 * MS - 1) == []
    assert line.due(now_ns=10 * MS) == [(PORT, b"out")]
    assert line.timeout_s(now_ns=10 * MS) is None


def test_frames_of_several_links_leave_in_the_order_they_came_each_to_its_port() -> None:
    line = Line([(HOST, PORT), (OTHER_HOST, OTHER_PORT)], delay_ns=MS)
    line.take(HOST, b"1", now_ns=0)
    line.take(OTHER_HOST, b"2", now_ns=10)
    line.take(HOST, b"3", now_ns=20)
    assert line.due(now_ns=MS + 10) == [(PORT, b"1"), (OTHER_PORT, b"2")]
    assert line.due(now_ns=2 * MS) == [(PORT, b"3")]


def test_a_full_line_drops_what_comes_beyond_its_limit_and_counts_it() -> None:
    line = Line([(HOST, PORT)], delay_ns=MS)
    for number in range(FRAMES_PER_LINK + 2):
        line.take(HOST, number.to_bytes(2), now_ns=0)
    assert line.dropped == 2
    due = line.due(now_ns=MS)
    assert [frame for _, frame in due] == [n.to_bytes(2) for n in range(FRAMES_PER_LINK)]
    # Towards the host nothing waits, so nothing is dropped.
    assert line.take(PORT, b"in", now_ns=0) == (HOST, b"in")
