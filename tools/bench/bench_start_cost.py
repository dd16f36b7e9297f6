"""Figure 13: what one cell costs to start and to hold, read from outside in /proc.

    python -m motocell.tools.bench.run --only 13 [--quick]

For a single-arm and a four-group cell, each run spawns ``motocell up`` (through the test
harness, ``testing.running_cell.start_cell``) and waits until it is motion-ready: every service
alive and START_TRAJ_MODE answered SUCCESS. At that instant it reads, for every process of the
cell (the launcher with its router, every service, and whatever else the launcher started):

- CPU: utime + stime, plus what the process's reaped children used (cutime + cstime), summed
  over the cell; also by kind of process;
- memory: PSS (its own pages and its share of the shared ones), its private pages (what a
  further cell beside it costs: the shared ones are there already) and RSS, summed.

Wall time is spawn -> motion-ready. Then one service's start is taken apart in a process of its
own (``start_phases``): the interpreter, its imports, the cell file, ``zenoh.open``.

Goals (issue 33): single-arm ready in <= 0.5 s wall and <= 0.4 s CPU, four-group <= 0.8 s /
<= 0.7 s; each further single-arm cell <= 48 MiB, four-group <= 80 MiB. Runs of 3.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motocell.shared.protocol.constants import Command, Result
from motocell.testing.processes import cmdline, descendants
from motocell.testing.running_cell import RunningCell, start_cell, wait_for_whole_cell
from motocell.tools.bench.measuring import (
    CLK_TCK,
    GROUP_MODELS,
    figure_result,
    workdir,
    write_cell_file,
)

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


def kind_of(pid: int, launcher: int) -> str:
    if pid == launcher:
        return "launcher+router"
    for word in cmdline(pid):
        if word.startswith("motocell.services."):
            return word.removeprefix("motocell.services.")
    return "other"


def read_process(pid: int, kind: str) -> ProcessRead | None:
    """None once it is gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()
        rollup = Path(f"/proc/{pid}/smaps_rollup").read_text()
    except OSError:
        return None
    # After the ")" field 0 is stat(5)'s field 3; utime, stime, cutime, cstime are 14-17.
    ticks = sum(int(value) for value in stat[11:15])
    memory = {}
    for line in rollup.splitlines():
        words = line.split()
        if len(words) == 3 and words[2] == "kB":
            memory[words[0].rstrip(":")] = int(words[1]) / 1024
    private = memory.get("Private_Clean", 0.0) + memory.get("Private_Dirty", 0.0)
    return ProcessRead(
        kind, ticks / CLK_TCK, memory.get("Pss", 0.0), private, memory.get("Rss", 0.0)
    )


def read_cell(cell: RunningCell) -> list[ProcessRead]:
    launcher = cell.process.pid
    reads = []
    for pid in (launcher, *sorted(descendants(launcher))):
        read = read_process(pid, kind_of(pid, launcher))
        if read is not None:
            reads.append(read)
    return reads


def motion_ready(cell: RunningCell) -> None:
    wait_for_whole_cell(cell.host, cell.port_base, cell.byte_order, TIMEOUT_S)
    with cell.motion() as motion:
        reply = motion.command(Command.START_TRAJ_MODE)
    if reply.result != Result.SUCCESS:
        raise RuntimeError(f"START_TRAJ_MODE refused: {reply}")


def once(config: Path, log: Path) -> tuple[float, list[ProcessRead], dict[str, float]]:
    """Wall seconds to motion-ready, every process read then, and one service's phases."""
    cell = start_cell(config, log=log)
    try:
        motion_ready(cell)
        wall = (time.monotonic_ns() - cell.spawned_ns) / 1e9
        reads = read_cell(cell)
        phases = start_phases(cell)
    finally:
        cell.stop()
    return wall, reads, phases


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


def cell_rows(
    label: str, models: tuple[str, ...], goals: tuple[float, ...], directory: Path
) -> list[dict[str, Any]]:
    wall_goal, cpu_goal, further_goal = goals
    config = write_cell_file(directory, f"bench13{label.replace('-', '')}", models=models)
    walls, cpus, pss, private, rss = [], [], [], [], []
    kinds: dict[str, list[float]] = {}
    phases: dict[str, list[float]] = {}
    for index in range(RUNS):
        wall, reads, phase = once(config, directory / f"{label}{index}.log")
        walls.append(wall * 1000)
        cpus.append(sum(r.cpu_s for r in reads) * 1000)
        pss.append(sum(r.pss_mib for r in reads))
        private.append(sum(r.private_mib for r in reads))
        rss.append(sum(r.rss_mib for r in reads))
        for kind, cpu in by_kind(reads).items():
            kinds.setdefault(kind, []).append(cpu * 1000)
        for name, seconds in phase.items():
            phases.setdefault(name, []).append(seconds * 1000)
    processes = f"{label}, {len(reads)} processes"
    rows = [
        figure_result(
            FIGURE,
            f"{label}: spawn -> motion-ready",
            "ms",
            walls,
            goal=("<=", wall_goal * 1000),
            note=processes,
        ),
        figure_result(
            FIGURE,
            f"{label}: CPU of every process to motion-ready",
            "ms",
            cpus,
            goal=("<=", cpu_goal * 1000),
        ),
    ]
    rows += [
        figure_result(FIGURE, f"{label}: CPU, {kind} (all of them)", "ms", values)
        for kind, values in sorted(kinds.items())
    ]
    rows += [
        figure_result(FIGURE, f"{label}: PSS once ready", "MiB", pss),
        figure_result(
            FIGURE,
            f"{label}: private once ready (a further cell)",
            "MiB",
            private,
            goal=("<=", further_goal),
        ),
        figure_result(FIGURE, f"{label}: RSS once ready", "MiB", rss),
    ]
    rows += [
        figure_result(FIGURE, f"{label}: {PHASES_SERVICE} alone, CPU of {name}", "ms", values)
        for name, values in phases.items()
    ]
    return rows


def run(quick: bool) -> list[dict[str, Any]]:
    del quick  # three runs are already the fewest a figure has
    rows: list[dict[str, Any]] = []
    with workdir() as directory:
        for label, (models, *goals) in CELLS.items():
            rows += cell_rows(label, models, tuple(goals), directory)
    return rows
