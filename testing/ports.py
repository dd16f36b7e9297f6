"""Listening on a port picked free, race-free: picked again when it was taken meanwhile.

A port found free (``shared/ports.py``) is only free at that moment: another process can bind
it before its owner does (a Zenoh router opened on it, a cell started on it), and that bind
then fails with "Address already in use". ``on_free_port`` is the one place where such a
failure leads to a new pick and a new try, a bounded number of times; any other failure, and
the last try's, is the caller's.
"""

from __future__ import annotations

import errno
from collections.abc import Callable
from typing import TypeVar

from motocell.shared.ports import free_port_block

T = TypeVar("T")

HOST = "127.0.0.1"
TRIES = 5
"""Picks in all: a race lost this often in a row is no race but a bug."""
_TAKEN_WORDS = ("Address already in use", "is taken by another process")
"""How a taken port is told: the kernel's and Zenoh's words; the launcher's refusal and
``open_session``'s translation of Zenoh's (tests/testing/test_ports.py holds them to it)."""


class PortTakenError(OSError):
    """A port ``on_free_port`` picked was taken before it could be bound (a failure that
    carries no text of its own to say so, such as a process's exit, is raised as this)."""


def on_free_port(
    bind: Callable[[int], T], *, count: int = 1, host: str = HOST, tries: int = TRIES
) -> T:
    """``bind(port)`` on a port picked free (with ``count - 1`` free ports after it): what it
    returns. When it fails because a port was taken meanwhile (``taken``), on a new pick, up
    to ``tries`` picks in all."""
    for attempt in range(1, tries + 1):
        try:
            return bind(free_port_block(count, host))
        except Exception as exc:
            if attempt == tries or not taken(exc):
                raise
    raise AssertionError("unreachable: the last try returns or raises")


def listening(open_: Callable[[str], T], scheme: str = "tcp", host: str = HOST) -> tuple[str, T]:
    """A Zenoh endpoint ``scheme/host:PORT`` on a port picked free, and what ``open_`` returns
    for it (a router, a session listening there): ``on_free_port``'s new pick when taken."""

    def bind(port: int) -> tuple[str, T]:
        endpoint = f"{scheme}/{host}:{port}"
        return endpoint, open_(endpoint)

    return on_free_port(bind, host=host)


def ended(what: str, returncode: int, said: str) -> Exception:
    """The error for ``what`` that exited with ``returncode`` after saying ``said``: a
    ``PortTakenError`` (``on_free_port`` picks again) when its words say a port was taken,
    else an AssertionError with its output."""
    message = f"{what} exited with {returncode}: {said}"
    return PortTakenError(message) if taken(RuntimeError(said)) else AssertionError(message)


def taken(error: BaseException) -> bool:
    """Whether ``error`` says that an address was in use."""
    if isinstance(error, PortTakenError):
        return True
    if isinstance(error, OSError) and error.errno == errno.EADDRINUSE:
        return True
    return any(words in str(error) for words in _TAKEN_WORDS)
