"""The warm parent (``launcher.zygote``), forked from the launcher once the launcher's own
modules are loaded, before it starts a thread or opens its router (docs/startup.md).

A fork shares its parent's pages: the interpreter, Zenoh's library with its relocations and
every module the launcher has loaded are in memory once for the launcher, the zygote and every
service the zygote forks, where a zygote of its own would hold a second copy. The zygote then
imports the services' modules while the launcher reads its cell file and opens its router, so
the two still load at once on two cores.

The zygote rewrites its command line in the room the launcher started with
(``launcher_names.ROOM_OPTION``), and so does every service it forks.
"""

from __future__ import annotations

import math
import os
import select
import signal
import socket
import subprocess
import sys


class ForkedProcess:
    """A process this launcher forked, or adopted from its zygote: ``Popen``'s ways, by pid."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid == self.pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        if self.poll() is None:
            if timeout is None:
                _, status = os.waitpid(self.pid, 0)
                self.returncode = os.waitstatus_to_exitcode(status)
            else:
                exits_within(self.pid, timeout)
        code = self.poll()
        if code is None:
            raise subprocess.TimeoutExpired(str(self.pid), timeout or 0.0)
        return code

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:  # not reaped, so the pid is still this process's
            os.kill(self.pid, sig)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def exits_within(pid: int, timeout: float, interrupt: int | None = None) -> bool:
    """Whether child ``pid`` exits within ``timeout`` s; the wait ends early, False, once the
    descriptor ``interrupt`` is readable (a stop's)."""
    exited = os.pidfd_open(pid)
    try:
        poller = select.poll()
        poller.register(exited, select.POLLIN)
        if interrupt is not None:
            poller.register(interrupt, select.POLLIN)
        ready = {fd for fd, _ in poller.poll(max(0, math.ceil(timeout * 1000)))}
        return exited in ready
    finally:
        os.close(exited)


class StartedZygote:
    """The zygote's process and the launcher's end of its socket, until ``warm.Zygote`` takes
    them; ``close`` kills it, for a launcher that ends before it asks for anything."""

    def __init__(self, pid: int, channel: socket.socket) -> None:
        self.process = ForkedProcess(pid)
        self.channel = channel

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        self.channel.close()


def fork_zygote() -> StartedZygote | None:
    """The launcher's zygote, None where no process is to be had. Call it where nothing is to
    be undone below it (the launcher's ``__main__``, outside its blocks): in the zygote, and in
    every service it forks, this returns only by ending the process as the interpreter ends,
    with the service's exit status."""
    # The zygote's module, with the services' names it holds, loads after the fork, in the
    # zygote alone: the launcher needs none of it.
    ours, theirs = socket.socketpair()
    launcher = os.getpid()
    try:
        pid = os.fork()
    except OSError as exc:  # EAGAIN, ENOMEM: the cell starts cold
        ours.close()
        theirs.close()
        print(f"motocell up: no warm parent ({exc}); services start cold", file=sys.stderr)
        return None
    if pid == 0:
        ours.close()
        from motocell.services.launcher.zygote import run  # noqa: PLC0415

        run(theirs, launcher)
        sys.exit(0)
    theirs.close()
    return StartedZygote(pid, ours)
