"""The launcher's side of its warm parent (``launcher.zygote``): start it, ask it for services,
and fall back to a plain ``python -m`` start for what it cannot fork (docs/startup.md).

The launcher makes itself a subreaper (PR_SET_CHILD_SUBREAPER) first: a forked service is then
its child, as a spawned one is, so the launcher reaps it and learns its exit status itself,
and a zygote that dies takes nothing with it. The zygote is asked only while it answers; once
it does not (killed, or gone for any reason), every later start, restarts included, is a
plain one, which costs what every start cost before there was a zygote.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import select
import signal
import socket
import subprocess
import sys
from collections.abc import Callable, Sequence
from typing import Protocol

from motocell.services.launcher.core.forks import (
    ForkProtocolError,
    ForkRefused,
    ForkRequest,
    decode_reply,
    encode,
)
from motocell.shared.service import PARENT_PID_ENV
from motocell.shared.service_names import WARM_PARENT_MODULE

log = logging.getLogger("motocell")

PR_SET_CHILD_SUBREAPER = 36
ROOM = 8192
"""Bytes of command line the zygote holds for a service's (``zygote.rewrite_command_line``):
a cell's longest, with its paths, is a few hundred."""
REPLY_S = 30.0
"""How long a fork may take to be answered, the zygote's imports included (a second on an
idle machine): longer, and the zygote is taken for stuck."""
STOP_S = 1.0


class Process(Protocol):
    """What the launcher needs of a service's process: ``subprocess.Popen`` or ``Forked``."""

    @property
    def pid(self) -> int: ...

    @property
    def returncode(self) -> int | None: ...

    def poll(self) -> int | None: ...

    def wait(self, timeout: float | None = None) -> int: ...

    def send_signal(self, sig: int) -> None: ...

    def kill(self) -> None: ...


class ForkedProcess:
    """A service the zygote forked, now the launcher's child: ``Popen``'s ways, by pid."""

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
                _wait_for_exit(self.pid, timeout)
        code = self.poll()
        if code is None:
            raise subprocess.TimeoutExpired(str(self.pid), timeout or 0.0)
        return code

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:  # not reaped, so the pid is still this process's
            os.kill(self.pid, sig)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


def _wait_for_exit(pid: int, timeout: float) -> None:
    exited = os.pidfd_open(pid)
    try:
        poller = select.poll()
        poller.register(exited, select.POLLIN)
        poller.poll(max(0, round(timeout * 1000)))
    finally:
        os.close(exited)


class ZygoteGoneError(Exception):
    """The zygote did not answer: it is gone or stuck."""


class NotForkedError(Exception):
    """The zygote refused this one request (``ForkRefused``); it serves the others."""


class ZygoteChannel:
    """The launcher's end of the zygote's socket: one request, then its reply."""

    def __init__(self, channel: socket.socket) -> None:
        channel.settimeout(REPLY_S)
        self._channel = channel
        self._lines = channel.makefile("rwb")

    def fork(self, module: str, args: Sequence[str]) -> int:
        """The forked service's pid; ZygoteGoneError when the zygote does not answer,
        NotForkedError when it refuses this one."""
        try:
            self._lines.write(encode(ForkRequest(module, tuple(args))))
            self._lines.flush()
            line = self._lines.readline()
            reply = decode_reply(line) if line else None
        except (OSError, ForkProtocolError) as exc:
            raise ZygoteGoneError(str(exc)) from exc
        if reply is None:
            raise ZygoteGoneError("it has closed its socket")
        if isinstance(reply, ForkRefused):
            raise NotForkedError(reply.reason)
        return reply.pid

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self._lines.close()
        self._channel.close()


class Zygote:
    """A running zygote, which holds ``modules``."""

    def __init__(self, modules: Sequence[str]) -> None:
        self.modules = frozenset(modules)
        ours, theirs = socket.socketpair()
        env = {**os.environ, PARENT_PID_ENV: str(os.getpid())}
        command = [
            *(sys.executable, "-m", WARM_PARENT_MODULE),
            *("--channel", str(theirs.fileno()), "--room", " " * ROOM, ",".join(modules)),
        ]
        try:
            # A process group of its own, as every service has: a Ctrl-C reaches the launcher.
            self.process = subprocess.Popen(
                command, env=env, pass_fds=(theirs.fileno(),), process_group=0
            )
        except BaseException:
            ours.close()
            raise
        finally:
            theirs.close()
        self._channel = ZygoteChannel(ours)

    def fork(self, module: str, args: Sequence[str]) -> Process:
        try:
            return ForkedProcess(self._channel.fork(module, args))
        except ZygoteGoneError as exc:
            raise ZygoteGoneError(f"{exc}; its exit code {self.process.poll()}") from exc

    def close(self) -> None:
        """End it (it may be in the middle of its imports) and close its socket."""
        self._channel.close()
        self.process.terminate()
        try:
            self.process.wait(timeout=STOP_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


class WarmParent(Protocol):
    """What ``Starter`` needs of a zygote (``Zygote``)."""

    @property
    def modules(self) -> frozenset[str]: ...

    def fork(self, module: str, args: Sequence[str]) -> Process: ...

    def close(self) -> None: ...


def become_subreaper() -> bool:
    """Whether this process now adopts its descendants' orphans (Linux alone can)."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(None, use_errno=True)
    done: int = libc.prctl(PR_SET_CHILD_SUBREAPER, 1)
    return done == 0


def spawn(argv: Sequence[str]) -> subprocess.Popen[bytes]:
    """``argv`` as a process of its own; it stops when the launcher does (``shared.service``),
    in a process group of its own: a Ctrl-C at the terminal reaches the launcher alone, which
    stops the children in order, and no child is interrupted mid start-up."""
    env = {**os.environ, PARENT_PID_ENV: str(os.getpid())}
    return subprocess.Popen(argv, env=env, process_group=0)


class Starter:
    """Starts a service's command line (``python -m module ...``): a fork of the zygote for the
    modules it holds while it answers, else a process of its own."""

    def __init__(
        self,
        zygote: WarmParent | None,
        plain: Callable[[Sequence[str]], Process] = spawn,
    ) -> None:
        self._zygote = zygote
        self._spawn = plain

    def __call__(self, argv: Sequence[str]) -> Process:
        module, args = argv[2], argv[3:]
        if self._zygote is not None and module in self._zygote.modules:
            try:
                return self._zygote.fork(module, args)
            except NotForkedError as exc:
                log.warning("%s starts as a process of its own: %s", module, exc)
            except ZygoteGoneError as exc:
                log.warning(
                    "the warm parent failed (%s); services start as processes of their own", exc
                )
                self.close()
        return self._spawn(argv)

    def close(self) -> None:
        if self._zygote is not None:
            self._zygote.close()
            self._zygote = None
