"""Who runs at which priority in a running cell (docs/realtime.md): every service's threads at
the services' SCHED_RR, the executor's clock at SCHED_FIFO, the gateway's motion connection
thread a step above the services while it has a client (docs/reply-path.md), the launcher's
router threads at
SCHED_RR, and the launcher's main thread, which starts the services, and its warm parent, which
has imported them, at ordinary priority, so that a starting (or restarting) service's imports
never run at the priority of the running cells' threads."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.shared.protocol.constants import Command
from motocell.shared.protocol.replies import motion_ctrl
from motocell.shared.realtime import REPLY_PRIORITY, RT_PRIORITY, SERVICE_PRIORITY
from motocell.testing.running_cell import RunningCell, running_cell

pytestmark = [
    pytest.mark.cell,
    pytest.mark.skipif(os.geteuid() != 0, reason="needs the privilege to take SCHED_RR"),
]


@pytest.fixture(scope="module")
def cell() -> Iterator[RunningCell]:
    with running_cell() as running:
        yield running


WAIT_S = 10.0
"""How long a connection's thread may take to end once its client has gone (it waits 50 ms)."""


def raised(pid: int) -> list[int]:
    """The threads of ``pid`` at the reply priority."""
    return [tid for tid, policy in policies(pid).items() if policy == (os.SCHED_RR, REPLY_PRIORITY)]


def none_raised(pid: int) -> bool:
    """Waits until no thread of ``pid`` runs at the reply priority (a connection's thread ends
    a little after its client); whether none does within ``WAIT_S``."""
    deadline = time.monotonic() + WAIT_S
    while raised(pid):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def policies(pid: int) -> dict[int, tuple[int, int]]:
    """Per thread of ``pid``: its scheduling policy and priority."""
    found = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        tid = int(task.name)
        with contextlib.suppress(ProcessLookupError):  # a thread that ended since the listing
            found[tid] = (os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority)
    return found


def test_the_launchers_main_thread_is_ordinary_and_its_router_threads_are_not(
    cell: RunningCell,
) -> None:
    launcher = policies(cell.process.pid)
    assert launcher.pop(cell.process.pid) == (os.SCHED_OTHER, 0)
    assert launcher, "the router's threads"
    assert set(launcher.values()) == {(os.SCHED_RR, SERVICE_PRIORITY)}
    assert cell.children() == cell.services(), "the zygote let go (test_warm_start: its policy)"


def test_every_service_thread_runs_at_the_services_priority_but_the_clock(
    cell: RunningCell,
) -> None:
    clocks = 0
    (gateway,) = cell.service_pids("gateway")
    assert none_raised(gateway), "no thread keeps the reply priority without a client"
    for pid in cell.services():
        for policy in policies(pid).values():
            if policy == (os.SCHED_FIFO, RT_PRIORITY):
                clocks += 1
            else:
                assert policy == (os.SCHED_RR, SERVICE_PRIORITY), pid
    assert clocks == 1


def test_the_motion_ports_connection_thread_answers_a_step_above_the_services(
    cell: RunningCell,
) -> None:
    """Only while it has its client; the I/O port's stays at the services' priority, and no
    Zenoh thread of the gateway takes it."""
    (gateway,) = cell.service_pids("gateway")
    assert none_raised(gateway)
    with cell.motion() as motion, cell.io() as io:
        # A reply proves each connection's thread runs: it set its priority before serving.
        motion.request(motion_ctrl(Command.CHECK_MOTION_READY))
        io.request(motion_ctrl(Command.CHECK_MOTION_READY))
        assert len(raised(gateway)) == 1
    assert none_raised(gateway), "the thread goes with its client"
