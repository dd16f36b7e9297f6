"""``motocell record``: every sample of one or more cells, with its receive time, into an MCAP file.

By default every cell running here, each through its own router (``tools.cells`` finds them);
``--zenoh-connect`` reaches a cell elsewhere. A secured cell is joined as its read-only
observer and recorded key by key as the catalogue lists what an observer may receive (nothing
else can travel on it); an open bus is recorded whole, keys the catalogue does not know too.

The file opens as-is in Foxglove and the ``mcap`` CLI (info, cat, doctor): one channel per key,
the payloads the catalogue knows as JSON with their JSON Schema, anything else as the raw msgpack
(``tools.recording`` has the layout). Zenoh's threads only stamp and queue each sample; one
writer thread writes the file, and hands it to the file system at least every ``FLUSH_S``.
Ctrl-C (SIGINT) or SIGTERM ends the recording normally: the file gets its summary, and the
closing lines count what it holds. A recorder killed outright (SIGKILL, a power cut) leaves a
file without a summary, which ``mcap``'s ``make_reader`` refuses and its ``StreamReader``
reads up to the cut: its first sample is flushed at once, then at least every ``FLUSH_S``, so
it holds all but about the last half second. ``motocell plot`` reads it and says it was cut;
``--repair`` writes a copy with its summary (docs/observing.md says which readers open what).
"""

from __future__ import annotations

import argparse
import queue
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import zenoh

from motocell.shared.bus.catalog import ROUTES, Op, Role
from motocell.shared.bus.keys import ROOT
from motocell.shared.config import Cell
from motocell.shared.service import StopFlag, stop_on_signals
from motocell.tools import cell_files, cells
from motocell.tools.cell_files import Joined
from motocell.tools.cells import Target


class Sink(Protocol):
    """Where the recorder's writer thread puts each sample: an MCAP file (``McapSink``)."""

    def write(self, received_ns: int, key: str, data: bytes) -> None: ...

    def flush(self) -> None: ...

    def finish(self) -> None: ...


QUEUE_SIZE = 100_000
"""Samples waiting for the writer: about 100 s of one busy cell, a few tens of MB at most. A
writer that falls further behind than that loses samples (counted) instead of memory."""

FLUSH_S = 0.5
"""How long a sample may wait in the writer's chunk before it reaches the file: what a
recorder killed outright (SIGKILL, a power cut) loses at most, beside its queue, so that with
the writer's lag on a loaded machine it stays within about a second. Each flush ends an MCAP
chunk; a chunk of half a second still compresses well, and costs a few hundred bytes of
indexes."""

OBSERVED = tuple(
    route.suffix for route in ROUTES if route.op is Op.PUT and Role.OBSERVER in route.receivers
)
"""What an observer of a secured cell may receive: its router refuses a wider subscription
(``motocell/<cell>/**``) outright."""

# --------------------------------------------------------------------------- the recorder


class Recorder:
    """Zenoh callbacks only stamp and queue a sample; one writer thread writes the file.

    A writing error (a full disk) sets ``stop``: the recording ends and the command fails.
    """

    def __init__(self, sink: Sink, stop: StopFlag) -> None:
        self.sink = sink
        self.stop = stop
        self.queue: queue.Queue[tuple[int, str, bytes] | None] = queue.Queue(QUEUE_SIZE)
        self.dropped = 0
        """Samples lost to a full queue. Zenoh runs callbacks on several threads, and ``+=``
        is a read and a write another thread can come between: counted under a lock, which
        only a drop takes."""
        self._dropped_lock = threading.Lock()
        self.error: Exception | None = None
        self._thread = threading.Thread(target=self._drain, name="recorder", daemon=True)

    def start(self) -> None:
        """Start the writer thread; ``close`` ends it."""
        self._thread.start()

    def on_sample(self, sample: zenoh.Sample) -> None:
        """Runs on a Zenoh thread: nothing here may block or write."""
        received_ns = time.time_ns()
        try:
            self.queue.put_nowait((received_ns, str(sample.key_expr), sample.payload.to_bytes()))
        except queue.Full:
            with self._dropped_lock:
                self.dropped += 1

    def _drain(self) -> None:
        flushes = Flushes()
        while True:
            try:
                item = self.queue.get(timeout=_until(flushes.due))
            except queue.Empty:  # quiet for a while: hand the file what waits
                item = _FLUSH
            if item is None:  # the stop marker
                return
            if self.error is not None:
                continue  # keep emptying the queue so the stop marker gets through
            try:
                if item is not _FLUSH:
                    self.sink.write(*item)
                    flushes.wrote(time.monotonic())
                if flushes.is_due(time.monotonic()):
                    self.sink.flush()
                    flushes.flushed()
            except Exception as exc:  # a full disk, a closed file: report it, stop recording
                self.error = exc
                self.stop.set()

    def close(self) -> None:
        """Write everything queued, then the summary. Call once no callback can run any more."""
        self.queue.put(None)
        self._thread.join()
        if self.error is None:
            try:
                self.sink.finish()
            except OSError as exc:  # the summary did not fit on the disk
                self.error = exc


_FLUSH = (0, "", b"")
"""Not a sample: the writer's own reminder that a flush is due."""


class Flushes:
    """When the writer hands the file what the sink holds (times on ``time.monotonic``).

    The first sample at once: it brings the channels and schemas, so a recorder killed at any
    moment after its first sample leaves a file that holds it. After that, at most ``FLUSH_S``
    after the oldest sample not yet flushed, so a kill loses at most that and the queue."""

    def __init__(self) -> None:
        self.due: float | None = None
        """When what the sink holds unflushed must reach the file (None: nothing waits)."""
        self._first = True

    def wrote(self, now: float) -> None:
        """A sample went into the sink at ``now``."""
        if self.due is None:
            self.due = now if self._first else now + FLUSH_S

    def is_due(self, now: float) -> bool:
        return self.due is not None and now >= self.due

    def flushed(self) -> None:
        self.due = None
        self._first = False


def _until(deadline: float | None) -> float | None:
    """How long to wait for the next sample before ``deadline`` (None: as long as it takes)."""
    return None if deadline is None else max(0.0, deadline - time.monotonic())


def run_recorder(
    sink: Sink, subscriptions: list[tuple[zenoh.Session, str]], duration: float | None, ready: str
) -> Recorder:
    """Every sample on ``subscriptions`` (session, key expression) into ``sink`` until Ctrl-C,
    SIGTERM, ``duration`` seconds or a failed write; ``ready`` printed once subscribed. The
    recorder returned, closed, says what went wrong (``error``) and what was lost (``dropped``).
    Outside the main thread (a caller's thread) no signal stops it; ``duration`` does."""
    with stop_on_signals() as stop:
        recorder = Recorder(sink, stop)
        recorder.start()
        try:
            subscribed_until_stopped(recorder.on_sample, subscriptions, ready, stop, duration)
        finally:
            recorder.close()
    return recorder


def subscribed_until_stopped(
    on_sample: Callable[[zenoh.Sample], None],
    subscriptions: list[tuple[zenoh.Session, str]],
    ready: str,
    stop: StopFlag,
    duration: float | None,
) -> None:
    """Every sample on ``subscriptions`` (session, key expression) to ``on_sample``, on Zenoh's
    threads, from when ``ready`` is printed until ``stop`` or ``duration`` seconds."""
    subscribers = [s.declare_subscriber(e, on_sample) for s, e in subscriptions]
    print(ready, flush=True)
    stop.wait(duration)
    for subscriber in subscribers:
        subscriber.undeclare()


# --------------------------------------------------------------------------- the command


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell record`` (``tools.cli`` names the command)."""
    parser.description = __doc__
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("out", metavar="OUT", help="the MCAP file to write (replaced if present)")
    parser.add_argument(
        "--repair",
        metavar="CUT",
        help="record nothing: write OUT from CUT, a recording whose recorder was killed, with "
        "the summary that indexed MCAP readers (mcap's make_reader) need",
    )
    cell_files.add_arguments(parser)
    cells.add_arguments(parser, several=True)
    parser.set_defaults(run=run)


def key_exprs(target: Target) -> list[str]:
    if target.credentials is None:
        return [f"{ROOT}/{name}/**" for name in target.names]
    return [f"{ROOT}/{cell}/{suffix}" for cell in target.cells for suffix in OBSERVED]


def run(args: argparse.Namespace) -> int:
    if args.repair is not None:
        return _repair(Path(args.repair), Path(args.out))
    return cell_files.observe(args, "record", lambda joined, known: _record(joined, known, args))


def _repair(cut: Path, out: Path) -> int:
    """``out``: what ``cut`` holds, as a whole file (``recording.repair``)."""
    from motocell.tools.recording import MCAP_MAGIC, Recording, repair  # noqa: PLC0415

    try:
        with cut.open("rb") as stream:
            magic = stream.read(len(MCAP_MAGIC))
    except OSError as exc:
        print(f"motocell record: cannot read {cut}: {exc.strerror}", file=sys.stderr)
        return 2
    if magic != MCAP_MAGIC:
        print(f"motocell record: {cut}: not an MCAP file, nothing to repair", file=sys.stderr)
        return 2
    if out.exists() and out.samefile(cut):
        print(
            f"motocell record: --repair would write over {cut} while reading it: give OUT a "
            "new name",
            file=sys.stderr,
        )
        return 2
    recording = Recording(cut)
    try:
        with out.open("wb") as stream:
            copied = repair(recording, stream)
    except OSError as exc:
        print(f"motocell record: writing {out} failed: {exc}", file=sys.stderr)
        return 1
    held = "all it held before its cut" if recording.cut else "it was whole"
    print(f"wrote {out}: {copied} messages from {cut} ({held}), with its summary")
    return 0


def _record(joined: Joined, known: dict[str, Cell], args: argparse.Namespace) -> int:
    # mcap is in the tools extra: imported by this command only, not by every `motocell`.
    from motocell.tools.recording import McapSink  # noqa: PLC0415

    try:
        stream = open(args.out, "wb")  # noqa: SIM115 -- closed below, after the summary
    except OSError as exc:
        print(f"motocell record: cannot write {args.out}: {exc}", file=sys.stderr)
        return 1
    started = time.monotonic()
    with stream:

        def announce(key: str, encoding: str, payload: str) -> None:
            # Runs on the writer thread; tells an operator (and tests) what is arriving.
            print(f"+ {key} ({encoding}, {payload})", flush=True)

        sink = McapSink(stream, on_new_channel=announce, cells=known)
        exprs = [(session, expr) for target, session in joined for expr in key_exprs(target)]
        sink.metadata(
            "motocell.recording",
            {
                "key_exprs": " ".join(expr for _, expr in exprs),
                "zenoh_connect": " ".join(target.endpoint for target, _ in joined),
                "started_unix_ns": str(time.time_ns()),
            },
        )
        # The header and the metadata on disk before any sample: killed before the first
        # one, the file is an empty recording that readers open, not a bare file.
        try:
            sink.flush()
        except OSError as exc:
            print(f"motocell record: writing {args.out} failed: {exc}", file=sys.stderr)
            return 1
        where = ", ".join(target.describe() for target, _ in joined)
        ready = f"recording {where} into {args.out}; Ctrl-C to stop"
        recorder = run_recorder(sink, exprs, args.duration, ready)
    elapsed = time.monotonic() - started
    if recorder.error is not None:
        print(f"motocell record: writing {args.out} failed: {recorder.error}", file=sys.stderr)
        return 1
    _report(args.out, recorder.dropped, elapsed)
    return 0


def _report(out: str, dropped: int, elapsed: float) -> None:
    """What the file holds, as its own summary counts it: the keys' channels and the view's."""
    from motocell.tools.recording import channel_counts  # noqa: PLC0415

    channels = sorted(channel_counts(out))
    total = sum(count for _, count in channels)
    print(f"wrote {out}: {total} messages on {len(channels)} channels in {elapsed:.1f} s")
    for topic, count in channels:
        print(f"{count:>9}  {topic}")
    if dropped:
        print(
            f"motocell record: {dropped} samples dropped (the writer fell behind)",
            file=sys.stderr,
        )
