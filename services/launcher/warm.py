"""The launcher's side of its warm parent (``launcher.zygote``, started by ``warm_parent``): ask
it for services, and fall back to a plain ``python -m`` start for what it cannot fork
(docs/startup.md).

The launcher makes itself a subreaper (PR_SET_CHILD_SUBREAPER) before its first request: a
forked service is then its child, as a spawned one is, so the launcher reaps it and learns its
exit status itself, and a zygote that dies takes nothing with it. The zygote is asked only
while it answers; once it does not (killed, or gone for any reason), every later start,
restarts included, is a plain one, which costs what every start cost before there was a zygote.
A stop asked while the launcher waits for the zygote ends that wait at once
(``StoppedWaiting``): the zygote is killed, and a service it forked meanwhile with it. Being a
subreaper adopts every orphan of the launcher's descendants, not only the forked services:
``reap_strays`` reaps those.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import math
import os
import select
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Container, Sequence
from typing import Protocol

from motocell.services.launcher.core.forks import (
    Forked,
    ForkProtocolError,
    ForkRefused,
    ForkRequest,
    decode_reply,
    encode,
)
from motocell.services.launcher.loop import Stop
from motocell.services.launcher.warm_parent import ForkedProcess, StartedZygote, exits_within
from motocell.shared.bus.session import StoppedWaiting
from motocell.shared.launcher_names import PARENT_PID_ENV
from motocell.shared.service_names import WARM_MODULES

log = logging.getLogger("motocell")

PR_SET_CHILD_SUBREAPER = 36
REPLY_S = 5.0
"""How long a fork may take to be answered, the zygote's imports included (0.2-0.3 s, also on
a loaded machine: docs/startup.md): longer, and the zygote is taken for stuck and every start
is a plain one, which costs a few tenths of a second more; a stuck zygote holds each start
(restarts too) this long at most."""


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


class ZygoteGoneError(Exception):
    """The zygote did not answer: it is gone or stuck."""


class NotForkedError(Exception):
    """The zygote refused this one request (``ForkRefused``); it serves the others."""


class ZygoteChannel:
    """The launcher's end of the zygote's socket: one request, then its reply."""

    def __init__(self, channel: socket.socket, stop: Stop) -> None:
        channel.setblocking(False)
        self._channel = channel
        self._stop = stop
        self._received = bytearray()

    def fork(self, module: str, args: Sequence[str]) -> int:
        """The forked service's pid; ZygoteGoneError when the zygote does not answer within
        REPLY_S, NotForkedError when it refuses this one, StoppedWaiting on a stop."""
        try:
            self._channel.sendall(encode(ForkRequest(module, tuple(args))))
            line = self._reply_line()
            reply = decode_reply(line) if line else None
        except (OSError, ForkProtocolError) as exc:
            raise ZygoteGoneError(str(exc)) from exc
        if reply is None:
            raise ZygoteGoneError("it has closed its socket")
        if isinstance(reply, ForkRefused):
            raise NotForkedError(reply.reason)
        return reply.pid

    def _reply_line(self) -> bytes:
        """The next line, b"" at end of file; a poll on the socket and on the stop, since a
        signal handler that sets the stop does not end a blocking ``recv`` (Python retries
        it)."""
        deadline = time.monotonic() + REPLY_S
        poller = select.poll()
        poller.register(self._channel, select.POLLIN)
        poller.register(self._stop.fileno(), select.POLLIN)
        while b"\n" not in self._received:
            wait = deadline - time.monotonic()
            if wait <= 0:
                raise ZygoteGoneError(f"no answer in {REPLY_S:.0f} s")
            poller.poll(math.ceil(wait * 1000))
            if self._stop.is_set():
                raise StoppedWaiting
            if not self._receive():
                return b""
        line, _, self._received[:] = self._received.partition(b"\n")
        return bytes(line) + b"\n"

    def _receive(self) -> bool:
        """Take what has arrived; False at end of file."""
        try:
            data = self._channel.recv(4096)
        except BlockingIOError:
            return True
        self._received += data
        return data != b""

    def late_reply(self) -> int | None:
        """Once the zygote is dead: the pid of a service it forked and answered after the
        launcher stopped waiting, if it did (that service is the launcher's child)."""
        with contextlib.suppress(OSError):  # BlockingIOError: nothing more has come
            while data := self._channel.recv(4096):
                self._received += data
        line = bytes(self._received).partition(b"\n")[0]
        self._received.clear()  # told once: a second close finds nothing
        try:
            reply = decode_reply(line)
        except ForkProtocolError:
            return None
        return reply.pid if isinstance(reply, Forked) else None

    def close(self) -> None:
        self._channel.close()


class Zygote:
    """A running zygote (``warm_parent``), which holds ``WARM_MODULES``; ``stop`` ends a wait
    for it."""

    def __init__(self, started: StartedZygote, stop: Stop) -> None:
        self.modules = frozenset(WARM_MODULES)
        self.process = started.process
        self._stop = stop
        self._channel = ZygoteChannel(started.channel, stop)

    def fork(self, module: str, args: Sequence[str]) -> Process:
        try:
            return ForkedProcess(self._channel.fork(module, args))
        except ZygoteGoneError as exc:
            self.close()
            raise ZygoteGoneError(f"{exc}; its exit code {self.process.returncode}") from exc
        except StoppedWaiting:
            self.close()
            raise

    def pids(self) -> set[int]:
        """The zygote's pid until it is reaped (a poll reaps it once dead)."""
        return set() if self.process.poll() is not None else {self.process.pid}

    def retire(self) -> None:
        """Let it end by itself, with nothing asked of it: the end of its socket ends it once
        it has let the last service it forked go (it writes the go after its reply, so a kill
        now could come between the two, and that service would end unstarted); killed if it
        has not ended within ``REPLY_S``, or at once on a stop (everything stops then)."""
        self._channel.close()
        if not exits_within(self.process.pid, REPLY_S, interrupt=self._stop.fileno()):
            self.process.kill()
        self.process.wait()

    def close(self) -> None:
        """Kill it: it holds nothing that needs an orderly end, and it may be stuck or stopped
        (SIGSTOP), or in the middle of its imports. A service it forked and answered for
        after the launcher stopped waiting is killed too; one it did not answer for ends by
        itself, its go never written (``zygote.await_go``)."""
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        late = self._channel.late_reply()
        self._channel.close()
        if late is not None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(late, signal.SIGKILL)
            os.waitpid(late, 0)


class WarmParent(Protocol):
    """What ``Starter`` needs of a zygote (``Zygote``)."""

    @property
    def modules(self) -> frozenset[str]: ...

    def fork(self, module: str, args: Sequence[str]) -> Process: ...

    def pids(self) -> set[int]: ...

    def retire(self) -> None: ...

    def close(self) -> None: ...


def become_subreaper() -> bool:
    """Whether this process now adopts its descendants' orphans (Linux alone can)."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(None, use_errno=True)
    done: int = libc.prctl(PR_SET_CHILD_SUBREAPER, 1)
    return done == 0


def reap_strays(known: Container[int]) -> None:
    """Reap every exited child of this process whose pid is not ``known``: the orphans a
    subreaper adopts (a service's own child left behind, a zygote's first child), which
    nobody else waits for. A known child's exit status is the supervision's: it is never
    taken here, and one found exited ends the round (a later one reaps the rest, once the
    supervision has)."""
    while True:
        try:
            exited = os.waitid(os.P_ALL, 0, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        except ChildProcessError:
            return
        if exited is None or exited.si_pid in known:
            return
        os.waitpid(exited.si_pid, 0)


def spawn(argv: Sequence[str]) -> subprocess.Popen[bytes]:
    """``argv`` as a process of its own; it stops when the launcher does (``shared.service``),
    in a process group of its own: a Ctrl-C at the terminal reaches the launcher alone, which
    stops the children in order, and no child is interrupted mid start-up."""
    env = {**os.environ, PARENT_PID_ENV: str(os.getpid())}
    return subprocess.Popen(argv, env=env, process_group=0)


class Starter:
    """Starts a service's command line (``python -m module ...``): a fork of the zygote for the
    modules it holds while it answers, until it is retired, else a process of its own."""

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
            except StoppedWaiting:
                self.close()
                raise
        return self._spawn(argv)

    def pids(self) -> set[int]:
        """The processes it holds that are not services: its zygote's, until reaped."""
        return set() if self._zygote is None else self._zygote.pids()

    def retire(self) -> None:
        """Every service has had its first start: the zygote goes, and with it the pages of
        its heap that only it still maps, 6 MiB a cell (docs/startup.md, The warm parent
        retired); a restart from here on is a process of its own."""
        if self._zygote is not None:
            self._zygote.retire()
            self._zygote = None

    def close(self) -> None:
        if self._zygote is not None:
            self._zygote.close()
            self._zygote = None
