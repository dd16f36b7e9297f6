"""The C heap's free chunks, taken by the launcher and its warm parent before each forks
(docs/startup.md, "What a fork copies, and the heap's holes").

The zygote's imports leave a few hundred small free chunks scattered through glibc's heap
(temporaries freed along the way). A fork's first allocations of the C heap (CPython's for
objects over 512 bytes, numpy's, Zenoh's Rust on the main thread) take those chunks first, and
writing into one copies the whole page around it, a page that otherwise stays shared. The
zygote allocates every free chunk below the heap's top itself and keeps them, so that a fork's
allocations come from the top of the heap, on pages that hold only the fork's own data.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Iterator

LARGEST_REQUEST = 1 << 16
"""Below glibc's mmap threshold (128 KiB at least), so such a request is served from the heap."""

TCACHE_LARGEST = 1032
"""The largest request glibc's per-thread cache serves; each of its bins serves only requests
of its own size, in steps of 16 bytes."""

SMALLEST_REQUEST = 24
"""Its smallest chunk's payload."""

TCACHE_COUNT = 7
"""Chunks a bin of the per-thread cache holds at most. Those chunks are free for what comes
next, yet ``mallinfo2`` counts them in use."""


class MallInfo2(ctypes.Structure):
    """glibc's ``struct mallinfo2`` (mallinfo(3))."""

    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena",
            "ordblks",
            "smblks",
            "hblks",
            "hblkhd",
            "usmblks",
            "fsmblks",
            "uordblks",
            "fordblks",
            "keepcost",
        )
    ]


def request_sizes() -> Iterator[int]:
    """The sizes asked for, largest first: a hole is taken by the largest request it holds, and
    what is left of it by the smaller ones after. Below ``TCACHE_LARGEST`` every size the cache
    has a bin for, since a cached chunk goes only to a request of its size."""
    size = LARGEST_REQUEST
    while size > TCACHE_LARGEST:
        yield size
        size //= 2
    yield from range(TCACHE_LARGEST, SMALLEST_REQUEST - 1, -16)


def fill_heap_holes() -> int:
    """Allocate, and never free, every free chunk of the main heap below its top: the bytes
    kept; 0 where the C library has no ``mallinfo2`` (not glibc, or glibc before 2.33)."""
    libc = ctypes.CDLL(None)
    if not hasattr(libc, "mallinfo2"):
        return 0
    libc.mallinfo2.restype = MallInfo2
    libc.malloc.restype = ctypes.c_void_p
    libc.malloc.argtypes = [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    libc.sbrk.restype = ctypes.c_void_p
    libc.sbrk.argtypes = [ctypes.c_ssize_t]

    def top() -> int:
        """Where the top chunk (the never-used end of the heap) starts."""
        return int(libc.sbrk(0)) - int(libc.mallinfo2().keepcost)

    # The free bytes bound what is kept, whatever the heap's shape (one not made by sbrk alone).
    cached = TCACHE_COUNT * sum(range(SMALLEST_REQUEST, TCACHE_LARGEST + 1, 16))
    return take_holes(libc.malloc, libc.free, top, int(libc.mallinfo2().fordblks) + cached)


def take_holes(
    malloc: Callable[[int], int | None],
    free: Callable[[int], None],
    top: Callable[[], int],
    most: int,
) -> int:
    """Ask ``malloc`` for each of ``request_sizes`` until it answers from ``top`` (no hole of
    that size is left: that one is freed again), keeping at most ``most`` bytes."""
    kept = 0
    for size in request_sizes():
        start = top()  # taking a hole leaves the top where it is
        while kept + size <= most:
            chunk = malloc(size)
            if chunk is None:
                return kept
            if chunk >= start:
                free(chunk)
                break
            kept += size
    return kept
