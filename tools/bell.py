"""A wake-up for a command's thread that waits for samples: Zenoh's threads ring it as they hand
samples over, and the command sleeps until a ring, its stop flag (Ctrl-C) or its deadline,
instead of waking every so often to look (``echo``, ``hz``, ``watch``'s first frame)."""

from __future__ import annotations

import contextlib
import math
import os
import select
import weakref
from typing import Protocol


class StopSignal(Protocol):
    """``shared.service.StopFlag``: set by a signal, readable on ``fileno`` once set."""

    def is_set(self) -> bool: ...

    def fileno(self) -> int: ...


class Bell:
    """Rung from any thread, waited for by one, together with a stop flag. A ring while no one
    waits is kept until the next wait, which then returns at once: a ring between the waiter's
    last look and its wait is never lost."""

    def __init__(self) -> None:
        self._read, self._write = os.pipe()
        os.set_blocking(self._read, False)
        os.set_blocking(self._write, False)
        # Closed once nothing can ring or wait any more (Zenoh's callbacks hold the owner until
        # their subscriber goes), so no ring ever writes to a closed or reused descriptor.
        weakref.finalize(self, _close, self._read, self._write)

    def ring(self) -> None:
        with contextlib.suppress(BlockingIOError):  # the pipe is full: rung many times already
            os.write(self._write, b"\0")

    def wait(self, stop: StopSignal, timeout: float | None) -> bool:
        """Until a ring since the last wait, ``stop``, or ``timeout`` seconds (None: no limit);
        whether it was rung. Every ring before it returns is taken."""
        poller = select.poll()
        poller.register(self._read, select.POLLIN)
        if not stop.is_set():
            poller.register(stop.fileno(), select.POLLIN)
            poller.poll(None if timeout is None else max(0, math.ceil(timeout * 1000)))
        rung = False
        with contextlib.suppress(BlockingIOError):
            while os.read(self._read, 4096):
                rung = True
        return rung


def _close(*fds: int) -> None:
    for fd in fds:
        os.close(fd)
