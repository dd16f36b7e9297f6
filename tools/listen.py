"""What ``motocell echo`` and ``motocell hz`` share: the key a user names, joining the cells as
their observer (as ``watch`` does, ``tools.cells``), and the samples that arrive, stamped with
their arrival time on Zenoh's thread and handed to the command's own thread, which sleeps until
one comes or it is stopped (``tools.bell``).
"""

from __future__ import annotations

import argparse
import difflib
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass
from types import TracebackType

import zenoh

from motocell.shared.bus import catalog
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import ROUTES, Op, Role
from motocell.shared.bus.keys import ROOT
from motocell.tools import cells
from motocell.tools.bell import Bell, StopSignal
from motocell.tools.cells import TargetError

OBSERVER = Identity(Role.OBSERVER)
"""Read-only on a secured bus, as ``ps``, ``watch`` and ``record`` join."""
PUBLISHED = tuple(
    sorted(
        route.suffix for route in ROUTES if route.op is Op.PUT and Role.OBSERVER in route.receivers
    )
)
"""The keys an observer receives (the catalogue's): what KEY may name."""
QUEUE_SIZE = 10_000
"""Samples waiting for the command's thread; more are dropped (and counted) rather than stall
Zenoh's thread, which would hold back the cell's other streams to this session."""


@dataclass(frozen=True)
class Received:
    key: str
    payload: bytes
    received_ns: int
    """CLOCK_MONOTONIC when Zenoh handed the sample over."""


class Arrivals:
    """Samples handed over by Zenoh's threads, in arrival order, to the one thread that takes
    them, which sleeps while there are none (``tools.bell``). At most ``size`` wait; more are
    dropped and counted."""

    def __init__(self, size: int = QUEUE_SIZE) -> None:
        self._samples: deque[Received] = deque()
        self._size = size
        self._arrived = Bell()
        self._drops = threading.Lock()
        self.dropped = 0

    def put(self, received: Received) -> None:
        """From any thread; never blocks."""
        if len(self._samples) >= self._size:
            with self._drops:  # Zenoh calls back on several threads
                self.dropped += 1
            return
        self._samples.append(received)
        self._arrived.ring()

    def next(self, stop: StopSignal, timeout: float | None = None) -> Received | None:
        """The oldest sample not taken yet; None once ``stop`` is set, or when none came within
        ``timeout`` seconds (None: no limit)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._samples and not stop.is_set():
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                return None
            self._arrived.wait(stop, left)
        if stop.is_set() or not self._samples:
            return None
        return self._samples.popleft()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "key",
        metavar="KEY",
        help="a key after motocell/<cell>/: state, controller/status, executor/tick, "
        "group/0/queue, group/*/queue (every group), ...",
    )
    cells.add_arguments(parser, several=True)


def published_key(key: str) -> str:
    """``key`` when a cell publishes it for observers; TargetError naming the keys otherwise."""
    route = catalog.route_of(f"{ROOT}/cell/{key}")
    if route is not None and route.suffix in PUBLISHED:
        return key
    keys = f"(keys: {', '.join(PUBLISHED)})"
    if route is not None and route.op is Op.QUERY:
        raise TargetError(f"{key!r} is asked (a Zenoh query), never published {keys}")
    close = difflib.get_close_matches(key, PUBLISHED, n=1)
    hint = f"; did you mean {close[0]}?" if close else ""
    raise TargetError(f"no cell publishes {key!r}{hint} {keys}")


class Listener:
    """Every sample of ``key`` of the cells named by the command line, in arrival order."""

    def __init__(self, args: argparse.Namespace) -> None:
        """CellsError (one line, its exit status) for a key no cell publishes, a cell not
        running, or a bus that cannot be joined."""
        key = published_key(args.key)
        self._joined = cells.join_all(cells.some_targets(args), OBSERVER)
        self.arrivals = Arrivals()
        self.key_exprs = [
            f"{ROOT}/{name}/{key}" for target, _ in self._joined for name in target.names
        ]
        """What is subscribed to: ``key`` of each named cell, or of every cell (``*``)."""
        self._subscribers = [
            session.declare_subscriber(f"{ROOT}/{name}/{key}", self._on_sample)
            for target, session in self._joined
            for name in target.names
        ]

    def _on_sample(self, sample: zenoh.Sample) -> None:
        self.arrivals.put(
            Received(str(sample.key_expr), sample.payload.to_bytes(), time.monotonic_ns())
        )

    def next(self, stop: StopSignal, timeout: float | None = None) -> Received | None:
        """The next sample; None once ``stop`` is set, or when none arrived within ``timeout``
        seconds (None: no limit)."""
        return self.arrivals.next(stop, timeout)

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()
        cells.close_all(self._joined)
        dropped = self.arrivals.dropped
        if dropped:
            print(f"{dropped} sample(s) dropped: this command fell behind", file=sys.stderr)

    def __enter__(self) -> Listener:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
