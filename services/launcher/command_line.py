"""A process's command line (``/proc/<pid>/cmdline``, what ``ps``, the tests and the benchmarks
read), rewritten in the memory of its arguments: the zygote and each service it forks write the
``python -m`` line they stand for into their launcher's, which holds room for the longest
(``launcher_names.ROOM``), and the launcher writes its own line back without that room."""

from __future__ import annotations

import ctypes
from pathlib import Path

ARG_START_FIELD = 45
ARG_END_FIELD = 46
"""arg_start and arg_end, fields 48 and 49 of /proc/<pid>/stat (stat(5)), counted from the
field after the command's name."""


def arguments_area() -> tuple[int, int]:
    """Where this process's arguments are in its memory: the first byte and one past the last."""
    fields = Path("/proc/self/stat").read_text().rsplit(")", 1)[-1].split()
    return int(fields[ARG_START_FIELD]), int(fields[ARG_END_FIELD])


def room() -> int:
    start, end = arguments_area()
    return end - start


def rewrite_command_line(words: bytes) -> None:
    """Make ``/proc/self/cmdline`` read ``words`` (NUL-ended words), the rest of the area
    zeroed; ValueError where they do not fit, which would write past it. The interpreter keeps
    copies of its arguments (``sys.argv``), nothing reads the originals again."""
    start, end = arguments_area()
    if len(words) > end - start:
        raise ValueError(f"a command line of {len(words)} bytes in room for {end - start}")
    filled = words.ljust(end - start, b"\0")
    ctypes.memmove(start, filled, len(filled))
