"""A delay line for the links of ``scripts/multihost``, where the kernel has no ``tc netem``
(``sch_netem``: this machine's has not).

Each delayed host's link is a pair of TAP devices the script creates: the host's interface
(moved into its namespace once this process holds it) and the host's port on the bridge. A
frame the host sends waits the delay, then enters the bridge; a frame towards the host passes
at once. A frame between two hosts therefore waits once: the delay is one way, exactly what
``tc qdisc add dev eth0 root netem delay MS`` on every host's interface gives. A TAP device
has no checksum or segmentation offload, so every frame is whole, checksummed and at most one
MTU, as on a wire. As netem, it holds at most 1000 frames per link and drops what comes
beyond.

    python -m motocell.tools.delay_line --delay-ms 10 HOST_TAP:PORT_TAP [...]

It prints ``ready`` once it holds every device, and runs until killed.
"""

from __future__ import annotations

import argparse
import contextlib
import fcntl
import os
import select
import struct
import sys
import time
from collections import deque
from collections.abc import Sequence

TUNSETIFF = 0x400454CA
IFF_TAP, IFF_NO_PI = 0x0002, 0x1000
FRAME_MAX = 65_536
FRAMES_PER_LINK = 1000
"""What the line holds per link before it drops: netem's default ``limit``."""


class Line:
    """Which frame goes where and when, without I/O: frames from a host wait ``delay_ns``,
    frames towards a host go at once. One delay for every frame keeps the waiting frames in
    arrival order, so one queue serves every link."""

    def __init__(self, pairs: Sequence[tuple[int, int]], delay_ns: int) -> None:
        self.towards = {host: port for host, port in pairs} | {port: host for host, port in pairs}
        self.hosts = {host for host, _ in pairs}
        self.delay_ns = delay_ns
        self.limit = FRAMES_PER_LINK * len(pairs)
        self.waiting: deque[tuple[int, int, bytes]] = deque()
        self.dropped = 0

    def take(self, source: int, frame: bytes, now_ns: int) -> tuple[int, bytes] | None:
        """A frame read from ``source``: (target, frame) to write now, or None (it waits, or
        the line is full and drops it)."""
        target = self.towards[source]
        if source not in self.hosts:
            return target, frame
        if len(self.waiting) >= self.limit:
            self.dropped += 1
        else:
            self.waiting.append((now_ns + self.delay_ns, target, frame))
        return None

    def due(self, now_ns: int) -> list[tuple[int, bytes]]:
        """The waiting frames whose delay is over, oldest first."""
        frames = []
        while self.waiting and self.waiting[0][0] <= now_ns:
            _, target, frame = self.waiting.popleft()
            frames.append((target, frame))
        return frames

    def timeout_s(self, now_ns: int) -> float | None:
        """How long until the next waiting frame is due (None: nothing waits)."""
        if not self.waiting:
            return None
        return max(0.0, (self.waiting[0][0] - now_ns) / 1e9)


def open_tap(name: str) -> int:
    """The TAP device ``name`` (created by the script), non-blocking, frames without a packet
    information header."""
    descriptor = os.open("/dev/net/tun", os.O_RDWR | os.O_NONBLOCK)
    fcntl.ioctl(descriptor, TUNSETIFF, struct.pack("16sH", name.encode(), IFF_TAP | IFF_NO_PI))
    return descriptor


def carry(line: Line) -> None:
    """Forever: every frame the devices give, where and when ``line`` says. The first frame it
    drops is said once in its log: a measurement made while it dropped is not the delay's
    alone."""
    told_dropping = False
    while True:
        timeout = line.timeout_s(time.monotonic_ns())
        readable, _, _ = select.select(list(line.towards), [], [], timeout)
        now = time.monotonic_ns()
        for source in readable:
            for frame in _frames(source):
                passing = line.take(source, frame, now)
                if passing is not None:
                    _send(*passing)
        for target, frame in line.due(now):
            _send(target, frame)
        if line.dropped and not told_dropping:
            print(f"dropping frames: {line.limit} wait already", file=sys.stderr, flush=True)
            told_dropping = True


def _frames(descriptor: int) -> list[bytes]:
    frames = []
    while True:
        try:
            frames.append(os.read(descriptor, FRAME_MAX))
        except BlockingIOError:
            return frames


def _send(descriptor: int, frame: bytes) -> None:
    """A frame a link cannot take now (its device down or gone) is lost, as on a wire."""
    with contextlib.suppress(OSError):
        os.write(descriptor, frame)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m motocell.tools.delay_line", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--delay-ms", type=float, required=True)
    parser.add_argument("links", nargs="+", metavar="HOST_TAP:PORT_TAP")
    args = parser.parse_args(argv)
    pairs = []
    for link in args.links:
        host, _, port = link.partition(":")
        try:
            pairs.append((open_tap(host), open_tap(port)))
        except OSError as exc:
            print(f"delay_line: cannot open the TAP devices of {link}: {exc}", file=sys.stderr)
            return 1
    print("ready", flush=True)
    carry(Line(pairs, round(args.delay_ms * 1e6)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
