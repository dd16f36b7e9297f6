"""What a group of processes holds that no other process does: a further cell's memory.

    python -m motocell.tools.bench.own_memory PID [PID ...]

Summing each process's private pages (``Private_*`` of smaps) misses the pages a cell's
processes share only among themselves: the warm parent's heap, which the services forked from
it map until they write to it, is private to none of them, and yet a further cell brings its
own. Summing PSS counts them, but also a share of every library the cell maps, which a
further cell beside others does not add. So this reads, for every page a process maps, the
physical page behind it (``/proc/<pid>/pagemap``) and how many mappings that page has on the
whole machine (``/proc/kpagecount``): an anonymous page (the heap, copies on write, Python's
objects, thread stacks) whose mappings are all this group's is the group's own, counted once.

Reading physical page numbers needs CAP_SYS_ADMIN (root): without it the kernel reads them as
0, and ``own_memory`` says so (None) instead of guessing. File-backed pages (the interpreter,
libraries, the page cache) are left out: a further cell shares them; so are pages swapped out
and shared memory segments. The processes are read one after another, not at one instant.
"""

from __future__ import annotations

import argparse
import ctypes
import os
from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

PAGE = os.sysconf("SC_PAGE_SIZE")
ENTRY = 8
"""Bytes per page in pagemap and kpagecount."""
PRESENT = np.uint64(1 << 63)
FILE_OR_SHARED = np.uint64(1 << 61)
FRAME = np.uint64((1 << 55) - 1)
"""pagemap's bits (the kernel's Documentation/admin-guide/mm/pagemap.rst): the page is in
memory; it is a file's page or shared anonymous memory; the physical frame number."""
MIB = 1 << 20


@dataclass(frozen=True)
class OwnMemory:
    total_mib: float
    """Every anonymous page only the group maps, once."""
    alone_mib: dict[int, float]
    """By process: the pages only it maps."""
    among_mib: float
    """The pages two or more of the group map and nobody else does."""


def frames(pid: int) -> np.ndarray:
    """The physical frames of the anonymous pages ``pid`` has in memory, one per mapping of
    each (empty once the process is gone)."""
    found = []
    try:
        with open(f"/proc/{pid}/maps") as maps, open(f"/proc/{pid}/pagemap", "rb") as pagemap:
            for start, end in _ranges(maps):
                pagemap.seek(start // PAGE * ENTRY)
                entries = np.frombuffer(pagemap.read((end - start) // PAGE * ENTRY), np.uint64)
                anonymous = (entries & PRESENT != 0) & (entries & FILE_OR_SHARED == 0)
                found.append(entries[anonymous] & FRAME)
    except (OSError, ValueError):  # gone meanwhile
        return np.zeros(0, np.uint64)
    return np.concatenate(found) if found else np.zeros(0, np.uint64)


def _ranges(maps: Iterable[str]) -> Iterator[tuple[int, int]]:
    for line in maps:
        if line.rstrip().endswith("[vsyscall]"):  # above what pagemap reads
            continue
        start, end = line.split(maxsplit=1)[0].split("-")
        yield int(start, 16), int(end, 16)


def own_memory(pids: Sequence[int]) -> OwnMemory | None:
    """What ``pids`` alone hold; None where this process cannot read physical frames."""
    if not frames_readable():
        return None
    by_pid = {pid: frames(pid) for pid in pids}
    mapped = np.concatenate([np.zeros(0, np.uint64), *by_pid.values()])
    unique, here = np.unique(mapped, return_counts=True)
    everywhere = _mapcounts(unique)
    own = unique[everywhere == here]
    alone = set(own[here[everywhere == here] == 1].tolist())
    counts: Counter[int] = Counter()
    for pid, pages in by_pid.items():
        counts[pid] = sum(1 for frame in pages.tolist() if frame in alone)
    alone_pages = sum(counts.values())
    return OwnMemory(
        total_mib=own.size * PAGE / MIB,
        alone_mib={pid: counts[pid] * PAGE / MIB for pid in pids},
        among_mib=(own.size - alone_pages) * PAGE / MIB,
    )


def frames_readable() -> bool:
    """Whether pagemap gives this process physical frames: without CAP_SYS_ADMIN it reads each
    as 0, and another user's pagemap not at all."""
    probe = bytearray(PAGE)
    probe[0] = 1  # in memory, written: its own frame
    address = ctypes.addressof(ctypes.c_char.from_buffer(probe))
    with open("/proc/self/pagemap", "rb") as pagemap:
        pagemap.seek(address // PAGE * ENTRY)
        entry = np.frombuffer(pagemap.read(ENTRY), np.uint64)[0]
    return bool(entry & FRAME) and os.access("/proc/kpagecount", os.R_OK)


def _mapcounts(frames_: np.ndarray) -> np.ndarray:
    """How many mappings each frame has on the machine (``frames_`` sorted, unique)."""
    counts = np.zeros(frames_.size, np.uint64)
    fd = os.open("/proc/kpagecount", os.O_RDONLY)
    try:
        for index, frame in enumerate(frames_.tolist()):
            counts[index] = np.frombuffer(os.pread(fd, ENTRY, frame * ENTRY), np.uint64)[0]
    finally:
        os.close(fd)
    return counts


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="own_memory", description=__doc__.splitlines()[0])
    parser.add_argument("pids", nargs="+", type=int, metavar="PID")
    args = parser.parse_args(argv)
    own = own_memory(args.pids)
    if own is None:
        print("own_memory: physical frames are unreadable here (needs root)")
        return 1
    for pid, mib in own.alone_mib.items():
        print(f"{pid:>8}  {mib:6.1f} MiB alone  {_command(pid)}")
    print(f"shared among them alone: {own.among_mib:.1f} MiB; in all: {own.total_mib:.1f} MiB")
    return 0


def _command(pid: int) -> str:
    """The start of its command line; "(gone)" once it has ended."""
    try:
        words = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")[:3]
    except OSError:
        return "(gone)"
    return b" ".join(words).decode(errors="replace")


if __name__ == "__main__":
    raise SystemExit(main())
