"""A delay line for the links of ``scripts/multihost``, where the kernel has no ``tc netem``
(``sch_netem``: this machine's has not).

Each delayed host's link is a pair of TAP devices the script creates: the host's interface
(moved into its namespace once this process holds it) and the host's port on the bridge. A
frame the host sends waits the delay, then enters the bridge; a frame towards the host passes
at once. A frame between two hosts therefore waits once: the delay is one way, exactly what
``tc qdisc add dev eth0 root netem delay MS`` on every host's interface gives. A TAP device
has no checksum or segmentation offload, so every frame is whole, checksummed and at most one
MTU, as on a wire.

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


def open_tap(name: str) -> int:
    """The TAP device ``name`` (created by the script), non-blocking, frames without a packet
    information header."""
    descriptor = os.open("/dev/net/tun", os.O_RDWR | os.O_NONBLOCK)
    fcntl.ioctl(descriptor, TUNSETIFF, struct.pack("16sH", name.encode(), IFF_TAP | IFF_NO_PI))
    return descriptor


def carry(pairs: Sequence[tuple[int, int]], delay_ns: int) -> None:
    """Forever: frames from each host (first of a pair) to its port after ``delay_ns``,
    frames from each port to its host at once. One delay for every frame keeps the waiting
    frames in arrival order, so one queue serves every link."""
    towards = {host: port for host, port in pairs} | {port: host for host, port in pairs}
    hosts = {host for host, _ in pairs}
    waiting: deque[tuple[int, int, bytes]] = deque()
    while True:
        timeout = None
        if waiting:
            timeout = max(0.0, (waiting[0][0] - time.monotonic_ns()) / 1e9)
        readable, _, _ = select.select(list(towards), [], [], timeout)
        now = time.monotonic_ns()
        for source in readable:
            for frame in _frames(source):
                if source in hosts:
                    waiting.append((now + delay_ns, towards[source], frame))
                else:
                    _send(towards[source], frame)
        while waiting and waiting[0][0] <= now:
            _, target, frame = waiting.popleft()
            _send(target, frame)


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
        pairs.append((open_tap(host), open_tap(port)))
    print("ready", flush=True)
    carry(pairs, round(args.delay_ms * 1e6))
    return 0


if __name__ == "__main__":
    sys.exit(main())
