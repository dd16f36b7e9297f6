"""The warm parent (a zygote): one process per launcher that has imported every service's
modules, so that each service starts as a fork of it instead of a fresh interpreter that
imports them again (docs/startup.md).

The launcher forks it (``warm_parent.fork_zygote``) once its own modules are loaded, before it
starts a thread: what both load is in memory once. It opens no Zenoh session and starts no
thread (``OPENBLAS_NUM_THREADS=1``, set by ``motocell.services``, keeps numpy's worker away), so
a fork of it is as safe as a fork of a fresh interpreter, and a service opens its own session
after the fork, as it would after ``python -m``. It serves the launcher's requests
(``core.forks``) on its socket until that closes, and dies with the launcher
(``die_with_launcher``).

Each service is forked twice: the first child forks the service and exits at once, so the
service is re-parented to the launcher, which has made itself a subreaper
(PR_SET_CHILD_SUBREAPER): the launcher, not the zygote, is its parent, reaps it and reads its
exit status, and its PR_SET_PDEATHSIG (``shared.service``) follows the launcher, as for a
service started with ``python -m``. A zygote that dies takes no running service with it. The
service waits for the zygote's go (a byte on a pipe), written only once the launcher has its
pid; a zygote gone before that closes the pipe, and the service, which nobody recorded, ends.

The zygote, and then each service, rewrites its command line (``/proc/<pid>/cmdline``, what
``ps``, the tests and the benchmarks read) to the ``python -m`` line it stands for, in the
memory of the launcher's own arguments, which hold room for it (``launcher_names.ROOM``).
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import os
import socket
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Protocol

from motocell.services.launcher.command_line import rewrite_command_line, room
from motocell.services.launcher.core.forks import (
    Forked,
    ForkProtocolError,
    ForkRefused,
    ForkRequest,
    command_line,
    decode_request,
    encode,
    nul_ended,
)
from motocell.services.launcher.heap_holes import fill_heap_holes
from motocell.shared.launcher_names import PARENT_PID_ENV, ROOM_OPTION, WARM_PARENT_MODULE
from motocell.shared.service import die_with_launcher
from motocell.shared.service_names import WARM_MODULES
from motocell.shared.signals import drop_held_stop_signals, release_stop_signals

STANDARD_STREAMS = 2
"""The highest of stdin, stdout and stderr's descriptors."""


class Held:
    """In the zygote: a service forked and waiting for its go (``await_go``), which it gets
    once the launcher has been told its pid."""

    def __init__(self, pid: int, go: int) -> None:
        self.reply = Forked(pid)
        self._go = go

    def release(self) -> None:
        """The launcher has the pid: let the service run."""
        with contextlib.suppress(BrokenPipeError):  # it died meanwhile: the launcher sees it
            os.write(self._go, b"!")
        os.close(self._go)

    def abandon(self) -> None:
        """The launcher never learnt the pid: the service ends on end of file."""
        os.close(self._go)


Fork = Callable[[ForkRequest], Held | ForkRefused | None]
"""Forks the service of a request: in the zygote, what to reply; in the service, None."""


class Channel(Protocol):
    """The zygote's end of its socket, as lines."""

    def __iter__(self) -> Iterator[bytes]: ...

    def write(self, data: bytes, /) -> int: ...

    def flush(self) -> None: ...


def serve(channel: Channel, fork: Fork, space: int, python: str) -> ForkRequest | None:
    """Answer requests on ``channel`` until it closes (None); in a forked service, its request.

    A request whose command line would not fit in ``space`` bytes is refused, as is a line
    that is not a request: the launcher starts that one as a process of its own. A forked
    service is released only once its reply is flushed; a launcher that no longer reads (it
    gave up on this zygote) ends the loop, and the service with it."""
    for line in channel:
        try:
            request = decode_request(line)
        except ForkProtocolError as exc:
            if not _answer(channel, ForkRefused(str(exc))):
                return None
            continue
        if len(command_line(python, request)) > space:
            forked: Held | ForkRefused | None = ForkRefused(
                f"its command line is longer than {space} bytes"
            )
        else:
            forked = fork(request)
        if forked is None:
            return request
        if isinstance(forked, ForkRefused):
            if not _answer(channel, forked):
                return None
        elif _answer(channel, forked.reply):
            forked.release()
        else:
            forked.abandon()
            return None
    return None


def _answer(channel: Channel, reply: Forked | ForkRefused) -> bool:
    """Whether the reply reached the socket (not when the launcher closed it)."""
    try:
        channel.write(encode(reply))
        channel.flush()
    except OSError:
        return False
    return True


def fork_service(
    request: ForkRequest,
    *,
    fork: Callable[[], int] = os.fork,
    end: Callable[[int], object] = os._exit,
) -> Held | ForkRefused | None:
    """Fork twice (see the module's text): in the zygote, the service, held, once it is the
    launcher's child; in the service, None, once it has its go. ``fork`` and ``end`` are
    ``os.fork`` and ``os._exit``, which a test makes fail or record."""
    del request  # the service reads it from ``serve``'s return
    pid_read, pid_write = os.pipe()
    go_read, go_write = os.pipe()
    try:
        first = fork()
    except OSError as exc:  # EAGAIN, ENOMEM: this one is spawned, the zygote goes on
        for fd in (pid_read, pid_write, go_read, go_write):
            os.close(fd)
        return ForkRefused(f"fork failed: {exc}")
    if first == 0:
        _fork_again((pid_read, go_write), pid_write, go_read, fork, end)  # only the service
        return None
    os.close(pid_write)
    os.close(go_read)
    with os.fdopen(pid_read, "rb") as said:
        text = said.read().decode()
    os.waitpid(first, 0)  # gone: the service's parent is now the launcher
    if not text.isdecimal():
        os.close(go_write)
        return ForkRefused(f"fork failed: {text}")
    return Held(int(text), go_write)


def _fork_again(
    zygotes: tuple[int, int],
    pid_write: int,
    go_read: int,
    fork: Callable[[], int],
    end: Callable[[int], object],
) -> None:
    """In the first child: close the zygote's ends of the pipes, fork the service, tell the
    zygote its pid, and end, whatever happens (a zygote gone makes the write raise
    BrokenPipeError): nothing of the zygote's own code (its ``with`` blocks, its atexit
    handlers) may run here. Returns only in the service, once the zygote lets it go; a
    service whose zygote is gone first ends at once."""
    in_service = False
    try:
        for fd in zygotes:
            os.close(fd)
        try:
            service = fork()
        except OSError as exc:
            os.write(pid_write, str(exc).encode())
        else:
            in_service = service == 0
            if not in_service:
                os.write(pid_write, str(service).encode())
    finally:
        if not in_service:
            end(0)
    os.close(pid_write)
    if not await_go(go_read):
        end(0)


def await_go(go: int) -> bool:
    """In a forked service: whether the zygote let it go (False: the zygote is gone, and the
    launcher never learnt this process's pid)."""
    try:
        return os.read(go, 1) != b""
    finally:
        os.close(go)


def become(request: ForkRequest, python: str) -> None:
    """In a forked service: what ``python -m request.module *request.args`` would do from here
    (a process group of its own, as the launcher gives a spawned one; its command line)."""
    os.setpgid(0, 0)
    rewrite_command_line(command_line(python, request))
    service = sys.modules[f"{request.module}.__main__"]  # imported by ``warm_up``
    sys.argv = [service.__file__ or request.module, *request.args]
    service.main()


def warm_up(modules: Sequence[str]) -> None:
    """Import every service's modules, then take them out of the garbage collector's sight:
    a collection in a service would otherwise write to every object's header and copy the
    pages the forks share (docs/startup.md). The collector is paused while they import: what
    they make lives as long as the process, and the 60 collections it would otherwise run
    meanwhile, walking it, are 6 % of the imports' CPU. Last, it takes the C heap's free chunks
    (``heap_holes``), which the forks' allocations would otherwise fill, each copying a page."""
    gc.disable()
    try:
        for module in modules:
            importlib.import_module(f"{module}.__main__")
    finally:
        gc.enable()
    fill_heap_holes()
    gc.freeze()


def run(channel: socket.socket, launcher: int) -> None:
    """The zygote, just forked from ``launcher`` (``warm_parent.fork_zygote``) with its end of
    the socket, ``channel``: serve the launcher until it closes the socket; in a forked
    service, run the service."""
    os.environ[PARENT_PID_ENV] = str(launcher)  # for ``die_with_launcher``, here and in forks
    sys._xoptions.pop(ROOM_OPTION, None)  # the launcher's: not for a Python its forks start
    os.setpgid(0, 0)  # a process group of its own, as every service has: a Ctrl-C reaches
    # the launcher alone, which stops the children in order
    close_inherited(keep=channel.fileno())
    rewrite_command_line(nul_ended((sys.executable, "-m", WARM_PARENT_MODULE)))
    # Forked while the launcher holds SIGINT and SIGTERM (its ``__main__``: before its own
    # handlers exist). One sent to the launcher's process group before the line above is held
    # here too, and is the launcher's: dropped. Then released, SIGTERM ends it, the one its
    # PR_SET_PDEATHSIG sends when the launcher dies.
    drop_held_stop_signals()
    release_stop_signals()
    die_with_launcher()
    warm_up(WARM_MODULES)
    with channel, channel.makefile("rwb") as lines:
        request = serve(lines, fork_service, room(), sys.executable)
    if request is None:
        # The launcher is done with it: nothing of its own to flush or undo, and tearing its
        # modules down would only cost the CPU the launcher waits for (``warm.Zygote.retire``).
        os._exit(0)
    become(request, sys.executable)


def close_inherited(keep: int) -> None:
    """Close every descriptor of the launcher's but the standard streams and ``keep``: a
    service started with ``python -m`` inherits none of them (the harness's lifeline among
    them), and neither does a fork. Those open, as listed, not a range up to the limit: where
    the kernel has no ``close_range`` (or a sandbox refuses it) that is one ``close`` per
    number, a million of them under a container's usual limit."""
    for name in os.listdir("/proc/self/fd"):
        fd = int(name)
        if fd > STANDARD_STREAMS and fd != keep:
            with contextlib.suppress(OSError):  # the listing's own, closed by then
                os.close(fd)
