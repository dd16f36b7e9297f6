"""A group's own memory (tools/bench/own_memory.py): the pages it alone maps, a page two of its
processes share counted once, a page shared with a process outside it not at all."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator

import pytest

from motocell.tools.bench.own_memory import own_memory

HELD_MIB = 16
HOLDER = (
    "import os, sys\n"
    f"held = bytearray({HELD_MIB} << 20)\n"
    "for page in range(0, len(held), 4096):\n"
    "    held[page] = 1\n"  # in memory: a page never written is the shared zero page
    "if os.fork() == 0:\n"
    "    print(os.getpid(), flush=True)\n"  # the child shares the parent's pages, unwritten
    "    sys.stdin.read()\n"
    "    os._exit(0)\n"
    "sys.stdin.read()\n"
    "os.wait()\n"
)
"""A process holding HELD_MIB of its own, and its fork, which maps the same pages."""

needs_root = pytest.mark.skipif(os.geteuid() != 0, reason="physical frames are root's to read")
pytestmark = pytest.mark.cell  # processes of their own


@pytest.fixture
def parent_and_child() -> Iterator[tuple[int, int]]:
    with subprocess.Popen(
        [sys.executable, "-c", HOLDER], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    ) as holder:
        assert holder.stdin is not None and holder.stdout is not None
        try:
            yield holder.pid, int(holder.stdout.readline())
        finally:
            holder.stdin.close()
            holder.wait(30)


@needs_root
def test_pages_two_processes_share_count_once_for_both(
    parent_and_child: tuple[int, int],
) -> None:
    parent, child = parent_and_child
    both = own_memory([parent, child])
    assert both is not None
    assert both.among_mib >= HELD_MIB  # the buffer, mapped by both
    assert both.total_mib >= HELD_MIB
    assert both.total_mib < 3 * HELD_MIB  # not once per process


@needs_root
def test_a_page_shared_with_a_process_outside_is_not_the_groups(
    parent_and_child: tuple[int, int],
) -> None:
    parent, child = parent_and_child
    alone = own_memory([child])
    both = own_memory([parent, child])
    assert alone is not None and both is not None
    assert alone.total_mib < both.total_mib - HELD_MIB / 2
    assert alone.among_mib == 0  # one process: nothing is shared within it


@needs_root
def test_a_gone_process_holds_nothing() -> None:
    gone = own_memory([2**22 + 1])  # above the kernel's largest pid
    assert gone is not None
    assert gone.total_mib == 0


@pytest.mark.skipif(
    os.geteuid() != 0 or shutil.which("setpriv") is None, reason="needs to drop root"
)
def test_without_root_it_says_so() -> None:
    unprivileged = ["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups"]
    done = subprocess.run(
        [*unprivileged, sys.executable, "-m", "motocell.tools.bench.own_memory", str(os.getpid())],
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
    )
    assert done.returncode == 1, done.stderr
    assert "needs root" in done.stdout
