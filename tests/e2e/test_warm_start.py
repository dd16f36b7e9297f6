"""Services forked from the launcher's warm parent (docs/startup.md) are supervised as spawned
ones were: each is the launcher's child with its ``python -m`` command line; the zygote, let go
once every service has started, takes none with it, and a service killed after is restarted
as a process of its own (whose claim settles, where the first start's held at once on the
launcher's new bus); a killed launcher takes the services with it; a SIGTERM while the launcher
waits for a stopped zygote stops everything at once, and a zygote killed before it forks leaves
a cell whose services start as processes of their own."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.services.launcher.warm import REPLY_S
from motocell.shared.config import PORT_COUNT
from motocell.shared.ports import free_port, free_port_block
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import MotionClient
from motocell.testing.processes import alive, cmdline, descendants, wait_until
from motocell.testing.running_cell import running_cell

pytestmark = pytest.mark.cell

ZYGOTE = "launcher.zygote"
SERVICES = ("controller", "executor", "broadcaster", "gateway", "interpolator")
HOST = "127.0.0.1"
DEADLINE_S = 60.0
"""For a hang, not a timing: a start takes a second or two."""
STOP_BOUND_S = 3.0
"""Within this, a SIGTERM has ended every process; shorter than REPLY_S, after which the
launcher would give the zygote up anyway."""
OPEN_BUS = "runs on an open bus"
"""The launcher's warning, the last it says before it starts the services."""
READY = " ready: motion "
"""The launcher's ready line (``cell NAME ready: motion HOST:PORT, ...``)."""


def parent(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()[1])


def motion_ready(motion: MotionClient) -> bool:
    return motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE


def test_the_zygote_goes_once_the_services_started_and_a_killed_service_is_restarted() -> None:
    with running_cell() as cell, cell.motion() as motion:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        assert cell.service_pids(ZYGOTE) == set(), "let go, and reaped"
        assert len(cell.children()) == len(SERVICES)
        for service in SERVICES:
            (pid,) = cell.service_pids(service)
            assert parent(pid) == cell.process.pid, f"{service} is the launcher's child"
            assert cmdline(pid)[:3] == [sys.executable, "-m", f"motocell.services.{service}"]
            # Its first start, never restarted: the zygote let go before the last service it
            # forked had its go would have ended that service, and its restart settles.
            assert cmdline(pid)[-1] == "--new-bus", "its own new router: the claim held at once"

        (victim,) = cell.service_pids("interpolator")
        os.kill(victim, signal.SIGKILL)
        wait_until(
            lambda: bool(cell.service_pids("interpolator") - {victim}), 10.0, "a new interpolator"
        )
        (restarted,) = cell.service_pids("interpolator")
        assert parent(restarted) == cell.process.pid
        assert "--new-bus" not in cmdline(restarted), "a restart's claim settles"
        wait_until(lambda: motion_ready(motion), 15.0, "motion-ready again")


def test_a_killed_launcher_takes_its_services_with_it() -> None:
    with running_cell() as cell:
        processes = cell.children()
        assert len(processes) == len(SERVICES)
        cell.process.kill()
        wait_until(lambda: not any(alive(pid) for pid in processes), 5.0, "every process to end")


@contextlib.contextmanager
def motocell_up(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[bytes], Path]]:
    """``motocell up --open-bus`` on free ports, its output to a file; whatever it started is
    killed if the test leaves it running."""
    port_base = free_port_block(PORT_COUNT, HOST)
    zenoh_port = free_port(HOST)
    output = tmp_path / "up.log"
    command = [
        *(sys.executable, "-m", "motocell.tools", "up", "--open-bus"),
        *("--port-base", str(port_base), "--zenoh-listen", f"tcp/{HOST}:{zenoh_port}"),
    ]
    env = {**os.environ, RUNTIME_DIR_ENV: str(tmp_path / "run"), "PYTHONUNBUFFERED": "1"}
    with output.open("wb") as out:
        up = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, env=env)
    started: set[int] = set()
    try:
        yield up, output
    finally:
        started |= descendants(up.pid)
        for pid in started | ({up.pid} if up.poll() is None else set()):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        up.wait()


def zygote_of(up: subprocess.Popen[bytes]) -> int | None:
    found = [pid for pid in descendants(up.pid) if ZYGOTE in " ".join(cmdline(pid))]
    return found[0] if found else None


ATTEMPTS = 5
"""Starts tried for one whose zygote is caught before it forks: it imports for a tenth of a
second or two, which a test on a loaded machine can miss, and once the services have started
it is gone."""


@contextlib.contextmanager
def zygote_stopped_before_it_forks(
    tmp_path: Path,
) -> Iterator[tuple[subprocess.Popen[bytes], Path, int]]:
    """``motocell up`` with its zygote stopped (SIGSTOP) before its first fork: every start
    from then on waits for a zygote that cannot answer."""
    for attempt in range(ATTEMPTS):
        directory = tmp_path / str(attempt)
        directory.mkdir()
        with motocell_up(directory) as (up, output):
            wait_until(
                lambda: zygote_of(up) is not None or READY in output.read_text(),
                DEADLINE_S,
                "the zygote or the cell ready",
            )
            zygote = zygote_of(up)
            if zygote is None:
                continue  # started and let go before it was seen
            os.kill(zygote, signal.SIGSTOP)
            # Nothing forked yet: a fork in progress would show its first child or service.
            if descendants(up.pid) == {zygote}:
                yield up, output, zygote
                return
    pytest.fail(f"no zygote caught before its first fork in {ATTEMPTS} starts")


def test_a_sigterm_while_the_launcher_waits_for_a_stopped_zygote_stops_everything(
    tmp_path: Path,
) -> None:
    assert STOP_BOUND_S < REPLY_S
    with zygote_stopped_before_it_forks(tmp_path) as (up, output, zygote):
        # Forked before the launcher took the services' priority: the services' imports are
        # the zygote's, and must not run at the cell's priority.
        assert os.sched_getscheduler(zygote) == os.SCHED_OTHER
        wait_until(lambda: OPEN_BUS in output.read_text(), DEADLINE_S, "the services' start")
        processes = descendants(up.pid) | {up.pid}
        up.send_signal(signal.SIGTERM)
        wait_until(lambda: not any(alive(pid) for pid in processes), STOP_BOUND_S, "every process")
        assert up.wait(DEADLINE_S) == 0, output.read_text()
        assert "Traceback" not in output.read_text()


def test_a_zygote_killed_before_it_forks_leaves_a_cell_started_cold(tmp_path: Path) -> None:
    with zygote_stopped_before_it_forks(tmp_path) as (up, output, zygote):
        wait_until(lambda: OPEN_BUS in output.read_text(), DEADLINE_S, "the services' start")
        os.kill(zygote, signal.SIGKILL)  # while the launcher waits for its first fork
        wait_until(lambda: READY in output.read_text(), DEADLINE_S, "the cell ready")
        said = output.read_text()
        assert "the warm parent failed" in said, said
        services = descendants(up.pid)
        assert len(services) == len(SERVICES), "every service, and no zygote"
        for pid in services:
            assert parent(pid) == up.pid
            assert cmdline(pid)[:2] == [sys.executable, "-m"]
        up.send_signal(signal.SIGTERM)
        assert up.wait(DEADLINE_S) == 0, output.read_text()
        assert "Traceback" not in output.read_text()
