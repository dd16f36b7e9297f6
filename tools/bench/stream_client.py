"""The cell's motion client in its own process, for every figure that moves (3-8).

    python -m motocell.tools.bench.stream_client --port P [--host H] [--byte-order little|big]

It holds the one motion-port connection for a whole figure and runs jobs, one JSON line each on
stdin (``Requests`` or ``Stream``, below), answering ``done`` (or ``error ...``) on stdout once
the job's record is in its ``out`` .npz. Running it in a process of its own keeps its round
trips free of the benchmark process's Zenoh callbacks (one GIL shared with 250 Hz observers
inflated them); the garbage collector is off while it measures and every round trip goes into
arrays sized for the job up front (``tools.bench.recording``).

Streaming is motoman_driver's: send a point, read the reply, resend it ``busy_retry_s`` (5 ms)
after a BUSY, stop at any other failure. A paced stream sends point i no earlier than
i x ``pace_s`` after the first. ``probes``: requests sent in turn, one at the start of every
BUSY back-off, to time other requests under the same load. A ``stop`` line ends a stream early
and sends STOP_MOTION, which clears the queues.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import math
import time
from collections.abc import Mapping

import msgspec
import numpy as np

from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import Command, Result, describe_reply
from motocell.shared.protocol.messages import Message, MotoMotionReply
from motocell.shared.protocol.replies import motion_ctrl
from motocell.testing.client import MotionClient
from motocell.tools.bench.recording import (
    CLIENT_PRIORITIES,
    Columns,
    StdinControl,
    freeze_gc,
    report,
    take_client_priority,
)

BUSY_RETRY_S = 0.005
"""motoman_driver resends a BUSY point after 5 ms."""


class Requests(msgspec.Struct, frozen=True, tag="requests"):
    """One request frame sent ``count`` times, one at a time (its round trips and results)."""

    frame: bytes
    count: int
    out: str


class Stream(msgspec.Struct, frozen=True, tag="stream"):
    """Points streamed like motoman_driver (module docstring)."""

    frames: list[bytes]
    seconds: float
    """The longest the stream may take; sizes its record (``stream_capacity``)."""
    out: str
    busy_retry_s: float = BUSY_RETRY_S
    pace_s: float = 0.0
    probes: list[bytes] = msgspec.field(default_factory=list)


Job = Requests | Stream
JOB = msgspec.json.Decoder(Job)


def stream_capacity(points: int, seconds: float, busy_retry_s: float) -> int:
    """Requests a stream can make in ``seconds``: each point's SUCCESS, plus at most one BUSY
    per back-off (every BUSY is followed by ``busy_retry_s`` of sleep); probes fewer still."""
    return points + math.ceil(seconds / busy_retry_s) + 1


class Link:
    """Request frames out, the reply's result back."""

    def __init__(self, client: MotionClient) -> None:
        self.sock = client.sock
        self.reader = client.reader
        self.stop_motion = client.reader.codec.send(motion_ctrl(Command.STOP_MOTION))

    def exchange(self, frame: bytes) -> tuple[int, int]:
        """(result, subcode) of the reply to ``frame``."""
        self.sock.sendall(frame)
        reply = self.reader.next()
        if not isinstance(reply, Message) or not isinstance(reply.body, MotoMotionReply):
            raise RuntimeError(f"expected a MOTO_MOTION_REPLY, got {reply}")
        return reply.body.result, reply.body.subcode


def run_requests(link: Link, job: Requests) -> Mapping[str, np.ndarray]:
    record = Columns(job.count, ("rtt_ns", "result", "subcode"))
    for _ in range(job.count):
        sent = time.monotonic_ns()
        result, subcode = link.exchange(job.frame)
        record.add(time.monotonic_ns() - sent, result, subcode)
    return record.arrays()


class Streaming:
    """One ``Stream`` job's state and record."""

    def __init__(self, link: Link, job: Stream, control: StdinControl) -> None:
        self.link, self.job, self.control = link, job, control
        size = stream_capacity(len(job.frames), job.seconds, job.busy_retry_s)
        self.replies = Columns(size, ("sent_ns", "rtt_ns", "result"))
        self.probes = Columns(size, ("probe_rtt_ns", "probe_index"))
        self.accepted_ns = np.zeros(len(job.frames), dtype=np.int64)
        self.points = self.busy = self.first_sent_ns = 0
        self.error = ""

    def run(self) -> None:
        job = self.job
        pace_ns = round(job.pace_s * 1e9)
        self.first_sent_ns = time.monotonic_ns()
        for index, frame in enumerate(job.frames):
            if pace_ns:
                wait_ns = self.first_sent_ns + index * pace_ns - time.monotonic_ns()
                if wait_ns > 0:
                    time.sleep(wait_ns / 1e9)
            reply = self._send_until_taken(frame)
            if reply is None:
                self.link.exchange(self.link.stop_motion)
                return
            if reply[0] != Result.SUCCESS:
                self.error = f"point {index} refused: {describe_reply(*reply)}"
                return
            self.accepted_ns[index] = time.monotonic_ns()
            self.points += 1

    def _send_until_taken(self, frame: bytes) -> tuple[int, int] | None:
        """The first reply other than BUSY (result, subcode); None when told to stop first."""
        retry_ns = round(self.job.busy_retry_s * 1e9)
        while True:
            if self.control.pending():
                with contextlib.suppress(EOFError):  # the parent is gone: stop as well
                    self.control.read_line()
                return None
            sent = time.monotonic_ns()
            result, subcode = self.link.exchange(frame)
            replied = time.monotonic_ns()
            self.replies.add(sent, replied - sent, result)
            if result != Result.BUSY:
                return result, subcode
            self.busy += 1
            if self.job.probes:
                self._probe(self.busy % len(self.job.probes))
            time.sleep(max(0, replied + retry_ns - time.monotonic_ns()) / 1e9)

    def _probe(self, index: int) -> None:
        sent = time.monotonic_ns()
        self.link.exchange(self.job.probes[index])
        self.probes.add(time.monotonic_ns() - sent, index)

    def arrays(self) -> Mapping[str, np.ndarray]:
        accepted = self.accepted_ns[self.accepted_ns > 0]
        return {
            **self.replies.arrays(),
            **self.probes.arrays(),
            "accepted_ns": self.accepted_ns,
            "points": np.array(self.points),
            "busy": np.array(self.busy),
            "first_sent_ns": np.array(self.first_sent_ns),
            "last_accepted_ns": np.array(accepted.max() if accepted.size else 0),
            "dropped": np.array(self.replies.dropped + self.probes.dropped),
            "error": np.array(self.error),
        }


def serve(link: Link, control: StdinControl) -> None:
    """Jobs until the end of stdin; a ``stop`` line between jobs (its stream already ended
    by itself) is ignored."""
    while True:
        try:
            line = control.read_line()
        except EOFError:
            return
        if line in ("", "stop"):
            continue
        job = JOB.decode(line)
        gc.collect()
        gc.freeze()
        try:
            if isinstance(job, Requests):
                arrays = run_requests(link, job)
            else:
                streaming = Streaming(link, job, control)
                streaming.run()
                arrays = streaming.arrays()
            np.savez(job.out, allow_pickle=False, **arrays)
        except (OSError, RuntimeError, ValueError) as exc:
            report(f"error {type(exc).__name__}: {exc}")
            continue
        report("done")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--byte-order", choices=[o.value for o in ByteOrder], default="little")
    parser.add_argument(
        "--priority",
        choices=CLIENT_PRIORITIES,
        default="services",
        help="the gateway's reply priority, the cell's services' (the default), or ordinary, "
        "as a driver beside the cell on one machine runs",
    )
    args = parser.parse_args(argv)
    take_client_priority(args.priority)
    with MotionClient(args.host, args.port, ByteOrder(args.byte_order)) as client:
        control = StdinControl()
        freeze_gc()
        report("ready")
        serve(Link(client), control)


if __name__ == "__main__":
    main()
