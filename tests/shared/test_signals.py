"""The stop signals held and released (shared/signals.py): one held is delivered at the release,
unless dropped first, and dropping keeps the handlers. Each is sent to this thread, the one
that holds them: sent to the process, another thread of the test run could take it."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator

import pytest

from motocell.shared.signals import (
    drop_held_stop_signals,
    hold_stop_signals,
    release_stop_signals,
)


@pytest.fixture
def counted() -> Iterator[list[int]]:
    """SIGTERM counted by a handler of the test's, the previous one back at the end."""
    seen: list[int] = []
    previous = signal.signal(signal.SIGTERM, lambda sig, frame: seen.append(sig))
    try:
        yield seen
    finally:
        release_stop_signals()
        signal.signal(signal.SIGTERM, previous)


def test_a_held_signal_comes_at_the_release(counted: list[int]) -> None:
    hold_stop_signals()
    signal.pthread_kill(threading.get_ident(), signal.SIGTERM)
    assert counted == []
    release_stop_signals()
    assert counted == [signal.SIGTERM]


def test_a_dropped_signal_never_comes_and_the_handler_stays(counted: list[int]) -> None:
    hold_stop_signals()
    signal.pthread_kill(threading.get_ident(), signal.SIGTERM)
    drop_held_stop_signals()
    release_stop_signals()
    assert counted == []
    signal.pthread_kill(
        threading.get_ident(), signal.SIGTERM
    )  # one that comes after: handled as before
    assert counted == [signal.SIGTERM]
