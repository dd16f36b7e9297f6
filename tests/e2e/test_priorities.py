"""Who runs at which priority in a running cell (docs/realtime.md): every service's threads at
the services' SCHED_RR, the executor's clock at SCHED_FIFO, the gateway's connection threads a
step above the services (docs/reply-path.md), the launcher's router threads at
SCHED_RR, and the launcher's main thread, which starts the services, and its warm parent, which
has imported them, at ordinary priority, so that a starting (or restarting) service's imports
never run at the priority of the running cells' threads."""

from __future__ import annotations

import os
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


def policies(pid: int) -> dict[int, tuple[int, int]]:
    """Per thread of ``pid``: its scheduling policy and priority."""
    found = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        tid = int(task.name)
        found[tid] = (os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority)
    return found


def test_the_launchers_main_thread_is_ordinary_and_its_router_threads_are_not(
    cell: RunningCell,
) -> None:
    launcher = policies(cell.process.pid)
    assert launcher.pop(cell.process.pid) == (os.SCHED_OTHER, 0)
    assert launcher, "the router's threads"
    assert set(launcher.values()) == {(os.SCHED_RR, SERVICE_PRIORITY)}
    for zygote in cell.children() - cell.services():
        # The services' imports are its own: they must not run at the cells' priority.
        assert set(policies(zygote).values()) == {(os.SCHED_OTHER, 0)}


def test_every_service_thread_runs_at_the_services_priority_but_the_clock(
    cell: RunningCell,
) -> None:
    clocks = 0
    (gateway,) = cell.service_pids("gateway")
    for pid in cell.services():
        for policy in policies(pid).values():
            if policy == (os.SCHED_FIFO, RT_PRIORITY):
                clocks += 1
            elif pid == gateway and policy == (os.SCHED_RR, REPLY_PRIORITY):
                continue  # a connection's thread, maybe of a client that has just gone
            else:
                assert policy == (os.SCHED_RR, SERVICE_PRIORITY), pid
    assert clocks == 1


def test_the_gateways_connection_threads_answer_a_step_above_the_services(
    cell: RunningCell,
) -> None:
    (gateway,) = cell.service_pids("gateway")
    with cell.motion() as motion, cell.io() as io:
        # A reply proves each connection's thread runs: it set its priority before serving.
        motion.request(motion_ctrl(Command.CHECK_MOTION_READY))
        io.request(motion_ctrl(Command.CHECK_MOTION_READY))
        raised = [p for p in policies(gateway).values() if p != (os.SCHED_RR, SERVICE_PRIORITY)]
    # Both connections' threads; another may still be closing (a client that has just gone).
    assert len(raised) >= 2
    assert set(raised) == {(os.SCHED_RR, REPLY_PRIORITY)}
