"""What ``motocell echo`` and ``motocell hz`` share: the key a user names, joining the cells as
their observer (as ``watch`` does, ``tools.cells``), and the samples that arrive, stamped with
their arrival time on Zenoh's thread and handed to the command's own thread.
"""

from __future__ import annotations

import argparse
import difflib
import queue
import sys
import time
from dataclasses import dataclass
from types import TracebackType

import zenoh

from motocell.shared.bus import catalog
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import ROUTES, Op, Role
from motocell.shared.bus.keys import ROOT
from motocell.tools import cells
from motocell.tools.cells import TargetError

OBSERVER = Identity(Role.OBSERVER)
"""Read-only on a secured bus, as ``ps``, ``watch`` and ``record`` join."""
PUBLISHED = tuple(
    sorted(
        route.suffix for route in ROUTES if route.op is Op.PUT and Role.OBSERVER in route.receivers
    )
)
"""The keys an observer receives (the catalogue's): what KEY may name."""
POLL_S = 0.1
"""How often a command waiting for samples looks at its stop flag."""
QUEUE_SIZE = 10_000
"""Samples waiting for the command's thread; more are dropped (and counted) rather than stall
Zenoh's thread, which would hold back the cell's other streams to this session."""


@dataclass(frozen=True)
class Received:
    key: str
    payload: bytes
    received_ns: int
    """CLOCK_MONOTONIC when Zenoh handed the sample over."""


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
        self._queue: queue.Queue[Received] = queue.Queue(QUEUE_SIZE)
        self.dropped = 0
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
        received = Received(str(sample.key_expr), sample.payload.to_bytes(), time.monotonic_ns())
        try:
            self._queue.put_nowait(received)
        except queue.Full:
            self.dropped += 1

    def next(self, timeout: float) -> Received | None:
        """The next sample, or None when none arrived within ``timeout`` seconds."""
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()
        cells.close_all(self._joined)
        if self.dropped:
            print(f"{self.dropped} sample(s) dropped: this command fell behind", file=sys.stderr)

    def __enter__(self) -> Listener:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
