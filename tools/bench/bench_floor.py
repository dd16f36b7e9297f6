"""Figure 15: a factory floor: 100 single-arm cells on one machine, at rest and with 8 of them
streaming side by side.

    python -m motocell.tools.bench.run --only 15 [--quick]

Twice, each a floor of its own: every cell with its own Zenoh router (what ``motocell up``
does), and every cell joining one router for the floor (``motocell router``, as a site runs
them, docs/site.md; open, without credentials). Each floor:

1. **Start.** 100 single-arm cells (quick: 4), each a whole ``motocell up`` with its own name,
   TCP ports and runtime directory (``testing.running_cell``, ports picked free at the start),
   started ``AT_ONCE`` at a time. A cell is ready once it can be driven: every service alive,
   state flowing, its motion port answering and CHECK_MOTION_READY no longer reporting a
   missing service (``running_cell``'s rule); START_TRAJ_MODE would then succeed. Not asked
   for, since a cell that was made motion-ready stays so, and announces its heartbeats ten
   times a second (docs/benchmarks.md, figure 15). Reported: the wall time from the first
   spawn to the last cell ready, and each cell's own start. Goal: all ready within 2 minutes.
2. **At rest.** Nothing connected, nobody subscribed: 3 windows of 10 s (quick 2 s) over every
   process of every cell (and the floor's router), as figure 7 measures (``CostSampler``): CPU
   in % of one core and wake-ups, all together; then PSS, private pages and RSS of every
   process, in total and per cell. Goals: <= 50 % of one core, <= 6 GiB PSS.
3. **Streaming.** 8 of the cells are made motion-ready and driven as figure 7 drives its
   cells (``DemoCell``: a state client and a motion client each, 2 s demo moves back to back),
   the others idle beside them; 3 windows of 20 s (quick 2 s): the minute of the goal. Every
   trajectory is judged as in figure 7: aborted when a point is refused or the robot does not
   come to rest exactly at its last point. Goals: 0 aborted, every goal reached; missed
   periods are reported against the machine's floor (docs/realtime.md).

Every process of every cell is stopped and reaped at the end of each floor, also on failure or
Ctrl-C (the cells' stacks close; a start under way is waited for first), and each cell dies
with this process whatever ends it (``start_cell``'s lifeline).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack, contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motocell.testing.processes import cmdline, descendants
from motocell.testing.running_cell import RunningCell, router_on_free_port, running_cell
from motocell.tools.bench.bench_scale import (
    DemoCell,
    MovingWindow,
    Trajectory,
    aborted_text,
    ended_within,
    measure_moving,
)
from motocell.tools.bench.bench_start_cost import ProcessRead, read_process
from motocell.tools.bench.measuring import (
    START_TIMEOUT_S,
    Window,
    cost_window,
    figure_result,
    gc_paused,
    process_kinds,
    total,
    workdir,
    write_cell_file,
)

FIGURE = 15
CELLS = 100
QUICK_CELLS = 4
AT_ONCE = 2
"""Cells starting at the same time (docs/benchmarks.md, figure 15: one at a time was slower, and
more at once than the machine has cores no faster)."""
READY_GOAL_S = 120.0
REST_CPU_GOAL = 50.0
"""% of one core, every process of the floor together."""
REST_PSS_GOAL_MIB = 6 * 1024.0
REST_SETTLE_S = 5.0
"""After the last start: its burst passes and every clock comes to rest."""
REST_WINDOWS = 3
REST_WINDOW_S = 10.0
QUICK_REST_WINDOW_S = 2.0
STREAMING = 8
QUICK_STREAMING = 2
STREAM_SETTLE_S = 2.0
STREAM_WINDOWS = 3
STREAM_WINDOW_S = 20.0
QUICK_STREAM_WINDOW_S = 2.0
ROUTERS = {"own routers": False, "one shared router": True}
"""Per floor: whether its cells join one router."""
ROUTER_KIND = "shared router"


@dataclass
class Floor:
    """The cells of one floor as they run, and what their start took."""

    router: tuple[int, str] | None
    """The shared router's pid and endpoint; None: each cell runs its own."""
    cells: list[RunningCell] = field(default_factory=list)
    start_s: list[float] = field(default_factory=list)
    """Each cell's own start, spawn -> ready, in the order they became ready."""
    ready_s: float = 0.0
    """The first spawn -> the last cell ready."""

    def pids(self) -> dict[int, str]:
        """Every process of the floor, by kind."""
        found = {pid: kind for c in self.cells for pid, kind in process_kinds(c).items()}
        if self.router is not None:
            found[self.router[0]] = ROUTER_KIND
        return found


@dataclass
class Measured:
    """One floor's figures."""

    label: str
    count: int
    at_once: int
    start_s: list[float]
    ready_s: float
    rest: list[Window]
    memory: list[ProcessRead]
    moving: list[MovingWindow]
    trajectories: list[Trajectory]


def cell_name(number: int) -> str:
    return f"floor{number}"


@contextmanager
def floor_cell(
    directory: Path, number: int, router: str | None, started: list[float]
) -> Iterator[RunningCell]:
    """Cell ``number`` of the floor, ready to be driven; its start (spawn -> ready) appended
    to ``started``."""
    name = cell_name(number)
    config = write_cell_file(directory, name, models=("arm6",))
    with running_cell(
        config,
        router=router,
        log=directory / f"{name}.log",
        timeout=START_TIMEOUT_S,
        attempts=2,
    ) as cell:
        started.append((time.monotonic_ns() - cell.spawned_ns) / 1e9)
        yield cell


class CellStacks:
    """The stacks of a floor's started cells, added from the threads that start them; closed
    ``at_once`` at a time, every one of them whatever the others do."""

    def __init__(self) -> None:
        self._stacks: list[ExitStack] = []
        self._lock = threading.Lock()

    def add(self, stack: ExitStack) -> None:
        with self._lock:
            self._stacks.append(stack)

    def close(self, at_once: int) -> None:
        """The first failure raised once all are closed."""
        with self._lock:
            stacks, self._stacks = self._stacks, []
        with ThreadPoolExecutor(max_workers=at_once, thread_name_prefix="floor-stop") as pool:
            failures = [f for f in pool.map(_closed, stacks) if f is not None]
        if failures:
            raise failures[0]


def _closed(stack: ExitStack) -> BaseException | None:
    try:
        stack.close()
    except BaseException as exc:
        return exc
    return None


@contextmanager
def floor(directory: Path, count: int, at_once: int, shared: bool) -> Iterator[Floor]:
    """``count`` cells started ``at_once`` at a time; every process of every cell stopped and
    reaped on exit, however it comes (the starts under way end first, then every cell stops)."""
    with ExitStack() as stack:
        router = stack.enter_context(shared_router()) if shared else None
        found = Floor(router)
        stacks = CellStacks()
        stack.callback(stacks.close, at_once)
        endpoint = None if router is None else router[1]

        def start(number: int) -> RunningCell:
            with ExitStack() as cell_stack:
                cell = cell_stack.enter_context(
                    floor_cell(directory, number, endpoint, found.start_s)
                )
                stacks.add(cell_stack.pop_all())
            return cell

        begun = time.monotonic()
        pool = ThreadPoolExecutor(max_workers=at_once, thread_name_prefix="floor-start")
        try:
            found.cells = list(pool.map(start, range(1, count + 1)))
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        found.ready_s = time.monotonic() - begun
        yield found


@contextmanager
def shared_router() -> Iterator[tuple[int, str]]:
    """``motocell router`` on a free loopback port, open: its pid and endpoint."""
    before = descendants(os.getpid())
    with router_on_free_port() as endpoint:
        new = descendants(os.getpid()) - before
        routers = [pid for pid in new if "router" in cmdline(pid)]
        if len(routers) != 1:
            raise RuntimeError(f"the floor's router: {len(routers)} processes found")
        yield routers[0], endpoint


# -- measuring ---------------------------------------------------------------------------------
def measure_floor(found: Floor, label: str, quick: bool, directory: Path) -> Measured:
    """The floor at rest, then with ``STREAMING`` of its cells driven."""
    rest_s = QUICK_REST_WINDOW_S if quick else REST_WINDOW_S
    time.sleep(REST_SETTLE_S)
    rest = [cost_window(found.pids(), rest_s) for _ in range(REST_WINDOWS)]
    memory = [read for pid, kind in found.pids().items() if (read := read_process(pid, kind))]
    moving, trajectories = stream_beside(found, directory, quick)
    return Measured(
        label,
        len(found.cells),
        AT_ONCE,
        sorted(found.start_s),
        found.ready_s,
        rest,
        memory,
        moving,
        trajectories,
    )


def stream_beside(
    found: Floor, directory: Path, quick: bool
) -> tuple[list[MovingWindow], list[Trajectory]]:
    """The first cells of the floor driven side by side while the rest idle: windows over
    every process of the floor, and every trajectory driven."""
    count = min(QUICK_STREAMING if quick else STREAMING, len(found.cells))
    window_s = QUICK_STREAM_WINDOW_S if quick else STREAM_WINDOW_S
    seconds = STREAM_WINDOWS * window_s + 120.0
    driven: list[DemoCell] = []
    windows: list[MovingWindow] = []
    try:
        with gc_paused():
            for cell in found.cells[:count]:
                driven.append(DemoCell(directory, nullcontext(cell), seconds))
            time.sleep(STREAM_SETTLE_S)
            pids = found.pids()
            windows = [measure_moving(driven, window_s, pids) for _ in range(STREAM_WINDOWS)]
            for demo in driven:
                demo.stop()
                demo.check()
    finally:
        trajectories = [t for demo in driven for t in demo.done]
        for demo in driven:
            demo.close()
    return windows, trajectories


def run(quick: bool) -> list[dict[str, Any]]:
    count = QUICK_CELLS if quick else CELLS
    rows: list[dict[str, Any]] = []
    for label, shared in ROUTERS.items():
        with workdir() as directory, floor(directory, count, AT_ONCE, shared) as found:
            rows += floor_results(measure_floor(found, label, quick, directory))
    return rows


# -- results -----------------------------------------------------------------------------------
def per_cell(values: Sequence[float], cells: int) -> list[float]:
    return [v / max(1, cells) for v in values]


def reached(trajectories: Sequence[Trajectory]) -> int:
    """Trajectories whose every point was taken and whose robot came to rest exactly at the
    last one."""
    return sum(not t.aborted for t in trajectories)


def memory_totals(reads: Sequence[ProcessRead]) -> Mapping[str, float]:
    return {
        "PSS": sum(r.pss_mib for r in reads),
        "private": sum(r.private_mib for r in reads),
        "RSS": sum(r.rss_mib for r in reads),
    }


def floor_results(m: Measured) -> list[dict[str, Any]]:
    return [*start_rows(m), *rest_rows(m), *moving_rows(m)]


def start_rows(m: Measured) -> list[dict[str, Any]]:
    tag = f"[{m.count} cells, {m.label}]"
    return [
        figure_result(
            FIGURE,
            f"{tag} first spawn -> every cell ready",
            "s",
            [m.ready_s],
            goal=("<=", READY_GOAL_S),
            note=f"{m.at_once} started at once",
        ),
        figure_result(FIGURE, f"{tag} one cell's start, spawn -> ready", "s", m.start_s),
    ]


def rest_rows(m: Measured) -> list[dict[str, Any]]:
    tag = f"[{m.count} cells, {m.label}] at rest"
    rows = cost_rows(tag, m.rest, m.count, REST_CPU_GOAL)
    memory = memory_totals(m.memory)
    rows.append(
        figure_result(
            FIGURE,
            f"{tag}: PSS, every process",
            "MiB",
            [memory["PSS"]],
            goal=("<=", REST_PSS_GOAL_MIB),
            note=f"{len(m.memory)} processes",
        )
    )
    for name, mib in memory.items():
        rows.append(figure_result(FIGURE, f"{tag}: {name} per cell", "MiB", [mib / m.count]))
    rows.append(figure_result(FIGURE, f"{tag}: private, every process", "MiB", [memory["private"]]))
    return rows


def cost_rows(tag: str, windows: Sequence[Window], cells: int, goal: float) -> list[dict[str, Any]]:
    totals = [total("all", w.rows) for w in windows]
    cpu = [t.cpu_percent for t in totals]
    return [
        figure_result(
            FIGURE,
            f"{tag}: CPU, every process",
            "% of 1 core",
            cpu,
            goal=("<=", goal),
        ),
        figure_result(FIGURE, f"{tag}: CPU per cell", "% of 1 core", per_cell(cpu, cells)),
        figure_result(
            FIGURE, f"{tag}: wake-ups, every process", "1/s", [t.wakeups_per_s for t in totals]
        ),
    ]


def moving_rows(m: Measured) -> list[dict[str, Any]]:
    if not m.moving:
        return []
    driven = m.moving[0].cells
    tag = f"[{m.count} cells, {m.label}] {driven} streaming"
    every = m.trajectories
    in_windows = [ended_within(every, w.window) for w in m.moving]
    return [
        figure_result(
            FIGURE,
            f"{tag}: trajectories aborted, the whole figure",
            "trajectories",
            [sum(t.aborted for t in every)],
            goal=("==", 0),
            note=f"of {len(every)}; {aborted_text(every)}",
        ),
        figure_result(
            FIGURE,
            f"{tag}: goals reached, the whole figure",
            "trajectories",
            [reached(every)],
            goal=("==", len(every)),
            note="at rest exactly at the last point",
        ),
        figure_result(
            FIGURE,
            f"{tag}: trajectories ended per window",
            "trajectories",
            [len(t) for t in in_windows],
            note="2 s demo moves, 6 axes in 2016",
        ),
        figure_result(
            FIGURE,
            f"{tag}: window, as long as it took",
            "s",
            [(w.window.end_ns - w.window.start_ns) / 1e9 for w in m.moving],
            note="longer than asked when reading /proc waits for a busy machine",
        ),
        figure_result(
            FIGURE,
            f"{tag}: missed periods, the streaming cells",
            "periods",
            [w.missed for w in m.moving],
            note="this VM's floor applies (docs/realtime.md)",
        ),
        figure_result(
            FIGURE,
            f"{tag}: executor lateness p99",
            "us",
            [w.lateness_p99_us for w in m.moving],
        ),
        figure_result(
            FIGURE, f"{tag}: CPU, every process", "% of 1 core", [w.window.cpu for w in m.moving]
        ),
    ]
