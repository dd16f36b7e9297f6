"""Driving cells from outside, for tests and benchmarks: the processes a launcher started
(from /proc, Linux), whether a port listens, and waiting on a condition with a deadline."""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Callable
from pathlib import Path


def children(pid: int) -> set[int]:
    """The processes ``pid`` started (and that have not been reparented since)."""
    found: set[int] = set()
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return found  # gone meanwhile (a warm parent's first child lives a moment)
    for task in tasks:
        try:
            found.update(map(int, Path(f"/proc/{pid}/task/{task}/children").read_text().split()))
        except OSError:
            continue
    return found


def descendants(pid: int) -> set[int]:
    """Every process below ``pid``, children of children included."""
    found: set[int] = set()
    frontier = [pid]
    while frontier:
        for child in children(frontier.pop()) - found:
            found.add(child)
            frontier.append(child)
    return found


def alive(pid: int) -> bool:
    """Running (a zombie that nobody reaped yet counts as gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()[0]
    except OSError:
        return False
    return state != "Z"


def cmdline(pid: int) -> list[str]:
    """The process's arguments (``[]`` once it is gone)."""
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return []
    # A service forked by its launcher's warm parent rewrote its arguments in the room its
    # launcher started with (services/launcher/command_line.py): the rest reads as NULs. A last
    # argument that is empty reads the same, and is dropped with them: only PR_SET_MM, which
    # needs CAP_SYS_RESOURCE, could shrink the room to tell them apart.
    return raw.rstrip(b"\0").decode(errors="replace").split("\0") if raw else []


def connectable(host: str, port: int) -> bool:
    """Something listens at ``host:port``. A probe whose kernel-chosen source port happens to
    be ``port`` itself connects to itself (TCP simultaneous open) with nobody listening: that
    does not count."""
    with socket.socket() as probe:
        if probe.connect_ex((host, port)) != 0:
            return False
        return bool(probe.getsockname() != probe.getpeername())


def wait_until(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    """Poll ``predicate`` until it holds; TimeoutError naming ``what`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() >= deadline:
            raise TimeoutError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.01)
