"""The launcher's children as real processes under its loop: one that cannot start as
configured stops the cell (exit status 2, not a restart loop); each runs in a process group of
its own, so a terminal's Ctrl-C reaches the launcher alone; one that dies is restarted. An
exited child nobody knows (an orphan the launcher adopted) is reaped, a known one is not."""

from __future__ import annotations

import itertools
import os
import select
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import pytest

from motocell.services.launcher.core.children import ChildSpec
from motocell.services.launcher.core.restarts import RestartPolicy
from motocell.services.launcher.loop import supervise
from motocell.services.launcher.processes import Child, stop_children
from motocell.services.launcher.warm import reap_strays
from motocell.shared.config import EXIT_CONFIG
from motocell.shared.service import StopFlag
from motocell.shared.service_names import ServiceName

SLEEPER = (sys.executable, "-c", "import time; time.sleep(60)")
DEADLINE_MS = 10_000
"""For a process that exits at once: a hang, not a timing."""


def child(name: str, *argv: str) -> Child:
    service, _, instance = name.partition("/")
    return Child(ChildSpec(ServiceName(service, instance), argv))


@pytest.mark.cell
def test_a_child_that_exits_with_the_configuration_status_stops_the_cell() -> None:
    children = [
        child("controller/0", *SLEEPER),
        child("gateway/0", sys.executable, "-c", f"raise SystemExit({EXIT_CONFIG})"),
    ]
    try:
        status = supervise(children, RestartPolicy(delay_s=0.0), StopFlag(), lambda: None)
    finally:
        stop_children(children)
    assert status == EXIT_CONFIG
    assert not any(c.alive() for c in children)


@pytest.mark.cell
def test_every_child_has_a_process_group_of_its_own() -> None:
    children = [child("controller/0", *SLEEPER), child("executor/0", *SLEEPER)]
    stop = StopFlag()
    try:
        supervise(children, RestartPolicy(), stop, stop.set)
        groups = set()
        for started in children:
            assert started.process is not None
            groups.add(os.getpgid(started.process.pid))
    finally:
        stop_children(children)
    assert os.getpgrp() not in groups
    assert len(groups) == len(children)


@pytest.mark.cell
def test_a_child_that_dies_is_restarted_and_looks_come_only_when_asked(tmp_path: Path) -> None:
    """The launcher wakes for the death itself (no polling), restarts the child after the
    delay, and calls ``look`` again only at the time it asked for."""
    marker = str(tmp_path / "started-once")
    # First run: leave a marker and die; the restart finds it and sleeps.
    script = (
        "import os, sys, time\n"
        f"m = {marker!r}\n"
        "if os.path.exists(m):\n"
        "    time.sleep(60)\n"
        "open(m, 'w').close()\n"
        "sys.exit(3)\n"
    )
    children = [child("gateway/0", sys.executable, "-c", script)]
    stop = StopFlag()
    looks: list[float] = []
    pids: list[int] = []

    def look() -> float | None:
        looks.append(time.monotonic())
        process = children[0].process
        if process is not None and process.pid not in pids:
            pids.append(process.pid)
        if len(pids) == 2 and children[0].alive():
            stop.set()
            return None
        return time.monotonic() + 0.05

    try:
        assert supervise(children, RestartPolicy(delay_s=0.1), stop, look) == 0
    finally:
        stop_children(children)
    assert len(pids) == 2, "restarted once"
    assert all(b - a >= 0.045 for a, b in itertools.pairwise(looks)), "only when asked"


@pytest.mark.cell
def test_only_a_childs_first_start_has_its_first_start_arguments() -> None:
    started: list[tuple[str, ...]] = []

    def start(argv: Sequence[str]) -> subprocess.Popen[bytes]:
        started.append(tuple(argv))
        return subprocess.Popen(["true"])

    gateway = Child(ChildSpec(ServiceName("gateway", "0"), ("serve",), ("--new-bus",)), start)
    try:
        for _ in range(2):
            gateway.start()
            assert gateway.process is not None
            gateway.process.wait(timeout=DEADLINE_MS / 1000)
    finally:
        gateway.forget()
    assert started == [("serve", "--new-bus"), ("serve",)]


class AllBut:
    """Every pid but one is known: the test reaps its own child and no other's."""

    def __init__(self, stray: int) -> None:
        self.stray = stray

    def __contains__(self, pid: object) -> bool:
        return pid != self.stray


def exited_unreaped(pid: int) -> None:
    """Until ``pid`` has exited (its status still there to take)."""
    exited = os.pidfd_open(pid)
    try:
        poller = select.poll()
        poller.register(exited, select.POLLIN)
        assert poller.poll(DEADLINE_MS), f"{pid} did not exit"
    finally:
        os.close(exited)


@pytest.mark.cell
def test_an_exited_child_nobody_knows_is_reaped_and_a_known_one_left_to_its_owner() -> None:
    stray = os.posix_spawnp("true", ["true"], os.environ)
    exited_unreaped(stray)
    reap_strays(AllBut(stray))
    with pytest.raises(ChildProcessError):
        os.waitpid(stray, os.WNOHANG)

    known = os.posix_spawnp("true", ["true"], os.environ)
    exited_unreaped(known)
    reap_strays({known})
    assert os.waitpid(known, os.WNOHANG)[0] == known, "its status was still there"
