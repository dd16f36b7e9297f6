"""The lifeline: a cell that stops when the process that started it ends, however it ends.

A harness (``motocell.testing``) starts ``motocell up`` (or ``motocell router``) with
``--lifeline FD``: the read end of a pipe whose write end only the harness holds. The kernel
closes that write end when the harness's process ends, by a return, SIGTERM, SIGKILL or the OOM
killer alike, and the launcher's read then returns end of file: it stops the cell as on SIGTERM,
and removes the directories the harness named with ``--lifeline-scratch`` (the cell's registry,
credentials and cell file), which nobody else is left to remove. PR_SET_PDEATHSIG would not do:
it signals when the thread that started the child ends, not its process, and a test may start
a cell from a thread of its own.

The read end is watched by a thread of its own, blocked in ``read`` (no wake-ups at rest), so the
lifeline holds in every phase of the launcher, waiting for a router to come included.
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import stat
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from motocell.shared.service import StopFlag

log = logging.getLogger("motocell")

READ_SIZE = 64
"""Whatever the starter writes is ignored; only the end of file counts."""


class LifelineError(Exception):
    """``--lifeline`` names no pipe this process holds, or ``--lifeline-scratch`` comes alone."""


def lifeline_argument(text: str) -> int:
    """argparse's type for ``--lifeline FD``: a descriptor number."""
    if not text.isdecimal():
        raise argparse.ArgumentTypeError(f"{text!r} is not a descriptor number")
    return int(text)


def check_lifeline(fd: int | None, scratch: Sequence[str]) -> None:
    """LifelineError unless ``fd`` (None: not given) is a pipe this process holds open;
    ``scratch`` is only removed at the lifeline's end, so it needs one."""
    if fd is None:
        if scratch:
            raise LifelineError("--lifeline-scratch needs --lifeline")
        return
    try:
        mode = os.fstat(fd).st_mode
    except OSError:
        raise LifelineError(
            f"--lifeline {fd}: this process has no descriptor {fd} (start it with the read "
            "end of a pipe as that descriptor)"
        ) from None
    if not stat.S_ISFIFO(mode):
        raise LifelineError(f"--lifeline {fd}: descriptor {fd} is not a pipe")
    # The services must not hold it: only the starter's end decides.
    os.set_inheritable(fd, False)


class Lifeline:
    """Sets ``stop`` once ``fd`` reads end of file; ``ended`` says it did."""

    def __init__(self, fd: int, stop: StopFlag) -> None:
        self._fd = fd
        self._stop = stop
        self.ended = False
        # A daemon: at a stop by a signal the starter still holds its end, and this thread,
        # blocked in read, must not keep the launcher from exiting.
        self._thread = threading.Thread(target=self._watch, name="lifeline", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def _watch(self) -> None:
        try:
            while os.read(self._fd, READ_SIZE):
                pass
        except OSError as exc:
            log.warning("the lifeline failed (%s): stopping the cell", exc)
        else:
            log.warning("the process that started this cell is gone: stopping the cell")
        self.ended = True
        self._stop.set()


@contextmanager
def lifeline(fd: int | None, scratch: Sequence[str], stop: StopFlag) -> Iterator[None]:
    """Watch ``fd`` (None: no lifeline) while the block runs, ``stop`` when it ends; once the
    block is done, if the lifeline ended, remove ``scratch``."""
    if fd is None:
        yield
        return
    watcher = Lifeline(fd, stop)
    watcher.start()
    try:
        yield
    finally:
        if watcher.ended:
            remove(scratch)


def remove(scratch: Sequence[str]) -> None:
    """Remove each directory (or file) and all in it; what is already gone is no matter."""
    for entry in map(Path, scratch):
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
