"""The cell's service processes: each started with a descriptor that says when it exits (the
loop, ``loop.supervise``, sleeps on those), and all stopped with SIGTERM and, after a grace
period, SIGKILL."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import subprocess
import time
from collections.abc import Callable, Sequence

from motocell.services.launcher.core.children import CONTROLLER, ChildSpec
from motocell.services.launcher.warm import Process, spawn

log = logging.getLogger("motocell")

STOP_GRACE_S = 4.0
"""SIGTERM, then SIGKILL after this; the whole stop stays within 5 s."""
CONTROLLER_FIRST_S = 1.0
"""How long the others wait for the controller to stop before they get SIGTERM too."""


class Child:
    def __init__(self, spec: ChildSpec, start: Callable[[Sequence[str]], Process] = spawn) -> None:
        """``start``: how its command line becomes a process (``warm.Starter``: a fork of the
        warm parent, or a process of its own)."""
        self.spec = spec
        self._start = start
        self.process: Process | None = None
        self.exited: int | None = None
        """A descriptor that becomes readable when the process exits (a pidfd)."""

    @property
    def name(self) -> str:
        return self.spec.name

    def start(self) -> None:
        # The child arranges to get SIGTERM if the launcher dies (shared.service), so no
        # half cell outlives a killed launcher.
        self.forget()
        self.process = self._start(self.spec.argv_for(restart=self.process is not None))
        self.exited = os.pidfd_open(self.process.pid)

    @property
    def returncode(self) -> int | None:
        return self.process.returncode if self.process else None

    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def forget(self) -> None:
        """Close the exit descriptor of a process that is gone (or about to be replaced)."""
        if self.exited is not None:
            os.close(self.exited)
            self.exited = None


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
