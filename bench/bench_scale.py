"""Figure 7: how many 4-group cells fit on this machine with no missed period.

    python -m bench.run --only 7 [--quick]

Cells are added one at a time (N = 1, 2, 3, ...), each a whole ``motocell up`` with its own
router, 4 groups (arm6, arm6, arm7, positioner2), the default 10 ms state period, one state
client, and a constant-velocity 2016 trajectory (points 100 ms apart) streamed like
motoman_driver on every cell for as long as the benchmark runs, so every cell always moves and
every gateway answers BUSY points. After a cell is added and moving, three consecutive windows
(10 s each; 1 s in quick mode) measure, over all cells: missed periods (the increase of
``Tick.missed``), executor lateness p99 (raw ticks), and CPU % (of one core) and RSS of every
process (from /proc). Adding stops at the first N with a missed period, or at the cap (4 cells,
36 service processes, in the full suite; 2 in quick mode) to keep the suite's time bounded.

Reported: the largest N whose three windows all had 0 missed periods, the missed periods and
lateness p99 per N, and CPU % / RSS per process kind with one cell (N = 1) and at the largest N
measured.
"""

from __future__ import annotations

import statistics
import threading
import time
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bench.harness import (
    CpuSampler,
    Observer,
    Streamer,
    bench_cell,
    figure_result,
    percentiles,
    positions_of,
    process_kinds,
    ramps,
    start_traj_mode,
    wait_moving,
    workdir,
)
from testkit.cell import RunningCell
from testkit.client import ex_messages

FIGURE = 7
MAX_CELLS = 4
QUICK_MAX_CELLS = 2
WINDOWS = 3
WINDOW_S = 10.0
QUICK_WINDOW_S = 1.0
SPEED = 0.01
TRAJECTORY_S = 900.0
QUICK_TRAJECTORY_S = 120.0
KINDS = (
    "launcher+router",
    "controller",
    "executor",
    "broadcaster",
    "interpolator",
    "gateway",
)


class Loaded:
    """One cell with a state client and a trajectory streaming until stopped."""

    def __init__(self, stack: ExitStack, directory: Path, name: str, seconds: float) -> None:
        self.cell: RunningCell = stack.enter_context(bench_cell(directory, name))
        self.observer = stack.enter_context(Observer(self.cell))
        self.observer.record_ticks()
        stack.enter_context(self.cell.state())
        motion = stack.enter_context(self.cell.motion())
        start_traj_mode(motion)
        starts = positions_of(self.cell.cell, self.observer.wait_still())
        messages = ex_messages(ramps(starts, SPEED, seconds, 0.1))
        self.stop = threading.Event()
        self.streamer = Streamer(motion, messages, self.stop)
        mark = self.observer.mark()
        self.streamer.start()
        stack.callback(self.finish)
        wait_moving(self.observer, mark)

    def finish(self) -> None:
        self.stop.set()
        self.streamer.join(10.0)


@dataclass(frozen=True)
class Window:
    """One measuring window over every loaded cell."""

    missed: float
    lateness_p99_us: float
    total_cpu: float
    by_kind: dict[str, tuple[float, float]]
    """Mean CPU (% of a core) and RSS per process kind that ran."""


def measure_window(cells: list[Loaded], window_s: float) -> Window:
    marks = [c.observer.mark() for c in cells]
    sampler = CpuSampler({p: k for c in cells for p, k in process_kinds(c.cell).items()})
    time.sleep(window_s)
    rows = sampler.finish()
    missed = 0
    lateness: list[float] = []
    for c, mark in zip(cells, marks, strict=True):
        ticks = c.observer.ticks_since(mark - 1)
        missed += ticks[-1].missed - ticks[0].missed
        lateness += [t.lateness_ns / 1000 for t in ticks[1:]]
        if c.streamer.error is not None:
            raise RuntimeError(f"streaming failed: {c.streamer.error}")
    by_kind = {}
    for kind in KINDS:
        cpu = [r[2] for r in rows if r[0] == kind]
        rss = [r[3] for r in rows if r[0] == kind]
        if cpu:
            by_kind[kind] = (statistics.mean(cpu), statistics.mean(rss))
    return Window(float(missed), percentiles(lateness, (99,))[0], sum(r[2] for r in rows), by_kind)


def run(quick: bool) -> list[dict[str, Any]]:
    cap = QUICK_MAX_CELLS if quick else MAX_CELLS
    window_s = QUICK_WINDOW_S if quick else WINDOW_S
    trajectory_s = QUICK_TRAJECTORY_S if quick else TRAJECTORY_S
    missed_by_n: dict[int, list[float]] = {}
    p99_by_n: dict[int, list[float]] = {}
    cpu_by_n: dict[int, dict[str, list[float]]] = {}
    rss_by_n: dict[int, dict[str, list[float]]] = {}
    total_cpu_by_n: dict[int, list[float]] = {}
    with ExitStack() as stack:
        directory = stack.enter_context(workdir())
        cells: list[Loaded] = []
        for n in range(1, cap + 1):
            cells.append(Loaded(stack, directory, f"scale{n}", trajectory_s))
            time.sleep(0.5 if quick else 1.0)  # let the newcomer's start-up burst pass
            missed_by_n[n], p99_by_n[n], total_cpu_by_n[n] = [], [], []
            cpu_by_n[n] = {k: [] for k in KINDS}
            rss_by_n[n] = {k: [] for k in KINDS}
            for _ in range(WINDOWS):
                window = measure_window(cells, window_s)
                missed_by_n[n].append(window.missed)
                p99_by_n[n].append(window.lateness_p99_us)
                total_cpu_by_n[n].append(window.total_cpu)
                for kind, (cpu, rss) in window.by_kind.items():
                    cpu_by_n[n][kind].append(cpu)
                    rss_by_n[n][kind].append(rss)
            if any(missed_by_n[n]):
                break
    clean = [n for n, missed in missed_by_n.items() if not any(missed)]
    largest = max(clean, default=0)
    measured = max(missed_by_n)
    capped = largest == cap
    results = [
        figure_result(
            FIGURE,
            "largest N with 0 missed periods" + (" (the cap)" if capped else ""),
            "cells",
            [largest],
            note=f"{WINDOWS} x {window_s:g} s windows per N; cap {cap}",
        )
    ]
    for n, missed_runs in missed_by_n.items():
        results.append(
            figure_result(FIGURE, f"N={n}: missed periods, all cells", "periods", missed_runs)
        )
        results.append(figure_result(FIGURE, f"N={n}: executor lateness p99", "us", p99_by_n[n]))
        results.append(
            figure_result(
                FIGURE, f"N={n}: CPU of all cell processes", "% of 1 core", total_cpu_by_n[n]
            )
        )
    for n in sorted({1, measured}):
        for kind in KINDS:
            if cpu_by_n[n][kind]:
                results.append(
                    figure_result(FIGURE, f"N={n}: {kind} CPU", "% of 1 core", cpu_by_n[n][kind])
                )
        for kind in KINDS:
            if rss_by_n[n][kind]:
                results.append(
                    figure_result(FIGURE, f"N={n}: {kind} RSS", "MiB", rss_by_n[n][kind])
                )
    return results
