"""The cell's service processes: started, watched and restarted (``core.RestartPolicy``),
stopped with SIGTERM and, after a grace period, SIGKILL."""

from __future__ import annotations

import contextlib
import logging
import math
import os
import select
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


class Child:
    def __init__(self, spec: ChildSpec) -> None:
        self.spec = spec
        self.process: subprocess.Popen[bytes] | None = None
        self.exited: int | None = None
        """A descriptor that becomes readable when the process exits (a pidfd)."""

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
        self.forget()
        self.process = subprocess.Popen(self.spec.argv, env=env, process_group=0)
        self.exited = os.pidfd_open(self.process.pid)

    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def forget(self) -> None:
        """Close the exit descriptor of a process that is gone (or about to be replaced)."""
        if self.exited is not None:
            os.close(self.exited)
            self.exited = None


def supervise(
    children: list[Child],
    policy: RestartPolicy,
    stop: StopFlag,
    look: Callable[[], float | None],
) -> int:
    """Start every child at once, then restart those that die, until ``stop`` (status 0) or
    until one cannot start as configured (EXIT_CONFIG: it has said why on stderr).

    Sleeps until a child exits, a restart is due, ``stop``, or the time ``look`` asked to run
    again: it runs once at the start and returns the next time.monotonic() it wants, or None
    when it has nothing more to watch. A cell that runs wakes its launcher for nothing."""
    if stop.is_set():  # stopped while the router started: nothing to start
        return 0
    for child in children:
        child.start()
    next_look = look()
    try:
        while True:
            _sleep(children, stop, [next_look, policy.next_restart()])
            if stop.is_set():
                return 0
            now = time.monotonic()
            if next_look is not None and now >= next_look:
                next_look = look()
            if _tend(children, policy, now) is Restart.GIVE_UP:
                return EXIT_CONFIG
    finally:
        for child in children:
            child.forget()


def _sleep(children: list[Child], stop: StopFlag, deadlines: list[float | None]) -> None:
    """Until a live child exits, ``stop``, or the earliest of ``deadlines``."""
    poller = select.poll()
    poller.register(stop.fileno(), select.POLLIN)
    for child in children:
        if child.exited is not None:
            poller.register(child.exited, select.POLLIN)
    due = [deadline for deadline in deadlines if deadline is not None]
    wait = None if not due else max(0.0, min(due) - time.monotonic())
    poller.poll(None if wait is None else math.ceil(wait * 1000))


def _tend(children: list[Child], policy: RestartPolicy, now: float) -> Restart | None:
    """Note the children found dead and restart those whose time has come; GIVE_UP when one
    cannot start as configured."""
    for child in children:
        if child.alive():
            continue
        child.forget()  # its exit is known: the pidfd would stay readable
        returncode = child.process.returncode if child.process else None
        action = policy.dead(child.name, now, returncode)
        if action is Restart.GIVE_UP:
            log.error("%s cannot start as configured; stopping the cell", child.name)
            return action
        if action is Restart.NOTICED:
            log.error(
                "%s exited (code %s); restarting in %.0f s; the cell is NOT_READY until it is back",
                child.name,
                returncode,
                policy.delay_s,
            )
        elif action is Restart.NOW:
            child.start()
    return None


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
