"""Figure 7: how many 4-group cells fit on this machine with no missed period.

    python -m motocell.bench.run --only 7 [--quick]

Each cell is a whole ``motocell up`` with its own router, 4 groups (arm6, arm6, arm7,
positioner2), the default 10 ms state period, one state client, and a motion client streaming a
2016 trajectory (every axis swinging 0.2 rad either side of its start, points 200 ms apart, like
motoman_driver, so every gateway also answers BUSY points) for as long as the figure runs; the
clients run in processes of their own (``bench.clients``).

The goal: with SCHED_FIFO, 0 missed periods in 3 x 60 s for as many cells as fit in 70 % of the
machine's CPU (two on a 2-core machine). The search (``next_count``, ``fits``):

1. probe: start with 1 cell; after each cell is added and moving, one short window (10 s; quick
   1 s) measures missed periods (the increase of ``Tick.missed``, all cells) and the CPU of
   every cell process (from /proc, % of one core, all cells together). Another cell is added
   while that window had 0 missed periods and CPU under 70 % of the machine, up to a cap
   (4 cells; quick 2);
2. verify: the largest probed count that fits is measured for 3 windows of 60 s (quick 2 s)
   with only that many cells running; if a window misses a period or goes over the CPU limit,
   one count less is verified, at most ``VERIFICATIONS`` times in all.

Reported: the largest verified count, per probed count its missed periods and CPU, per verified
count its windows' missed periods, lateness p99 and CPU, and CPU % / RSS per process kind with
one cell and at the largest count.
"""

from __future__ import annotations

import contextlib
import os
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motocell.bench.clients import StateClientProcess, StreamClientProcess
from motocell.bench.harness import (
    CpuSampler,
    Observer,
    bench_cell,
    figure_result,
    gc_paused,
    oscillations,
    percentiles,
    positions_of,
    process_kinds,
    wait_moving,
    workdir,
)
from motocell.testkit.client import ex_messages

FIGURE = 7
CPU_SHARE = 0.7
"""Of the machine's CPU, for the cells' processes together."""
MAX_CELLS = 4
QUICK_MAX_CELLS = 2
PROBE_S = 10.0
QUICK_PROBE_S = 1.0
WINDOWS = 3
WINDOW_S = 60.0
QUICK_WINDOW_S = 2.0
VERIFICATIONS = 2
COUNT_GOAL = 2
"""Cells the goal expects on a 2-core machine."""
AMPLITUDE = 0.2
SWING_PERIOD_S = 20.0
POINT_INTERVAL_S = 0.2
SETTLE_S = 1.0
"""After a cell is added: its start-up burst passes."""
KINDS = (
    "launcher+router",
    "controller",
    "executor",
    "broadcaster",
    "interpolator",
    "gateway",
)


def cpu_limit(cpus: int) -> float:
    """CPU_SHARE of the machine, in % of one core."""
    return CPU_SHARE * cpus * 100.0


def fits(missed: float, cpu: float, limit: float) -> bool:
    return missed == 0 and cpu <= limit


def next_count(cells: int, missed: float, cpu: float, limit: float, cap: int) -> int | None:
    """After probing ``cells`` cells: how many to probe next, or None when the search stops
    (a missed period, the CPU over the limit, or the cap)."""
    if not fits(missed, cpu, limit) or cells >= cap:
        return None
    return cells + 1


class Loaded:
    """One cell with a state client and a motion client streaming until it is closed."""

    def __init__(self, directory: Path, name: str, seconds: float) -> None:
        self.stack = contextlib.ExitStack()
        try:
            self._start(directory, name, seconds)
        except BaseException:
            self.stack.close()
            raise

    def _start(self, directory: Path, name: str, seconds: float) -> None:
        stack = self.stack
        self.cell = stack.enter_context(bench_cell(directory, name))
        self.observer = stack.enter_context(Observer(self.cell))
        self.observer.record_ticks()
        state = StateClientProcess(self.cell, directory / f"{name}-state.npz", seconds)
        stack.callback(state.kill)
        streamer = stack.enter_context(StreamClientProcess(self.cell, directory))
        streamer.start_traj_mode()
        starts = positions_of(self.cell.cell, self.observer.wait_still())
        plans = oscillations(starts, AMPLITUDE, SWING_PERIOD_S, seconds, POINT_INTERVAL_S)
        mark = self.observer.mark()
        streamer.begin(ex_messages(plans), seconds)
        stack.callback(streamer.end)
        wait_moving(self.observer, mark)

    def close(self) -> None:
        self.stack.close()


@dataclass(frozen=True)
class Window:
    """One measuring window over every loaded cell."""

    missed: float
    lateness_p99_us: float
    total_cpu: float
    by_kind: dict[str, tuple[float, float]]
    """Mean CPU (% of a core) and RSS per process kind that ran."""


def measure_window(cells: Sequence[Loaded], window_s: float) -> Window:
    marks = [c.observer.mark() for c in cells]
    sampler = CpuSampler({p: k for c in cells for p, k in process_kinds(c.cell).items()})
    time.sleep(window_s)
    rows = sampler.finish()
    missed = 0
    lateness: list[float] = []
    for c, mark in zip(cells, marks, strict=True):
        ticks = c.observer.ticks_since(mark - 1)
        if not any(any(g.increment) for t in ticks for g in t.groups):
            raise RuntimeError(f"cell {c.cell.cell.name} stopped moving")
        missed += ticks[-1].missed - ticks[0].missed
        lateness += [t.lateness_ns / 1000 for t in ticks[1:]]
    by_kind = {}
    for kind in KINDS:
        cpu = [r[2] for r in rows if r[0] == kind]
        rss = [r[3] for r in rows if r[0] == kind]
        if cpu:
            by_kind[kind] = (statistics.mean(cpu), statistics.mean(rss))
    return Window(float(missed), percentiles(lateness, (99,))[0], sum(r[2] for r in rows), by_kind)


@dataclass
class Search:
    """What the figure measured."""

    limit: float
    probes: dict[int, Window]
    verified: dict[int, list[Window]]
    largest: int


def search(quick: bool) -> Search:
    cap = QUICK_MAX_CELLS if quick else MAX_CELLS
    probe_s = QUICK_PROBE_S if quick else PROBE_S
    window_s = QUICK_WINDOW_S if quick else WINDOW_S
    limit = cpu_limit(os.cpu_count() or 1)
    seconds = cap * (probe_s + 30.0) + VERIFICATIONS * WINDOWS * window_s + 60.0
    found = Search(limit, {}, {}, 0)
    cells: list[Loaded] = []
    with contextlib.ExitStack() as stack:
        directory = stack.enter_context(workdir())
        stack.callback(_close_all, cells)
        stack.enter_context(gc_paused())
        count: int | None = 1
        while count is not None:
            cells.append(Loaded(directory, f"scale{count}", seconds))
            time.sleep(SETTLE_S)
            probe = found.probes[count] = measure_window(cells, probe_s)
            count = next_count(len(cells), probe.missed, probe.total_cpu, limit, cap)
        candidate = max(
            (n for n, w in found.probes.items() if fits(w.missed, w.total_cpu, limit)), default=0
        )
        for _ in range(VERIFICATIONS):
            if candidate == 0:
                break
            while len(cells) > candidate:
                cells.pop().close()
            windows = found.verified[candidate] = [
                measure_window(cells, window_s) for _ in range(WINDOWS)
            ]
            if all(fits(w.missed, w.total_cpu, limit) for w in windows):
                found.largest = candidate
                break
            candidate -= 1
    return found


def _close_all(cells: list[Loaded]) -> None:
    while cells:
        cells.pop().close()


def run(quick: bool) -> list[dict[str, Any]]:
    found = search(quick)
    window_s = QUICK_WINDOW_S if quick else WINDOW_S
    results = [
        figure_result(
            FIGURE,
            f"largest N with 0 missed periods and CPU <= {found.limit:g} % of a core",
            "cells",
            [found.largest],
            goal=(">=", COUNT_GOAL),
            note=f"{WINDOWS} x {window_s:g} s windows at that N; 4-group cells",
        )
    ]
    for n, probe in found.probes.items():
        results += [
            figure_result(
                FIGURE, f"N={n} probe: missed periods, all cells", "periods", [probe.missed]
            ),
            figure_result(
                FIGURE, f"N={n} probe: CPU of all cell processes", "% of 1 core", [probe.total_cpu]
            ),
        ]
    for n, windows in found.verified.items():
        results += [
            figure_result(
                FIGURE,
                f"N={n}: missed periods, all cells",
                "periods",
                [w.missed for w in windows],
                goal=("==", 0),
                rule="all",
            ),
            figure_result(
                FIGURE, f"N={n}: executor lateness p99", "us", [w.lateness_p99_us for w in windows]
            ),
            figure_result(
                FIGURE,
                f"N={n}: CPU of all cell processes",
                "% of 1 core",
                [w.total_cpu for w in windows],
                goal=("<=", found.limit),
                rule="all",
            ),
        ]
    return results + _per_kind(found)


def _per_kind(found: Search) -> list[dict[str, Any]]:
    """CPU and RSS per process kind with one cell (its probe) and at the largest count."""
    views = {1: [found.probes[1]]} if 1 in found.probes else {}
    if found.largest in found.verified:
        views[found.largest] = found.verified[found.largest]
    results = []
    for n, windows in views.items():
        for column, unit, label in ((0, "% of 1 core", "CPU"), (1, "MiB", "RSS")):
            for kind in KINDS:
                values = [w.by_kind[kind][column] for w in windows if kind in w.by_kind]
                if values:
                    results.append(figure_result(FIGURE, f"N={n}: {kind} {label}", unit, values))
    return results
