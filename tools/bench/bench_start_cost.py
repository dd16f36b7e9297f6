"""Figure 13: what one cell costs to start and to hold, read from outside in /proc.

    python -m motocell.tools.bench.run --only 13 [--quick]

For a single-arm and a four-group cell, each run spawns ``motocell up`` (through the test
harness, ``testing.running_cell.start_cell``) and waits until it is motion-ready: every service
alive and START_TRAJ_MODE answered SUCCESS. Two ways, alternating: as ``motocell up`` starts
by default, every service a fork of the launcher's warm parent (docs/startup.md), and with
``--cold``, every service a fresh interpreter, as every start was before the warm parent.
Once motion-ready it reads, for every process of the cell (the launcher with its router, the
zygote, every service):

- CPU: utime + stime, plus what the process's reaped children used (cutime + cstime), summed
  over the cell; also by kind of process;
- memory: PSS (its own pages and its share of the shared ones), private pages (those one
  process alone maps) and RSS, summed; and the cell's own memory (``own_memory``: every
  anonymous page that the cell's processes map and no other process does, counted once),
  which is what a further cell costs: the private pages miss the warm parent's, which its
  forks share until they write to them, and PSS counts a share of every library.

Wall time is spawn -> motion-ready. Beside each cold run, one service's start is taken apart in
a fresh interpreter of its own (``start_phases``): the interpreter, its imports, the cell
file, ``zenoh.open``.

Goals (issue 33): single-arm ready in <= 0.5 s wall and <= 0.4 s CPU, four-group <= 0.8 s /
<= 0.7 s; each further single-arm cell <= 48 MiB, four-group <= 80 MiB, for the default start.
Runs of 3 each.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motocell.testing.running_cell import RunningCell, start_cell
from motocell.tools.bench.bench_startup import milestones
from motocell.tools.bench.measuring import (
    CLK_TCK,
    GROUP_MODELS,
    figure_result,
    memory_rollup_mib,
    process_kinds,
    workdir,
    write_cell_file,
)
from motocell.tools.bench.own_memory import OwnMemory, own_memory

FIGURE = 13
RUNS = 3
TIMEOUT_S = 60.0
CELLS = {
    "single-arm": (("arm6",), 0.5, 0.4, 48.0),
    "four-group": (GROUP_MODELS, 0.8, 0.7, 80.0),
}
"""Per cell: its groups' models, then the goals: wall s, CPU s, MiB for a further cell."""
PHASES_SERVICE = "interpolator"


@dataclass(frozen=True)
class ProcessRead:
    kind: str
    cpu_s: float
    """utime + stime + cutime + cstime."""
    pss_mib: float
    private_mib: float
    rss_mib: float


def read_process(pid: int, kind: str) -> ProcessRead | None:
    """None once it is gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()
    except OSError:
        return None
    memory = memory_rollup_mib(pid)
    if memory is None:
        return None
    # After the ")" field 0 is stat(5)'s field 3; utime, stime, cutime, cstime are 14-17.
    ticks = sum(int(value) for value in stat[11:15])
    private = memory.get("Private_Clean", 0.0) + memory.get("Private_Dirty", 0.0)
    return ProcessRead(
        kind, ticks / CLK_TCK, memory.get("Pss", 0.0), private, memory.get("Rss", 0.0)
    )


def read_cell(cell: RunningCell) -> list[ProcessRead]:
    reads = [read_process(pid, kind) for pid, kind in process_kinds(cell).items()]
    return [read for read in reads if read is not None]


def once(
    config: Path, log: Path, *, cold: bool
) -> tuple[dict[str, float], list[ProcessRead], OwnMemory | None, dict[str, float]]:
    """The way to motion-ready (figure 9's milestones, ms), every process read then, the
    cell's own memory (None without root), and one service's phases."""
    cell = start_cell(config, log=log, cold=cold)
    try:
        times = milestones(cell)
        reads = read_cell(cell)
        own = own_memory(list(process_kinds(cell)))
        phases = start_phases(cell) if cold else {}
    finally:
        cell.stop()
    return times, reads, own, phases


def start_phases(cell: RunningCell) -> dict[str, float]:
    """CPU seconds of each phase of a service's start, in a fresh interpreter
    (``motocell.tools.bench.start_phases``), joining the running cell's router."""
    command = [
        sys.executable,
        "-m",
        "motocell.tools.bench.start_phases",
        PHASES_SERVICE,
        cell.zenoh_endpoint,
        str(cell.config),
        str(cell.credentials or ""),
    ]
    done = subprocess.run(command, capture_output=True, check=True, timeout=TIMEOUT_S)
    phases: dict[str, float] = json.loads(done.stdout)
    return phases


def by_kind(reads: Iterable[ProcessRead]) -> dict[str, float]:
    cpu: dict[str, float] = {}
    for read in reads:
        cpu[read.kind] = cpu.get(read.kind, 0.0) + read.cpu_s
    return cpu


@dataclass
class Runs:
    """One way of starting one cell, over the runs."""

    walls: list[float] = field(default_factory=list)
    first_status: list[float] = field(default_factory=list)
    all_alive: list[float] = field(default_factory=list)
    start_traj_mode: list[float] = field(default_factory=list)
    cpus: list[float] = field(default_factory=list)
    pss: list[float] = field(default_factory=list)
    private: list[float] = field(default_factory=list)
    rss: list[float] = field(default_factory=list)
    kinds: dict[str, list[float]] = field(default_factory=dict)
    phases: dict[str, list[float]] = field(default_factory=dict)
    processes: int = 0

    own: list[float] = field(default_factory=list)

    def add(
        self,
        times: dict[str, float],
        reads: list[ProcessRead],
        own: OwnMemory | None,
        phases: dict[str, float],
    ) -> None:
        self.walls.append(times["motion_ready"])
        self.first_status.append(times["first_status"])
        self.all_alive.append(times["all_alive"])
        self.start_traj_mode.append(times["start_traj_mode"])
        self.cpus.append(sum(r.cpu_s for r in reads) * 1000)
        self.pss.append(sum(r.pss_mib for r in reads))
        self.private.append(sum(r.private_mib for r in reads))
        self.rss.append(sum(r.rss_mib for r in reads))
        if own is not None:
            self.own.append(own.total_mib)
        for kind, cpu in by_kind(reads).items():
            self.kinds.setdefault(kind, []).append(cpu * 1000)
        for name, seconds in phases.items():
            self.phases.setdefault(name, []).append(seconds * 1000)
        self.processes = len(reads)


def rows_of(label: str, runs: Runs, goals: tuple[float, ...] | None) -> list[dict[str, Any]]:
    """``goals`` (wall s, CPU s, MiB for a further cell): None for the cold start, which is
    measured to compare with."""
    wall_goal, cpu_goal, further_goal = goals or (None, None, None)

    def row(name: str, unit: str, values: list[float], goal: float | None) -> dict[str, Any]:
        aimed = None if goal is None else ("<=", goal)
        return figure_result(FIGURE, f"{label}: {name}", unit, values, goal=aimed)

    rows = [
        row("spawn -> motion-ready", "ms", runs.walls, wall_goal and wall_goal * 1000),
        row("CPU of every process to motion-ready", "ms", runs.cpus, cpu_goal and cpu_goal * 1000),
    ]
    rows[0]["note"] = f"{runs.processes} processes"
    rows += [
        row("spawn -> first ROBOT_STATUS", "ms", runs.first_status, None),
        row("spawn -> every service alive (no 5012)", "ms", runs.all_alive, None),
        row(
            "START_TRAJ_MODE's reply (servo on and INIT_ROS timer: 100 ms)",
            "ms",
            runs.start_traj_mode,
            None,
        ),
    ]
    rows += [
        row(f"CPU, {kind} (all of them)", "ms", values, None)
        for kind, values in sorted(runs.kinds.items())
    ]
    rows += [
        row("PSS once ready", "MiB", runs.pss, None),
        row("private once ready (pages one process alone maps)", "MiB", runs.private, None),
        row("RSS once ready", "MiB", runs.rss, None),
    ]
    if runs.own:  # read only as root (own_memory)
        rows.append(row("own memory once ready (a further cell)", "MiB", runs.own, further_goal))
    rows += [
        row(f"{PHASES_SERVICE} alone, CPU of {name}", "ms", values, None)
        for name, values in runs.phases.items()
    ]
    return rows


def cell_rows(
    label: str, models: tuple[str, ...], goals: tuple[float, ...], directory: Path
) -> list[dict[str, Any]]:
    """Cold and warm starts alternating, so that a change in the machine's load falls on both;
    one service's start taken apart beside the cold ones, whose start it is."""
    config = write_cell_file(directory, f"bench13{label.replace('-', '')}", models=models)
    cold, warm = Runs(), Runs()
    for index in range(RUNS):
        cold.add(*once(config, directory / f"{label}-cold{index}.log", cold=True))
        warm.add(*once(config, directory / f"{label}-warm{index}.log", cold=False))
    return [*rows_of(f"{label}, cold (--cold)", cold, None), *rows_of(label, warm, goals)]


def run(quick: bool) -> list[dict[str, Any]]:
    del quick  # three runs are already the fewest a figure has
    rows: list[dict[str, Any]] = []
    with workdir() as directory:
        for label, (models, *goals) in CELLS.items():
            rows += cell_rows(label, models, tuple(goals), directory)
    return rows
