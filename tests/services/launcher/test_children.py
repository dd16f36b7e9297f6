"""The launcher's children as real processes: one that cannot start as configured stops the
cell (exit status 2, not a restart loop); each runs in a process group of its own, so a
terminal's Ctrl-C reaches the launcher alone."""

from __future__ import annotations

import os
import sys

import pytest

from motocell.services.launcher.children import Child, stop_children, supervise
from motocell.services.launcher.core import ChildSpec, RestartPolicy
from motocell.shared.config import EXIT_CONFIG
from motocell.shared.service import StopFlag
from motocell.shared.service_names import ServiceName

SLEEPER = (sys.executable, "-c", "import time; time.sleep(60)")


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


def test_nothing_is_started_once_a_stop_was_asked() -> None:
    children = [child("controller/0", *SLEEPER)]
    stop = StopFlag()
    stop.set()
    assert supervise(children, RestartPolicy(), stop, lambda: None) == 0
    assert children[0].process is None
