"""Services forked from the launcher's warm parent (docs/startup.md) are supervised as spawned
ones were: each is the launcher's child with its ``python -m`` command line; a killed zygote
takes no service with it, and a service killed after it is restarted as a process of its own;
a killed launcher takes the services and the zygote with it."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import pytest

from motocell.shared.protocol.constants import Command, Result
from motocell.testing.client import MotionClient
from motocell.testing.processes import alive, cmdline, wait_until
from motocell.testing.running_cell import running_cell

pytestmark = pytest.mark.cell

ZYGOTE = "launcher.zygote"
SERVICES = ("controller", "executor", "broadcaster", "gateway", "interpolator")


def parent(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()[1])


def motion_ready(motion: MotionClient) -> bool:
    return motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE


def test_a_killed_zygote_takes_nothing_and_a_service_killed_after_it_is_restarted() -> None:
    with running_cell() as cell, cell.motion() as motion:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        (zygote,) = cell.service_pids(ZYGOTE)
        services = cell.children() - {zygote}
        for service in SERVICES:
            (pid,) = cell.service_pids(service)
            assert parent(pid) == cell.process.pid, f"{service} is the launcher's child"
            assert cmdline(pid)[:3] == [sys.executable, "-m", f"motocell.services.{service}"]

        os.kill(zygote, signal.SIGKILL)
        wait_until(lambda: not alive(zygote), 5.0, "the zygote to die")
        assert motion_ready(motion)
        # The zygote stays a zombie until the launcher next starts a service: no matter.
        running = {pid for pid in cell.children() if alive(pid)}
        assert running == services, "no service went with it"

        (victim,) = cell.service_pids("interpolator")
        os.kill(victim, signal.SIGKILL)
        wait_until(
            lambda: bool(cell.service_pids("interpolator") - {victim}), 10.0, "a new interpolator"
        )
        (restarted,) = cell.service_pids("interpolator")
        assert parent(restarted) == cell.process.pid
        wait_until(lambda: motion_ready(motion), 15.0, "motion-ready again")


def test_a_killed_launcher_takes_its_services_and_its_zygote_with_it() -> None:
    with running_cell() as cell:
        processes = cell.children()
        assert len(processes) == len(SERVICES) + 1  # and the zygote
        assert len(cell.service_pids(ZYGOTE)) == 1
        cell.process.kill()
        wait_until(lambda: not any(alive(pid) for pid in processes), 5.0, "every process to end")
