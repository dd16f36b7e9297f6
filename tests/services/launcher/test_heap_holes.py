"""Taking the C heap's holes (services/launcher/heap_holes.py): the sizes asked for, the filling
against a scripted heap, and glibc's own holes taken in a fresh interpreter."""

from __future__ import annotations

import subprocess
import sys

import pytest

from motocell.services.launcher.heap_holes import (
    LARGEST_REQUEST,
    SMALLEST_REQUEST,
    TCACHE_LARGEST,
    request_sizes,
    take_holes,
)

HOLE = 200
"""A request size of glibc's per-thread cache, and over its fast bins' largest."""


def test_the_sizes_go_from_the_largest_to_every_size_of_the_cache() -> None:
    sizes = list(request_sizes())
    assert sizes[0] == LARGEST_REQUEST
    assert sizes == sorted(sizes, reverse=True)
    assert set(range(SMALLEST_REQUEST, TCACHE_LARGEST + 1, 16)) <= set(sizes)
    assert sizes[-1] == SMALLEST_REQUEST


class Heap:
    """Holes of given sizes below a top that serves anything; ``malloc`` takes the first hole
    that holds the request."""

    def __init__(self, holes: list[int]) -> None:
        self.holes = holes
        self.top = 1_000_000
        self.freed: list[int] = []

    def malloc(self, size: int) -> int:
        for at, hole in enumerate(self.holes):
            if hole >= size:
                self.holes[at] -= size
                return at
        self.top += size
        return self.top - size

    def free(self, chunk: int) -> None:
        self.freed.append(chunk)


def test_every_hole_is_taken_and_what_came_from_the_top_is_freed() -> None:
    heap = Heap([100_000, 300, 24])
    kept = take_holes(heap.malloc, heap.free, lambda: 1_000_000, most=10**9)
    assert all(left < SMALLEST_REQUEST for left in heap.holes)
    assert kept == 100_324 - sum(heap.holes)
    assert all(chunk >= 1_000_000 for chunk in heap.freed)


def test_no_more_than_the_free_bytes_are_kept() -> None:
    heap = Heap([])  # a top that is never recognised as one: every chunk looks like a hole
    assert take_holes(heap.malloc, heap.free, lambda: 2**62, most=5000) <= 5000


def test_a_failed_allocation_ends_the_filling() -> None:
    assert take_holes(lambda size: None, lambda chunk: None, lambda: 0, most=10**9) == 0


GLIBC_HOLES = f"""
import ctypes
from motocell.services.launcher.heap_holes import fill_heap_holes
libc = ctypes.CDLL(None)
libc.malloc.restype = ctypes.c_void_p
libc.malloc.argtypes = [ctypes.c_size_t]
libc.free.argtypes = [ctypes.c_void_p]
pairs = [(libc.malloc({HOLE}), libc.malloc({HOLE})) for _ in range(20)]
holes = {{hole for hole, _ in pairs}}
for hole in holes:  # the second of each pair keeps the holes apart
    libc.free(hole)
assert fill_heap_holes() >= len(holes) * {HOLE}
after = [libc.malloc({HOLE}) for _ in range(len(holes))]
assert holes.isdisjoint(after), "a hole was left for a later allocation"
"""
"""Holes made in a fresh interpreter's heap, as the zygote's imports leave them: the test run's
own heap, after thousands of tests, is fragmented past what a test can set up."""


@pytest.mark.cell  # a process of its own
def test_glibcs_holes_are_taken() -> None:
    done = subprocess.run(
        [sys.executable, "-c", GLIBC_HOLES], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
