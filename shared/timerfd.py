"""A CLOCK_MONOTONIC deadline as a file descriptor (Linux's timerfd, called through libc, since
Python has ``os.timerfd_*`` only from 3.13): one thread sleeps in ``poll`` on it while another
moves the deadline, earlier or later, without waking it. A sleep with a timeout cannot do that:
a deadline moved later costs the sleeper a wake-up at the old one.
"""

from __future__ import annotations

import ctypes
import os
import time

_TFD_TIMER_ABSTIME = 1
_NS = 1_000_000_000


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


class _Itimerspec(ctypes.Structure):
    _fields_ = [("it_interval", _Timespec), ("it_value", _Timespec)]


_libc = ctypes.CDLL(None, use_errno=True)
_libc.timerfd_create.argtypes = [ctypes.c_int, ctypes.c_int]
_libc.timerfd_settime.argtypes = [
    ctypes.c_int,
    ctypes.c_int,
    ctypes.POINTER(_Itimerspec),
    ctypes.POINTER(_Itimerspec),
]


def _checked(result: int) -> int:
    if result < 0:
        errno = ctypes.get_errno()
        raise OSError(errno, os.strerror(errno))
    return result


class DeadlineTimer:
    """One deadline at a time, on CLOCK_MONOTONIC; readable (``fileno``) once it has passed,
    until ``take``. Not periodic: each deadline fires once. ``set`` from one thread at a time
    (it fills one setting it keeps, rather than making one per call)."""

    def __init__(self) -> None:
        self._fd = _checked(
            _libc.timerfd_create(time.CLOCK_MONOTONIC, os.O_NONBLOCK | os.O_CLOEXEC)
        )
        self._spec = _Itimerspec()

    def fileno(self) -> int:
        return self._fd

    def set(self, deadline_ns: int | None) -> None:
        """Fire at ``deadline_ns`` (CLOCK_MONOTONIC; at once if it has passed) instead of the
        deadline set before; None: never. A deadline replaced before ``take`` is not seen."""
        value = self._spec.it_value
        if deadline_ns is None:
            value.tv_sec = value.tv_nsec = 0  # all zero disarms the timer
        else:
            # An absolute zero would disarm it too: the earliest instant is 1 ns.
            value.tv_sec, value.tv_nsec = divmod(max(deadline_ns, 1), _NS)
        _checked(_libc.timerfd_settime(self._fd, _TFD_TIMER_ABSTIME, self._spec, None))

    def take(self) -> bool:
        """Whether the deadline passed since it was set; it is then taken (not readable)."""
        try:
            os.read(self._fd, 8)
        except BlockingIOError:
            return False
        return True

    def close(self) -> None:
        os.close(self._fd)
