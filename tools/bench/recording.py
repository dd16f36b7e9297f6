"""What the measuring child processes (``bench.state_client``, ``bench.stream_client``) share.

A measuring process must not pause while it measures: a full garbage collection of a heap of
recorded frames stops a state client's reader long enough to show up as feedback-age maxima
(docs/benchmarks.md, The benchmark must not be the slowest part). So each one records into
numpy arrays preallocated for the whole run (``Columns``: no objects per sample, a fixed bound)
and turns the collector off once set up (``freeze_gc``). Both are told to stop by a line on
stdin (``StdinControl``), never by a thread.
"""

from __future__ import annotations

import gc
import logging
import os
import select
import sys
from collections.abc import Mapping

import numpy as np

from motocell.shared.realtime import enter_reply_priority, enter_service_priority


def freeze_gc() -> None:
    """Collect once, move everything that survives out of the collector's sight, and turn the
    automatic collector off: what the measuring loop allocates is freed by reference counting
    alone (it makes no cycles), so nothing can stop the loop for a full collection."""
    gc.collect()
    gc.freeze()
    gc.disable()


def take_the_cells_priority() -> None:
    """The cell's services' SCHED_RR priority for this measuring client, where the machine
    grants it. A MotoROS client runs on hardware of its own; here it shares two cores with the
    cell, and at ordinary priority a reply it was sent waits until the cell's threads (SCHED_RR,
    docs/realtime.md), busy with the point it just accepted, let it run: a figure would time
    the scheduler instead of the cell."""
    enter_service_priority(logging.getLogger("bench"), quiet=True)


CLIENT_PRIORITIES = ("reply", "services", "ordinary")
"""What a motion client may run at: the priority of the gateway's thread that answers it
(``shared.realtime.REPLY_PRIORITY``), the cell's services', or ordinary priority."""


def take_client_priority(priority: str) -> None:
    """One of ``CLIENT_PRIORITIES`` for this motion client, where the machine grants it. At the
    services' priority its reply still waits for a CPU behind the cell's threads, all at that
    priority and busy with the point it just sent; at the gateway's own it waits for nobody in
    the cell but the clock, as a client on hardware of its own (figure 4 shows all three)."""
    if priority == "ordinary":
        return
    take_the_cells_priority()
    if priority == "reply":
        enter_reply_priority()


class Columns:
    """Rows of named int64 columns, preallocated: ``capacity`` rows at most; rows offered past
    it are counted in ``dropped`` instead of stored (the caller sizes it from the run length,
    so a drop means the run outlived its own plan, and is reported)."""

    def __init__(self, capacity: int, names: tuple[str, ...]) -> None:
        self.capacity = capacity
        self.columns = {name: np.zeros(capacity, dtype=np.int64) for name in names}
        self.rows = 0
        self.dropped = 0

    def add(self, *values: int) -> None:
        row = self.rows
        if row >= self.capacity:
            self.dropped += 1
            return
        for column, value in zip(self.columns.values(), values, strict=True):
            column[row] = value
        self.rows = row + 1

    def arrays(self) -> Mapping[str, np.ndarray]:
        """The filled rows of each column (views, not copies)."""
        return {name: column[: self.rows] for name, column in self.columns.items()}


class StdinControl:
    """Lines on stdin, read without blocking the measuring loop (one ``poll`` of the pipe).

    Reads the pipe itself (no ``sys.stdin`` buffer that could hold a line ``poll`` cannot see).
    """

    def __init__(self) -> None:
        self.fd = sys.stdin.fileno()
        self._poller = select.poll()
        self._poller.register(self.fd, select.POLLIN | select.POLLHUP)
        self._buffer = bytearray()
        self._ended = False

    def pending(self) -> bool:
        """A whole line, or the end of stdin, is waiting."""
        if b"\n" in self._buffer or self._ended:
            return True
        if self._poller.poll(0):
            self._fill()
        return b"\n" in self._buffer or self._ended

    def read_line(self) -> str:
        """The next line without its newline, blocking; EOFError at the end of stdin."""
        while b"\n" not in self._buffer and not self._ended:
            self._fill()
        end = self._buffer.find(b"\n")
        if end < 0:
            if not self._buffer:
                raise EOFError("stdin closed")
            end = len(self._buffer)
        line = bytes(self._buffer[:end])
        del self._buffer[: end + 1]
        return line.decode()

    def _fill(self) -> None:
        data = os.read(self.fd, 1 << 16)
        if data:
            self._buffer += data
        else:
            self._ended = True


def report(line: str) -> None:
    """One line to the parent (``ready``, ``done``, ``error ...``)."""
    sys.stdout.write(line + "\n")
    sys.stdout.flush()
