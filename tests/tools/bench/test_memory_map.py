"""The memory map tool: smaps parsed, mappings told apart by kind, this process mapped."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from motocell.tools.bench.memory_map import (
    ARENA_ALIGN,
    KINDS,
    KindTotal,
    Mapping,
    by_kind,
    inherited_kib,
    kind_of,
    main,
    parse_smaps,
    read_mappings,
)

SMAPS = """\
55d70af95000-55d70b466000 rw-p 00000000 00:00 0                          [heap]
Size:               4900 kB
Pss:                4456 kB
Private_Clean:         0 kB
Private_Dirty:      4456 kB
VmFlags: rd wr mr mw me ac sd
7fb551d8a000-7fb552d86000 r-xp 0015c000 fe:01 1234   /venv/zenoh/zenoh.abi3.so
Size:              16368 kB
Pss:                2573 kB
Private_Clean:       708 kB
Private_Dirty:         0 kB
VmFlags: rd ex mr mw me sd
"""


def anon(start: int, size: int, perms: str = "rw-p", private: int = 4) -> Mapping:
    return Mapping(start, start + size, perms, "", private, private, private)


def test_each_mapping_of_an_smaps_text_is_read_with_its_private_pages() -> None:
    heap, library = parse_smaps(SMAPS)
    assert (heap.path, heap.private_kib, heap.private_dirty_kib, heap.pss_kib) == (
        "[heap]",
        4456,
        4456,
        4456,
    )
    assert library.path == "/venv/zenoh/zenoh.abi3.so"
    assert (library.private_kib, library.private_dirty_kib, library.pss_kib) == (708, 0, 2573)


def test_an_anonymous_mapping_above_a_guard_page_is_a_thread_stack() -> None:
    guard = anon(0x7F0000001000, 4096, "---p", private=0)
    stack = anon(guard.end, 8 << 20)
    assert kind_of(stack, guard) == "stack"
    assert kind_of(stack, anon(0x7F0000001000, 4096)) == "anon"
    assert kind_of(stack, None) == "anon"


def test_an_anonymous_mapping_on_a_64_mib_boundary_is_a_malloc_arena() -> None:
    assert kind_of(anon(0x7F00 * ARENA_ALIGN, 132 << 10), None) == "arena"
    assert kind_of(anon(0x7F00 * ARENA_ALIGN + 4096, 132 << 10), None) == "anon"


def test_named_mappings_are_heap_stack_file_or_the_kernels() -> None:
    def named(path: str) -> str:
        return kind_of(Mapping(0x1000, 0x2000, "rw-p", path, 4, 4, 4), None)

    assert [named(p) for p in ("[heap]", "[stack]", "[vvar]", "/usr/lib/libc.so.6")] == [
        "heap",
        "stack",
        "kernel",
        "file",
    ]


def test_by_kind_sums_every_mapping_into_its_kind() -> None:
    totals = by_kind(parse_smaps(SMAPS))
    assert list(totals) == list(KINDS)
    assert totals["heap"] == KindTotal(4456, 4456, 4456)
    assert totals["file"] == KindTotal(708, 0, 2573)
    assert totals["anon"] == KindTotal()


def rollup_private_kib() -> int:
    fields = {}
    for line in Path("/proc/self/smaps_rollup").read_text().splitlines()[1:]:
        name, value, *_ = line.split()
        fields[name.rstrip(":")] = int(value)
    return fields["Private_Clean"] + fields["Private_Dirty"]


def test_this_process_mapped_by_kind_adds_up_to_what_the_kernel_counts() -> None:
    started = threading.Event()
    stop = threading.Event()

    def waits() -> None:
        started.set()
        stop.wait()

    thread = threading.Thread(target=waits)
    thread.start()
    try:
        started.wait()
        before = rollup_private_kib()
        totals = by_kind(read_mappings(os.getpid()))
        whole = sum(totals.values(), KindTotal()).private_kib
        after = rollup_private_kib()
    finally:
        stop.set()
        thread.join()
    # Reading the mappings touches pages of its own (a MiB where many modules are loaded): the
    # sum lies between the kernel's counts before and after it, give or take a few pages.
    assert min(before, after) - 64 <= whole <= max(before, after) + 64
    assert totals["heap"].private_kib > 0
    assert totals["file"].private_kib > 0
    assert totals["stack"].private_kib > 0  # the main thread's and the one above


def test_a_process_that_is_not_there_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(2**22 + 1)]) == 2  # above the kernel's largest pid
    assert capsys.readouterr().err.count("\n") == 1


def test_pids_and_a_cell_are_not_asked_together() -> None:
    with pytest.raises(SystemExit):
        main(["1", "--cell", "single-arm"])


def test_what_a_fork_wrote_in_its_parents_mappings_is_inherited() -> None:
    parent = [anon(0x7F0000000000, 1 << 20, private=100), anon(0x7F0000200000, 1 << 20)]
    code = Mapping(0x7F0000200000, 0x7F0000300000, "r-xp", "/lib/x.so", 50, 0, 50)
    child = [anon(0x7F0000000000, 1 << 20, private=300), code, anon(0x7F0000400000, 1 << 20)]
    assert inherited_kib(child, parent) == 300  # not the code only it has read, nor the new
