"""Where a process's memory is, by kind of mapping, read from ``/proc/<pid>/smaps``.

    python -m motocell.tools.bench.memory_map PID [PID ...]
    python -m motocell.tools.bench.memory_map --cell single-arm|four-group

Figure 13 says what a cell's processes hold in all (PSS, private pages, its own memory); this
says which of their mappings hold it, so that a saving can be aimed. ``--cell`` starts a cell
as figure 13 does (the launcher's default start), waits until it is motion-ready and maps
every process of it by kind (launcher+router, each service). As root it also gives, from
``own_memory``, the pages each process alone maps on the machine and the group's own memory
in all (the pages only its processes map, counted once).

The kinds:

- ``heap``: glibc's main arena (``[heap]``), the main thread's ``malloc``: Python's objects
  above 512 bytes, Python's own small-object arenas where ``brk`` had room;
- ``arena``: glibc's further arenas, one per thread that mallocs (up to 8 per core): Zenoh's
  Rust threads and Python's. An arena is a 64 MiB reservation aligned to 64 MiB, so an
  anonymous mapping starting on such a boundary is one;
- ``stack``: threads' stacks: an anonymous mapping right above a guard page (no access, one
  page or more), and the main thread's ``[stack]``;
- ``anon``: every other anonymous mapping: Python's object arenas, numpy's buffers, large
  ``malloc`` blocks, Zenoh's buffers;
- ``file``: file-backed mappings (the interpreter, shared libraries, extension modules): their
  private pages are the relocations and writes a process made to them (dirty), or pages
  only it maps (clean);
- ``kernel``: the kernel's (``[vdso]``, ``[vvar]``, ...).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from motocell.tools.bench.own_memory import OwnMemory, own_memory

KINDS = ("heap", "arena", "stack", "anon", "file", "kernel")
ARENA_ALIGN = 64 << 20
"""glibc's HEAP_MAX_SIZE on 64-bit: every further arena is mapped aligned to it."""


@dataclass(frozen=True)
class Mapping:
    start: int
    end: int
    perms: str
    path: str
    private_kib: int
    """Private_Clean + Private_Dirty."""
    private_dirty_kib: int
    pss_kib: int


@dataclass(frozen=True)
class KindTotal:
    private_kib: int = 0
    private_dirty_kib: int = 0
    pss_kib: int = 0

    def __add__(self, other: KindTotal) -> KindTotal:
        return KindTotal(
            self.private_kib + other.private_kib,
            self.private_dirty_kib + other.private_dirty_kib,
            self.pss_kib + other.pss_kib,
        )


def parse_smaps(text: str) -> list[Mapping]:
    """Every mapping of an smaps text, in address order (as the kernel writes them)."""
    mappings: list[Mapping] = []
    header: list[str] | None = None
    fields: dict[str, int] = {}

    def close() -> None:
        if header is None:
            return
        start, end = (int(half, 16) for half in header[0].split("-"))
        path = header[5] if len(header) > 5 else ""
        clean, dirty = fields.get("Private_Clean", 0), fields.get("Private_Dirty", 0)
        mappings.append(
            Mapping(start, end, header[1], path, clean + dirty, dirty, fields.get("Pss", 0))
        )

    for line in text.splitlines():
        words = line.split(maxsplit=5)
        if words and "-" in words[0] and not words[0].endswith(":"):
            close()
            header, fields = words, {}
        elif len(words) == 3 and words[2] == "kB":
            fields[words[0].rstrip(":")] = int(words[1])
    close()
    return mappings


def kind_of(mapping: Mapping, below: Mapping | None) -> str:
    """``below``: the mapping just under this one, if any (a thread stack's guard page)."""
    if mapping.path == "[heap]":
        return "heap"
    if mapping.path == "[stack]":
        return "stack"
    if mapping.path.startswith("["):
        return "kernel"
    if mapping.path:
        return "file"
    if mapping.start % ARENA_ALIGN == 0:
        return "arena"
    guarded = below is not None and below.end == mapping.start and below.perms.startswith("---")
    if guarded and not (below is not None and below.path):
        return "stack"
    return "anon"


def by_kind(mappings: Sequence[Mapping]) -> dict[str, KindTotal]:
    totals = dict.fromkeys(KINDS, KindTotal())
    for index, mapping in enumerate(mappings):
        below = mappings[index - 1] if index else None
        kind = kind_of(mapping, below)
        totals[kind] += KindTotal(mapping.private_kib, mapping.private_dirty_kib, mapping.pss_kib)
    return totals


def inherited_kib(mappings: Iterable[Mapping], parent: Iterable[Mapping]) -> int:
    """Private dirty KiB of a forked process in the mappings it has from its parent (those
    starting where one of the parent's does): pages it shared with the parent at the fork and
    has written since (copy on write), or new blocks in memory it inherited (a free slot of an
    inherited Python arena; the heap, grown since, counts whole). Clean pages are left out: a
    library's code that only this process has read yet is private but not a copy."""
    starts = {mapping.start for mapping in parent}
    return sum(mapping.private_dirty_kib for mapping in mappings if mapping.start in starts)


@dataclass(frozen=True)
class ProcessMap:
    name: str
    totals: dict[str, KindTotal]
    alone_mib: float | None = None
    """Its anonymous pages no other process maps (``own_memory``); None without root."""


def read_mappings(pid: int | str) -> list[Mapping]:
    return parse_smaps(Path(f"/proc/{pid}/smaps").read_text())


def table(rows: Iterable[ProcessMap], own: OwnMemory | None) -> str:
    """Private MiB per kind (dirty in brackets), then private and PSS in all, and the pages it
    alone maps, a line each; then the group's own memory."""
    heading = ["process", *KINDS, "private", "PSS", "alone"]
    lines = [" ".join(f"{word:>13}" for word in heading)]
    for row in rows:
        cells = [
            f"{t.private_kib / 1024:5.1f} ({t.private_dirty_kib / 1024:4.1f})"
            for t in row.totals.values()
        ]
        whole = sum(row.totals.values(), KindTotal())
        alone = "" if row.alone_mib is None else f"{row.alone_mib:.1f}"
        cells += [f"{whole.private_kib / 1024:.1f}", f"{whole.pss_kib / 1024:.1f}", alone]
        lines.append(" ".join(f"{cell:>13}" for cell in [row.name, *cells]))
    if own is not None:
        lines.append(
            f"their own memory: {own.total_mib:.1f} MiB, of it {own.among_mib:.1f} MiB that "
            "two or more of them map and no other process does"
        )
    return "\n".join(lines)


def as_json(rows: Iterable[ProcessMap], own: OwnMemory | None) -> str:
    return json.dumps(
        {
            "processes": [
                {
                    "process": row.name,
                    **{kind: vars(total) for kind, total in row.totals.items()},
                    "alone_mib": row.alone_mib,
                }
                for row in rows
            ],
            "own_mib": None if own is None else own.total_mib,
        }
    )


def mapped_cell(label: str) -> tuple[list[ProcessMap], OwnMemory | None]:
    """Start a cell as figure 13 does and map each of its processes once it is motion-ready."""
    # The harness only for --cell: mapping given pids needs none of it.
    from motocell.testing.running_cell import start_cell  # noqa: PLC0415
    from motocell.tools.bench.bench_start_cost import CELLS  # noqa: PLC0415
    from motocell.tools.bench.bench_startup import milestones  # noqa: PLC0415
    from motocell.tools.bench.measuring import (  # noqa: PLC0415
        process_kinds,
        workdir,
        write_cell_file,
    )

    models = CELLS[label][0]
    with workdir() as directory:
        config = write_cell_file(directory, f"memorymap{label.replace('-', '')}", models=models)
        cell = start_cell(config, log=directory / "cell.log")
        try:
            milestones(cell)
            return mapped(dict(sorted(process_kinds(cell).items(), key=lambda item: item[1])))
        finally:
            cell.stop()


def mapped(names: dict[int, str]) -> tuple[list[ProcessMap], OwnMemory | None]:
    """Each process of ``names`` mapped, and what the group holds alone (None without root)."""
    own = own_memory(list(names))
    rows = [
        ProcessMap(name, by_kind(read_mappings(pid)), None if own is None else own.alone_mib[pid])
        for pid, name in names.items()
    ]
    return rows, own


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="memory_map", description=__doc__.splitlines()[0])
    parser.add_argument("pids", nargs="*", type=int, help="processes to map")
    parser.add_argument("--cell", choices=("single-arm", "four-group"), help="start one, map it")
    parser.add_argument("--json", action="store_true", help="one JSON list instead of a table")
    args = parser.parse_args(argv)
    if bool(args.pids) == bool(args.cell):
        parser.error("give either PIDs or --cell")
    try:
        if args.cell:
            rows, own = mapped_cell(args.cell)
        else:
            rows, own = mapped({pid: str(pid) for pid in args.pids})
    except OSError as exc:
        print(f"memory_map: cannot read {exc.filename}: {exc.strerror}", file=sys.stderr)
        return 2
    print(as_json(rows, own) if args.json else table(rows, own))
    return 0


if __name__ == "__main__":
    sys.exit(main())
