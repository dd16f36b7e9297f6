"""What ``motocell hz`` says of one key, without Zenoh or a clock: the rate of its samples once
they mean one, and whether the samples say that their publisher rests. Pure: times are the
samples' arrival stamps (``listen.Received.received_ns``).
"""

from __future__ import annotations

import statistics
from collections import deque

import msgspec

from motocell.shared.bus import catalog
from motocell.shared.bus.liveness import AT_REST_HEARTBEAT_S, heartbeat_ms
from motocell.shared.bus.schemas import ControllerStatus, QueueState, State, Tick
from motocell.tools.listen import Received

MIN_SAMPLES = 3
"""A rate needs two intervals at least: one alone is whatever gap two samples had, and two
samples that came back to back would read as hundreds of hertz on a key sent once a second."""
MIN_SPAN_S = 0.5
"""A rate also needs samples that came over half a second at least: the first report
(``hz.REPORT_S`` after subscribing) still gives a fast key's rate, and a burst gives none."""
AT_REST_BEAT = f"every {AT_REST_HEARTBEAT_S:g} s"


class Rate:
    """The intervals between one key's samples, the last ``window`` of them, and the samples
    the report needs to tell whether their publisher rests."""

    def __init__(self, window: int) -> None:
        self.intervals_ns: deque[int] = deque(maxlen=window)
        self.first_ns: int | None = None
        self.samples = 0
        self.before: Received | None = None
        self.latest: Received | None = None
        self.new = 0
        """Samples since the last report."""

    def add(self, sample: Received) -> None:
        if self.latest is None:
            self.first_ns = sample.received_ns
        else:
            self.intervals_ns.append(sample.received_ns - self.latest.received_ns)
        self.before, self.latest = self.latest, sample
        self.samples += 1
        self.new += 1

    def report(self) -> str:
        """``average rate 100.000 Hz  min 0.0095 s  ...`` once the samples mean a rate, what
        came so far before then; then why it is slow, if the samples say their publisher
        rests. A new report starts."""
        new, self.new = self.new, 0
        if not new or self.latest is None or self.first_ns is None:
            return "no new samples"
        span_s = (self.latest.received_ns - self.first_ns) / 1e9
        if self.samples < MIN_SAMPLES or span_s < MIN_SPAN_S:
            shown = (
                f"{_samples(self.samples)} over {span_s:.3f} s: too few for a rate"
                f" (it takes {MIN_SAMPLES} over {MIN_SPAN_S:g} s)"
            )
        else:
            shown = _statistics([ns / 1e9 for ns in self.intervals_ns])
        resting = rest_note(self.before, self.latest)
        return shown if resting is None else f"{shown}; {resting}"


def _samples(n: int) -> str:
    return "1 sample" if n == 1 else f"{n} samples"


def _statistics(intervals: list[float]) -> str:
    total = sum(intervals)
    rate = len(intervals) / total if total > 0 else float("inf")
    return (
        f"average rate {rate:.3f} Hz  min {min(intervals):.4f} s  max {max(intervals):.4f} s"
        f"  std dev {statistics.pstdev(intervals):.5f} s  window {len(intervals)}"
    )


def rest_note(before: Received | None, latest: Received) -> str | None:
    """What the newest samples say of a publisher that rests while nothing moves (the rules
    in docs/timing.md, Heartbeats), or None when they say it does not, or nothing."""
    newest = _decoded(latest)
    if isinstance(newest, Tick) and newest.resting:
        return f"the executor's clock rests while nothing moves: its last tick again {AT_REST_BEAT}"
    if isinstance(newest, ControllerStatus | QueueState) and newest.heartbeat_ms == heartbeat_ms(
        motion_possible=False
    ):
        return (
            f"at rest, nothing can move: sent on change and every {newest.heartbeat_ms / 1000:g} s"
        )
    previous = None if before is None else _decoded(before)
    if isinstance(newest, State) and isinstance(previous, State) and previous.tick == newest.tick:
        return (
            f"nothing moves (tick {newest.tick} again): sent {AT_REST_BEAT}, or every state period"
            " while a client is on the state port"
        )
    return None


def _decoded(sample: Received) -> msgspec.Struct | None:
    try:
        return catalog.decode(sample.key, sample.payload)
    except msgspec.DecodeError:  # a newer schema, or a stranger's sample on an open bus
        return None
