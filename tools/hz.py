"""``motocell hz KEY``: how often a key's samples arrive, as ``rostopic hz`` reports a topic.

Every second, per key: the average rate over the last ``--window`` intervals between samples,
and the shortest, the longest and the standard deviation of those intervals, once the samples
mean a rate (``tools.rates``); and when the samples say that their publisher rests while
nothing moves, that too. Times are when the samples reached this command, so they include the
network's and Zenoh's jitter.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import Protocol

from motocell.shared.service import stop_on_signals
from motocell.tools import cells, listen
from motocell.tools.bell import StopSignal
from motocell.tools.cells import CellsError
from motocell.tools.listen import Listener, Received
from motocell.tools.rates import Rate

REPORT_S = 1.0
WINDOW = 1000


def add_arguments(hz: argparse.ArgumentParser) -> None:
    """The options of ``motocell hz`` (``tools.cli`` names the command)."""
    hz.description = __doc__
    listen.add_arguments(hz)
    hz.add_argument(
        "--window",
        type=int,
        default=WINDOW,
        metavar="N",
        help=f"intervals the statistics cover (default {WINDOW})",
    )
    hz.add_argument("--count", type=int, metavar="N", help="stop after N reports")
    hz.set_defaults(run=run)


class Samples(Protocol):
    """``listen.Listener``, or a test's script of samples."""

    def next(self, stop: StopSignal, timeout: float | None = None) -> Received | None: ...


def run(args: argparse.Namespace) -> int:
    if args.window < 1:
        print("motocell hz: --window must be 1 or more", file=sys.stderr)
        return 2
    with stop_on_signals() as stop:
        try:
            samples = Listener(args)
        except CellsError as exc:
            return cells.failed("hz", exc)
        with samples:
            print(f"subscribed to {', '.join(samples.key_exprs)}", flush=True)
            report(samples, stop, args.window, args.count)
    return 0


def report(
    samples: Samples,
    stop: StopSignal,
    window: int,
    count: int | None,
    clock: Callable[[], float] = time.monotonic,
) -> None:
    """A report every REPORT_S of ``clock`` once samples flow (nothing before the first, as
    rostopic hz), until ``count`` reports or ``stop``. Between reports it sleeps in
    ``samples.next``, which ``stop`` wakes."""
    rates: dict[str, Rate] = {}
    reports = 0
    due = clock() + REPORT_S
    while not stop.is_set() and (count is None or reports < count):
        sample = samples.next(stop, timeout=max(0.0, due - clock()))
        if sample is not None:
            rates.setdefault(sample.key, Rate(window)).add(sample)
        if clock() < due:
            continue
        due += REPORT_S
        if rates:
            for key in sorted(rates):
                print(f"{key}: {rates[key].report()}", flush=True)
            reports += 1
