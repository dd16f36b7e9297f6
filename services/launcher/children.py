"""The cell's service processes: started, watched and restarted (``core.RestartPolicy``),
stopped with SIGTERM and, after a grace period, SIGKILL."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import subprocess
import time
from collections.abc import Callable

from motocell.services.launcher.core import CONTROLLER, ChildSpec, Restart, RestartPolicy
from motocell.shared.config import EXIT_CONFIG
from motocell.shared.service import PARENT_PID_ENV, StopFlag

log = logging.getLogger("motocell")

STOP_GRACE_S = 4.0
"""SIGTERM, then SIGKILL after this; the whole stop stays within 5 s."""
CONTROLLER_FIRST_S = 1.0
"""How long the others wait for the controller to stop before they get SIGTERM too."""
WATCH_S = 0.2
"""How often the children are checked for life."""


class Child:
    def __init__(self, spec: ChildSpec) -> None:
        self.spec = spec
        self.process: subprocess.Popen[bytes] | None = None

    @property
    def name(self) -> str:
        return self.spec.name

    def start(self) -> None:
        # The child arranges to get SIGTERM if the launcher dies (shared.service), so no
        # half cell outlives a killed launcher. It runs in a process group of its own: a
        # Ctrl-C at the terminal reaches the launcher alone, which stops the children in
        # order (the controller first), and no child is interrupted mid start-up (a
        # KeyboardInterrupt traceback from its imports).
        env = {**os.environ, PARENT_PID_ENV: str(os.getpid())}
        self.process = subprocess.Popen(self.spec.argv, env=env, process_group=0)

    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None


def supervise(
    children: list[Child], policy: RestartPolicy, stop: StopFlag, check: Callable[[], None]
) -> int:
    """Start every child at once, then restart those that die, until ``stop`` (status 0) or
    until one cannot start as configured (EXIT_CONFIG: it has said why on stderr). ``check``
    runs at every look (WATCH_S) and must not block."""
    if stop.is_set():  # stopped while the router started: nothing to start
        return 0
    for child in children:
        child.start()
    while not stop.wait(WATCH_S):
        check()
        now = time.monotonic()
        for child in children:
            if child.alive():
                continue
            returncode = child.process.returncode if child.process else None
            action = policy.dead(child.name, now, returncode)
            if action is Restart.GIVE_UP:
                log.error("%s cannot start as configured; stopping the cell", child.name)
                return EXIT_CONFIG
            if action is Restart.NOTICED:
                log.error(
                    "%s exited (code %s); restarting in %.0f s; the cell is NOT_READY "
                    "until it is back",
                    child.name,
                    returncode,
                    policy.delay_s,
                )
            elif action is Restart.NOW:
                child.start()
    return 0


def stop_children(children: list[Child]) -> None:
    """SIGTERM to every child, the controller first: once it is gone nobody reports the others
    leaving as missing services, which on a normal stop is no news. The whole stop stays within
    STOP_GRACE_S."""
    running = [c for c in children if c.alive()]
    deadline = time.monotonic() + STOP_GRACE_S
    first = [c for c in running if c.name == CONTROLLER]
    for child in first:
        assert child.process is not None
        child.process.send_signal(signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            child.process.wait(timeout=CONTROLLER_FIRST_S)
    for child in running:
        assert child.process is not None
        if child.alive():
            child.process.send_signal(signal.SIGTERM)
    for child in running:
        assert child.process is not None
        try:
            child.process.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            log.warning("%s did not stop in time; killing it", child.name)
            child.process.kill()
            child.process.wait()
