"""Stopping a service's process for a while, as a loaded host does at worst, and telling how long
it really went without running.

A process stopped for STALL_S runs again only once the scheduler gives it a CPU; on a loaded
machine that can be much later. What a stall test may expect depends on the stall the process
lived through, not the one injected: one that lasted into the Zenoh lease may rightly make the
cell count the service gone. So the stall is measured (the kernel counts every time a thread
is put on a CPU), and a test whose stall came too near the lease skips, saying why, rather
than fail for the machine's load or pass without checking anything.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterable
from pathlib import Path

from motocell.shared.bus.session import LEASE_MS
from motocell.testing.processes import wait_until

LEASE_S = LEASE_MS / 1000
KEEP_ALIVE_S = LEASE_S / 4
"""Zenoh sends a keep-alive every quarter lease: a process with nothing else to send was last
heard up to this long before it stopped."""
WITHIN_LEASE_S = LEASE_S - KEEP_ALIVE_S
"""The longest stall the cell must ride out without counting the process gone."""
RESUME_DEADLINE_S = 60.0
"""For a process to take its SIGSTOP, or to be given a CPU once resumed: a bound for a hang,
not a speed."""


def timeslices(pid: int) -> int:
    """How many times the threads of ``pid`` have been put on a CPU (``/proc/PID/task/*/
    schedstat``, third field); a stopped process's count stays still."""
    return sum(int(fields[2]) for fields in _tasks(pid, "schedstat"))


def stopped(pid: int) -> bool:
    """Every thread of ``pid`` has taken its SIGSTOP (each must run once to do so)."""
    return all(fields[0] == "T" for fields in _tasks(pid, "stat", after=")"))


def _tasks(pid: int, name: str, after: str = "") -> list[list[str]]:
    """The fields of file ``name`` of each thread of ``pid`` (those after ``after``)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            text = (task / name).read_text()
        except OSError:
            continue  # the thread ended meanwhile
        found.append((text.rsplit(after, 1)[-1] if after else text).split())
    return found


def stall(pids: Iterable[int], seconds: float) -> float:
    """Stop ``pids`` (SIGSTOP) for ``seconds``, resume them, and return how long the longest
    went without running: from the stop until its threads were next put on a CPU."""
    processes = list(pids)
    for pid in processes:
        os.kill(pid, signal.SIGSTOP)
    stopped_ns = time.monotonic_ns()
    try:
        time.sleep(seconds)  # the stall itself: a duration to inject, not a wait for a state
        wait_until(lambda: all(map(stopped, processes)), RESUME_DEADLINE_S, "the stop")
    finally:
        counts = {pid: timeslices(pid) for pid in processes}
        for pid in processes:
            os.kill(pid, signal.SIGCONT)
    wait_until(
        lambda: all(timeslices(pid) > count for pid, count in counts.items()),
        RESUME_DEADLINE_S,
        "the stopped processes to run again",
    )
    return (time.monotonic_ns() - stopped_ns) / 1e9


def beyond_the_lease(lived: float, what: str) -> str:
    """Why a test whose stall (``lived``, seconds) came near enough the lease for the cell to
    count ``what`` gone cannot judge it ("" when it can): a loaded machine's doing."""
    if lived < WITHIN_LEASE_S:
        return ""
    return (
        f"{what} went {lived:.2f} s without running (stalled, then waiting for a CPU): "
        f"within {KEEP_ALIVE_S} s of the {LEASE_S} s lease, it may rightly count as gone"
    )
