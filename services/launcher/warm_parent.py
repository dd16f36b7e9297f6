"""The warm parent's process (``launcher.zygote``), started as the launcher's first act.

The zygote's imports take 0.15-0.3 s; the launcher's own (Zenoh, its cell file's loader) take
0.1-0.2 s and its router opens after them. Started before those, on a machine of two cores or
more, the zygote imports beside them instead of after them (measured in docs/startup.md). So
this module imports a few modules of the standard library and ``shared.launcher_names`` alone
(the services' names, with ``dataclasses``, would hold the zygote's start back by 11 ms of
CPU), and the zygote holds every service it can fork (``service_names.WARM_MODULES``, which it
reads itself) whatever the cell turns out to run: the cell's file is not read yet.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from motocell.shared.launcher_names import PARENT_PID_ENV, WARM_PARENT_MODULE

ROOM = 8192
"""Bytes of command line the zygote holds for a service's (``zygote.rewrite_command_line``):
a cell's longest, with its paths, is a few hundred."""
NOTHING_TO_FORK = frozenset({"--cold", "-h", "--help", "--version"})
"""Words of a launcher's command line after which it forks no service."""


class StartedZygote:
    """The zygote's process and the launcher's end of its socket, until ``warm.Zygote`` takes
    them; ``close`` kills it, for a launcher that ends before it asks for anything."""

    def __init__(self) -> None:
        ours, theirs = socket.socketpair()
        env = {**os.environ, PARENT_PID_ENV: str(os.getpid())}
        command = [
            *(sys.executable, "-m", WARM_PARENT_MODULE),
            *("--channel", str(theirs.fileno()), "--room", " " * ROOM),
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
        self.channel = ours

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        self.channel.close()


@contextmanager
def started_zygote(words: Sequence[str]) -> Iterator[StartedZygote | None]:
    """The zygote for a launcher run with ``words``, None where that run forks nothing; the
    zygote is killed at the block's end (``warm.Zygote`` has usually done so by then)."""
    if NOTHING_TO_FORK.intersection(words):
        yield None
        return
    try:
        zygote = StartedZygote()
    except OSError as exc:  # no process to be had (EAGAIN, ENOMEM): the cell starts cold
        print(f"motocell up: no warm parent ({exc}); services start cold", file=sys.stderr)
        yield None
        return
    try:
        yield zygote
    finally:
        zygote.close()
