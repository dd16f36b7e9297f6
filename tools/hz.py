"""``motocell hz KEY``: how often a key's samples arrive, as ``rostopic hz`` reports a topic.

Every second, per key: the average rate over the last ``--window`` intervals between samples,
and the shortest, the longest and the standard deviation of those intervals. Times are when
the samples reached this command, so they include the network's and Zenoh's jitter.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections import deque

from motocell.shared.service import StopFlag, stop_on_signals
from motocell.tools import cells, listen
from motocell.tools.cells import CellsError
from motocell.tools.listen import Listener

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


class Rate:
    """The intervals between one key's samples, the last ``window`` of them."""

    def __init__(self, window: int) -> None:
        self.intervals_ns: deque[int] = deque(maxlen=window)
        self.last_ns: int | None = None
        self.new = 0
        """Samples since the last report."""

    def add(self, received_ns: int) -> None:
        if self.last_ns is not None:
            self.intervals_ns.append(received_ns - self.last_ns)
        self.last_ns = received_ns
        self.new += 1

    def report(self) -> str:
        """``average rate 100.000 Hz  min 0.0095 s  ...``, and start a new report."""
        new, self.new = self.new, 0
        if not new:
            return "no new samples"
        intervals = [ns / 1e9 for ns in self.intervals_ns]
        if not intervals:
            return "one sample so far"
        rate = len(intervals) / sum(intervals) if sum(intervals) > 0 else float("inf")
        return (
            f"average rate {rate:.3f} Hz  min {min(intervals):.4f} s  max {max(intervals):.4f} s"
            f"  std dev {statistics.pstdev(intervals):.5f} s  window {len(intervals)}"
        )


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


def report(samples: Listener, stop: StopFlag, window: int, count: int | None) -> None:
    """A report every REPORT_S once samples flow (nothing before the first, as rostopic hz),
    until ``count`` reports or ``stop``."""
    rates: dict[str, Rate] = {}
    reports = 0
    due = time.monotonic() + REPORT_S
    while not stop.is_set() and (count is None or reports < count):
        sample = samples.next(stop, timeout=max(0.0, due - time.monotonic()))
        if sample is not None:
            rates.setdefault(sample.key, Rate(window)).add(sample.received_ns)
        if time.monotonic() < due:
            continue
        due += REPORT_S
        if rates:
            for key in sorted(rates):
                print(f"{key}: {rates[key].report()}", flush=True)
            reports += 1
