"""TCP ports on this machine: whether one is free, and free ones to use.

Free ports are picked below the kernel's ephemeral range. A port from that range (what binding
port 0 gives) can be handed to any outgoing connection between the moment it is found free and
the moment its owner binds it, and the cell then cannot listen ("Address already in use").
Below the range only a process that picks its ports
the same way can collide, and each pick is random.
"""

from __future__ import annotations

import argparse
import random
import socket
from collections.abc import Collection
from pathlib import Path

from motocell.shared.config import MAX_PORT, MAX_PORT_BASE, PORT_COUNT

EPHEMERAL_RANGE = Path("/proc/sys/net/ipv4/ip_local_port_range")
PICKED_SPAN = 12000
"""How far below the ephemeral range ports are picked (20768-32767 with Linux's default)."""
TRIES = 200


def free_port(host: str = "127.0.0.1") -> int:
    """A port free right now (another process may still take it before it is bound)."""
    return free_port_block(1, host)


def free_port_besides(taken: Collection[int], host: str = "127.0.0.1") -> int:
    """A port free right now that is none of ``taken``: ports picked for the same cell but not
    yet bound (its TCP ports, when its router's is picked), which a pick alone cannot see."""
    while True:
        port = free_port(host)
        if port not in taken:
            return port


def free_port_block(count: int, host: str = "127.0.0.1") -> int:
    """A base port with ``count`` consecutive free ports (for the motion/state/I/O trio)."""
    first, end = _picking_range(count)
    for _ in range(TRIES if first < end else 0):
        base = random.randrange(first, end)
        if all(port_free(base + i, host) for i in range(count)):
            return base
    while True:  # no room below the ephemeral range: the kernel's choice
        base = _kernel_port(host)
        if base + count <= MAX_PORT and all(port_free(base + i, host) for i in range(count)):
            return base


def port_base_argument(text: str) -> int:
    """argparse's type for a service's ``--port-base``: the motion port, the state and I/O
    ports after it. 0 is refused like any base whose ports leave 1-65535 (port 0 is no port), never
    read as a default."""
    try:
        base = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 1 <= base <= MAX_PORT_BASE:
        raise argparse.ArgumentTypeError(
            f"{base}: the motion, state and I/O ports ({base}-{base + PORT_COUNT - 1}) must lie "
            f"within 1-{MAX_PORT}"
        )
    return base


def port_free(port: int, host: str = "127.0.0.1") -> bool:
    with socket.socket() as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError:
            return False
        return True


def _picking_range(count: int) -> tuple[int, int]:
    """[first, end) for the base of ``count`` ports, all below the ephemeral range."""
    try:
        ephemeral_low = int(EPHEMERAL_RANGE.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        ephemeral_low = 32768
    return max(1024, ephemeral_low - PICKED_SPAN), ephemeral_low - count + 1


def _kernel_port(host: str) -> int:
    with socket.socket() as probe:
        probe.bind((host, 0))
        port: int = probe.getsockname()[1]
        return port
