"""What the benchmarks share: results and goals, the machine, CPU per process, cells, observers
and trajectories.

Cells come from the test kit's harness (``testing.running_cell``: free ports, a router of their own,
every process reaped on exit, also on Ctrl-C); ``bench_cell`` writes their cell file first:
four groups (arm6, arm6, arm7, positioner2) on a YRC1000, in a temporary directory that also
keeps the cell's log. The TCP clients that measure run in processes of their own
(``tools.bench.clients``).

Observers are Zenoh client sessions on the cell's router. Ticks wait in a Zenoh channel and are
drained (raw bytes, decoded later) when the benchmark looks at them, so no Python runs per tick;
the few keys whose arrival time matters are stamped in a callback. While a figure measures, this
process's garbage collector is off (``gc_paused``) so that no collection delays a stamp.
"""

from __future__ import annotations

import contextlib
import gc
import importlib.metadata
import math
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import zenoh

from motocell.shared.bus.schemas import Decoder, ExecutorMetrics, State, Tick
from motocell.shared.config import Cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import Command
from motocell.shared.protocol.replies import motion_ctrl
from motocell.testing.client import PlannedPoint
from motocell.testing.processes import cmdline, wait_until
from motocell.testing.running_cell import RunningCell, running_cell

SOURCE = Path(__file__).resolve().parent.parent
"""Where the bench package is: a checkout (git then names the commit measured) or an install."""
START_TIMEOUT_S = 60.0
"""Twice the tests' deadline: a benchmark may start a cell while others load the machine."""
GROUP_MODELS = ("arm6", "arm6", "arm7", "positioner2")
CHECK_MOTION_READY = motion_ctrl(Command.CHECK_MOTION_READY)
CHECK_QUEUE_CNT = motion_ctrl(Command.CHECK_QUEUE_CNT)

Result_ = dict[str, Any]


# -- results ---------------------------------------------------------------------------------
RESULTS_DIR = Path("bench-results")
"""Relative, so under the current directory: never inside an installed package."""


def compare(value: float, goal: tuple[str, float]) -> bool:
    op, target = goal
    if op == "<=":
        return value <= target
    if op == ">=":
        return value >= target
    if op == "==":
        return value == target
    raise ValueError(op)


def goal_text(goal: tuple[str, float]) -> str:
    op, target = goal
    number = f"{int(target):,}" if target == int(target) else f"{target:g}"
    return f"{op} {number}"


def figure_result(
    figure: int,
    name: str,
    unit: str,
    runs: Sequence[float],
    *,
    goal: tuple[str, float] | None = None,
    rule: str = "median",
    note: str = "",
) -> Result_:
    """One reported value: median and spread of the runs, and whether the goal is met.

    ``rule`` "median": the median meets the goal; "all": every run does (used for counts that
    must be zero, such as missed periods)."""
    values = [float(v) for v in runs]
    result: Result_ = {
        "figure": figure,
        "name": name,
        "unit": unit,
        "median": statistics.median(values) if values else float("nan"),
        "min": min(values) if values else float("nan"),
        "max": max(values) if values else float("nan"),
        "runs": values,
    }
    if goal is not None:
        result["goal"] = goal_text(goal)
        result["goal_rule"] = rule
        if not values:
            result["met"] = False
        elif rule == "all":
            result["met"] = all(compare(v, goal) for v in values)
        else:
            result["met"] = compare(result["median"], goal)
    if note:
        result["note"] = note
    return result


def percentiles(values: Sequence[float] | np.ndarray, qs: Sequence[float]) -> list[float]:
    array = np.asarray(values, dtype=np.float64)
    if array.size == 0:
        return [float("nan")] * len(qs)
    return [float(v) for v in np.percentile(array, qs)]


# -- machine -----------------------------------------------------------------------------------
def machine_info() -> dict[str, Any]:
    model = "unknown"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    mem_total = ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                mem_total = line.split(":", 1)[1].strip()
    return {
        "nproc": os.cpu_count(),
        "cpu_model": model,
        "memory": mem_total,
        "python": platform.python_version(),
        "kernel": platform.release(),
        "machine": platform.machine(),
        "numpy": np.__version__,
        "zenoh": _version("eclipse-zenoh"),
        "msgspec": _version("msgspec"),
        "loadavg_at_start": os.getloadavg(),
        "git": git_state(),
        "root": os.geteuid() == 0,
    }


def git_state() -> dict[str, Any]:
    """The commit measured and the files changed in the working tree (work in progress)."""

    def git(*args: str) -> str:
        try:
            done = subprocess.run(
                ["git", *args], cwd=SOURCE, capture_output=True, text=True, timeout=10, check=False
            )
        except (OSError, subprocess.TimeoutExpired):
            return ""
        return done.stdout.rstrip()

    if not (SOURCE / ".git").exists():
        return {"commit": "", "modified": []}
    changed = [line[3:] for line in git("status", "--porcelain").splitlines() if line[:2] != "??"]
    return {"commit": git("rev-parse", "--short", "HEAD"), "modified": changed}


def _version(package: str) -> str:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


# -- processes -------------------------------------------------------------------------------


CLK_TCK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float | None:
    """utime + stime of a process, seconds (all its threads)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[-1].split()
    except OSError:
        return None
    # After the ")" field 0 is the state (field 3 of stat(5)); utime, stime are 14 and 15.
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def rss_mib(pid: int) -> float | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        return None
    return None


PROCESS_KINDS = (
    "launcher+router",
    "zygote",
    "controller",
    "executor",
    "broadcaster",
    "gateway",
    "interpolator",
)
"""What ``process_kinds`` calls a cell's processes, in the order the figures report them."""


def process_kinds(cell: RunningCell) -> dict[int, str]:
    """Every process of the cell: the launcher (which runs the router), its warm parent (the
    zygote), and each service by its module (executor, gateway, interpolator, ...)."""
    kinds = {cell.process.pid: "launcher+router"}
    zygotes = cell.children() - cell.services()
    kinds.update(dict.fromkeys(zygotes, "zygote"))
    for pid in cell.services():
        modules = [word for word in cmdline(pid) if word.startswith("motocell.services.")]
        kinds[pid] = modules[0].removeprefix("motocell.services.") if modules else "gone"
    return kinds


# -- cost: CPU time and wake-ups of every thread --------------------------------------------
@dataclass(frozen=True)
class Usage:
    """What a thread (or a sum of threads) has used so far."""

    cpu_ns: int
    """Time on a CPU: ``/proc/<pid>/task/<tid>/schedstat``'s first field (nanoseconds, the
    scheduler's own account), or utime + stime at the clock tick's resolution where the kernel
    has no schedstat."""
    switches: int
    """Context switches, voluntary (it slept: every wake-up) and not (it was preempted)."""

    def __add__(self, other: Usage) -> Usage:
        return Usage(self.cpu_ns + other.cpu_ns, self.switches + other.switches)

    def __sub__(self, other: Usage) -> Usage:
        return Usage(self.cpu_ns - other.cpu_ns, self.switches - other.switches)


NO_USAGE = Usage(0, 0)


def parse_schedstat(text: str) -> int:
    """Nanoseconds on a CPU from a ``schedstat`` line (on-CPU ns, run-queue wait ns, slices)."""
    return int(text.split(maxsplit=1)[0])


def parse_switches(status: str) -> int:
    """Voluntary + nonvoluntary context switches from a ``/proc/.../status`` text."""
    total = 0
    for line in status.splitlines():
        if line.startswith(("voluntary_ctxt_switches:", "nonvoluntary_ctxt_switches:")):
            total += int(line.split()[1])
    return total


def _thread_usage(task: Path) -> Usage:
    try:
        cpu_ns = parse_schedstat((task / "schedstat").read_text())
    except FileNotFoundError:
        fields = (task / "stat").read_text().rsplit(")", 1)[-1].split()
        cpu_ns = (int(fields[11]) + int(fields[12])) * 1_000_000_000 // CLK_TCK
    return Usage(cpu_ns, parse_switches((task / "status").read_text()))


def thread_usage(pid: int) -> dict[int, Usage]:
    """Every live thread of ``pid`` now (empty once the process is gone)."""
    found = {}
    try:
        tasks = list(Path(f"/proc/{pid}/task").iterdir())
    except OSError:
        return {}
    for task in tasks:
        with contextlib.suppress(OSError, ValueError, IndexError):
            found[int(task.name)] = _thread_usage(task)
    return found


def usage_between(before: Mapping[int, Usage], after: Mapping[int, Usage]) -> Usage:
    """What a process's threads used between two looks: each thread alive at the second look,
    less what it had at the first (0 for a thread started since). A thread that ended in
    between is not counted: a cell's services keep their threads for their whole life."""
    total = NO_USAGE
    for tid, usage in after.items():
        total += usage - before.get(tid, NO_USAGE)
    return total


def memory_rollup_mib(pid: int) -> dict[str, float] | None:
    """Every size ``/proc/<pid>/smaps_rollup`` gives (``Rss``, ``Pss``, ``Private_Dirty``...),
    in MiB; None once the process is gone."""
    try:
        text = Path(f"/proc/{pid}/smaps_rollup").read_text()
    except OSError:
        return None
    sizes = {}
    for line in text.splitlines():
        words = line.split()
        if len(words) == 3 and words[2] == "kB":
            sizes[words[0].rstrip(":")] = int(words[1]) / 1024
    return sizes


def pss_mib(pid: int) -> float | None:
    """Proportional set size: the process's own pages plus its share of pages it shares (the
    interpreter, numpy, Zenoh), so the sum over many processes is the memory they take."""
    sizes = memory_rollup_mib(pid)
    return None if sizes is None else sizes.get("Pss")


@dataclass(frozen=True)
class ProcessCost:
    """One process over one window."""

    kind: str
    pid: int
    cpu_percent: float
    """Of one core."""
    wakeups_per_s: float
    """Context switches per second, all its threads."""
    rss_mib: float
    pss_mib: float


def process_cost(
    kind: str, pid: int, used: Usage, seconds: float, *, rss: float, pss: float
) -> ProcessCost:
    return ProcessCost(
        kind, pid, 100.0 * used.cpu_ns / 1e9 / seconds, used.switches / seconds, rss, pss
    )


class CostSampler:
    """CPU time (nanoseconds, every thread), wake-ups and memory per process over a window.
    Reading /proc is this process's work, not theirs."""

    def __init__(self, pids: Mapping[int, str]) -> None:
        self.pids = dict(pids)
        self.start = {pid: thread_usage(pid) for pid in self.pids}
        self.start_ns = time.monotonic_ns()

    def finish(self) -> list[ProcessCost]:
        """Every process alive at both looks."""
        after = {pid: thread_usage(pid) for pid in self.pids}
        seconds = (time.monotonic_ns() - self.start_ns) / 1e9
        rows = []
        for pid, kind in self.pids.items():
            rss, pss = rss_mib(pid), pss_mib(pid)
            if not self.start[pid] or not after[pid] or rss is None or seconds <= 0:
                continue
            used = usage_between(self.start[pid], after[pid])
            rows.append(process_cost(kind, pid, used, seconds, rss=rss, pss=pss or 0.0))
        return rows


@dataclass(frozen=True)
class Window:
    """One measuring window: the cost of every process measured (``cost_window``)."""

    rows: list[ProcessCost]
    start_ns: int
    end_ns: int

    @property
    def cpu(self) -> float:
        """% of one core, every process together."""
        return total("all", self.rows).cpu_percent


def cost_window(pids: Mapping[int, str], seconds: float) -> Window:
    """What ``pids`` (pid: kind) cost over the next ``seconds``."""
    sampler = CostSampler(pids)
    time.sleep(seconds)
    rows = sampler.finish()
    return Window(rows, sampler.start_ns, time.monotonic_ns())


def cost_by_kind(rows: Sequence[ProcessCost]) -> dict[str, ProcessCost]:
    """The processes of each kind added up (the interpolators of a cell, or every cell's
    executor), in the order the kinds first appear; ``pid`` is the number of processes."""
    kinds: dict[str, list[ProcessCost]] = {}
    for row in rows:
        kinds.setdefault(row.kind, []).append(row)
    return {kind: total(kind, found) for kind, found in kinds.items()}


def total(kind: str, rows: Sequence[ProcessCost]) -> ProcessCost:
    """``rows`` added up as one (``pid``: how many)."""
    return ProcessCost(
        kind,
        len(rows),
        sum(r.cpu_percent for r in rows),
        sum(r.wakeups_per_s for r in rows),
        sum(r.rss_mib for r in rows),
        sum(r.pss_mib for r in rows),
    )


# -- cells -----------------------------------------------------------------------------------
Extensions = tuple[tuple[str, int], ...]
"""Cell-file settings beyond MotoROS's behaviour, as (key, value) pairs."""


def write_cell_file(
    directory: Path,
    name: str,
    state_period_ms: float = 10.0,
    models: Sequence[str] = GROUP_MODELS,
    extensions: Extensions = (),
    *,
    tables: str = "",
) -> Path:
    """``extensions``: motocell's opt-in cell-file settings (``pending_points``,
    ``start_buffer_periods``), written only when a figure asks for them; ``tables``: TOML
    tables written after the groups (figure 12's ``[ros2]``)."""
    lines = [
        f'name = "{name}"',
        'controller = "YRC1000"',
        "interpolation_period_ms = 4",
        f"state_period_ms = {state_period_ms:g}",
    ]
    lines += [f"{key} = {value}" for key, value in extensions]
    lines.append("")
    names = {"arm6": "R", "arm7": "R", "positioner2": "S", "track1": "B"}
    for index, model in enumerate(models):
        lines += ["[[groups]]", f'name = "{names.get(model, "G")}{index + 1}"']
        lines += [f'model = "{model}"', ""]
    if tables:
        lines.append(tables)
    path = directory / f"{name}.toml"
    path.write_text("\n".join(lines))
    return path


def wait_for_every_slot(cell: RunningCell, timeout: float = START_TIMEOUT_S) -> None:
    """The gateway accepts a group's points only once it has heard that group's interpolator
    (its slot, published on change and every 0.1 s); wait until we have heard every one too."""
    session = cell.session()
    try:
        heard: set[str] = set()
        subscriber = session.declare_subscriber(
            cell.keys.group_slot_all, lambda sample: heard.add(str(sample.key_expr))
        )
        groups = len(cell.cell.groups)
        wait_until(lambda: len(heard) >= groups, timeout, "every interpolator's slot")
        subscriber.undeclare()
    finally:
        session.close()
    time.sleep(0.05)


@contextmanager
def gc_paused() -> Iterator[None]:
    """This process's collector off while a figure measures (after one collection), as in the
    measuring child processes; on again afterwards."""
    gc.collect()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        gc.unfreeze()
        gc.enable()


class LogTail:
    """What a cell's log (``bench_cell``'s ``<name>.log``) says from a point on: why a stream
    was refused, say (the services log every alarm they raise)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.offset = 0
        self.skip()

    def skip(self) -> None:
        """From now on."""
        with contextlib.suppress(OSError):
            self.offset = self.path.stat().st_size

    def lines(self, containing: str = "") -> list[str]:
        """The lines written since the last look that contain ``containing``, without their
        timestamps."""
        try:
            with self.path.open("rb") as log:
                log.seek(self.offset)
                text = log.read().decode(errors="replace")
                self.offset = log.tell()
        except OSError:
            return []
        return [without_timestamp(line) for line in text.splitlines() if containing in line]


def without_timestamp(line: str) -> str:
    """``2026-11-26 04:13:15,926 executor/0[1635] ERROR ...`` -> ``executor/0[1635] ERROR ...``."""
    parts = line.split(" ", 2)
    if len(parts) == 3 and parts[0][:1].isdigit() and parts[1][:1].isdigit():
        return parts[2]
    return line


ALARM = re.compile(r"alarm (\d+)")


def alarm_codes(lines: Sequence[str]) -> list[int]:
    """The alarm numbers the lines name (``... (alarm 4200)``), in order."""
    return [int(code) for line in lines for code in ALARM.findall(line)]


def refusal_text(error: object, logged: Sequence[str], most: int = 3) -> str:
    """A refusal, and the last ``most`` alarm lines its cell logged meanwhile."""
    if not logged:
        return str(error)
    return f"{error}; the cell's log: {' | '.join(logged[-most:])}"


@contextmanager
def workdir() -> Iterator[Path]:
    """A temporary directory for a figure's cells and clients; kept, and named, when the figure
    fails, so its cells' logs say why."""
    path = Path(tempfile.mkdtemp(prefix="motocell-bench-"))
    try:
        yield path
    except BaseException:
        print(f"  the failed figure's cell logs are kept in {path}", file=sys.stderr)
        raise
    shutil.rmtree(path, ignore_errors=True)


@contextmanager
def bench_cell(
    directory: Path,
    name: str = "bench",
    state_period_ms: float = 10.0,
    extensions: Extensions = (),
    tables: str = "",
) -> Iterator[RunningCell]:
    """A whole 4-group cell (``write_cell_file``), its output in ``directory/<name>.log``;
    stopped (every process reaped) on exit. A failed start is tried once more."""
    config = write_cell_file(directory, name, state_period_ms, extensions=extensions, tables=tables)
    log = directory / f"{name}.log"
    with running_cell(config, log=log, timeout=START_TIMEOUT_S, attempts=2) as cell:
        wait_for_every_slot(cell)
        yield cell


# -- observing -------------------------------------------------------------------------------
TICK_CHANNEL_DEPTH = 1 << 16
"""Ticks the Zenoh channel holds between two looks: 262 s at 250 Hz, four times the longest
window a figure sleeps through (a full channel would stall this session's network thread)."""


class ExecutorModes:
    """Whether the executors a figure observed ran SCHED_FIFO (``ExecutorMetrics.realtime``,
    1 Hz on the cell's ``executor/metrics`` key). Every ``Observer`` notes what it saw when it
    closes; ``tools.bench.run`` clears this before each figure and reads it after."""

    def __init__(self) -> None:
        self.seen: set[bool] = set()

    def clear(self) -> None:
        self.seen.clear()

    def note(self, realtime: bool) -> None:
        self.seen.add(realtime)

    def realtime(self) -> bool | None:
        """True: every executor observed ran SCHED_FIFO; False: one did not; None: none seen."""
        return all(self.seen) if self.seen else None


EXECUTOR_MODES = ExecutorModes()


class Observer:
    """A Zenoh client session on a cell's router that records raw samples of some keys, and
    always the executor's metrics (``EXECUTOR_MODES``)."""

    def __init__(self, cell: RunningCell) -> None:
        self.session = cell.session()
        self.keys = cell.keys
        self.ticks: list[bytes] = []
        self.states: list[tuple[int, bytes]] = []
        self._entities: list[Any] = []
        self._tick_channel: Any = None
        self._drain_lock = threading.Lock()
        """Several threads may look at the ticks (figure 7: each cell's driver and the windows)."""
        self._tick_decoder = Decoder(Tick)
        self.metrics = self.record(self.keys.metrics("executor"))

    def record_ticks(self) -> None:
        """Every ``executor/tick`` from now on, into ``ticks`` whenever they are looked at."""
        self._tick_channel = self.session.declare_subscriber(
            self.keys.executor_tick, zenoh.handlers.FifoChannel(TICK_CHANNEL_DEPTH)
        )
        self._entities.append(self._tick_channel)

    def _drain_ticks(self) -> None:
        channel = self._tick_channel
        if channel is None:
            return
        store = self.ticks.append
        with self._drain_lock:  # one drain at a time: ticks stay in their order
            while (sample := channel.try_recv()) is not None:
                store(sample.payload.to_bytes())

    def record_states(self) -> None:
        self.states = self.record(self.keys.state)

    def record(self, key: str) -> list[tuple[int, bytes]]:
        """Every sample of ``key`` from now on, with the time this observer got it."""
        samples: list[tuple[int, bytes]] = []
        store = samples.append

        def on_sample(sample: zenoh.Sample) -> None:
            store((time.monotonic_ns(), sample.payload.to_bytes()))

        self._entities.append(self.session.declare_subscriber(key, on_sample))
        return samples

    def states_between(self, start_ns: int, end_ns: int) -> list[tuple[int, State]]:
        decoder = Decoder(State)
        return [(at, decoder.decode(raw)) for at, raw in self.states if start_ns <= at <= end_ns]

    def mark(self) -> int:
        self._drain_ticks()
        return len(self.ticks)

    def ticks_since(self, start: int, end: int | None = None) -> list[Tick]:
        self._drain_ticks()
        decode = self._tick_decoder.decode
        return [decode(raw) for raw in self.ticks[start:end]]

    def latest_tick(self, timeout: float = 5.0) -> Tick:
        wait_until(lambda: self.mark() > 0, timeout, "an executor tick")
        return self._tick_decoder.decode(self.ticks[-1])

    def executor_metrics(self) -> list[tuple[int, ExecutorMetrics]]:
        decoder = Decoder(ExecutorMetrics)
        return [(at, decoder.decode(raw)) for at, raw in self.metrics]

    def wait_still(self, timeout: float = 10.0) -> Tick:
        """The first tick, from now on, at which no group has anything queued or moves, the
        servos included (their feedback at rest on the command)."""
        start = self.mark()
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            end = self.mark()
            for tick in self.ticks_since(start, end):
                if all(
                    g.depth == 0 and not any(g.increment) and not any(g.feedback_moved)
                    for g in tick.groups
                ):
                    return tick
            start = end
            time.sleep(0.02)
        raise TimeoutError(f"the robot did not stop within {timeout} s")

    def close(self) -> None:
        for entity in self._entities:
            with contextlib.suppress(Exception):
                entity.undeclare()
        self.session.close()
        for _, metrics in self.executor_metrics():
            EXECUTOR_MODES.note(metrics.realtime)

    def __enter__(self) -> Observer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def wait_moving(observer: Observer, mark: int, timeout: float = 10.0) -> None:
    """Until a tick after ``mark`` moves some axis."""

    def moved() -> bool:
        return any(any(g.increment) for t in observer.ticks_since(mark) for g in t.groups)

    wait_until(moved, timeout, "the robot to move")


def wake_ns(tick: Tick) -> int:
    """When the executor woke for this tick (CLOCK_MONOTONIC), as ``State.tick_ns``."""
    return tick.deadline_ns + tick.lateness_ns


def positions_of(cell: Cell, tick: Tick) -> dict[int, tuple[float, ...]]:
    """Each group's commanded position in ROS order and units, exactly from the tick's pulses."""
    result = {}
    for group, group_tick in zip(cell.groups, tick.groups, strict=True):
        axis_map = AxisMap(group)
        result[group.index] = tuple(axis_map.pulses_to_ros(group_tick.command_pulses).tolist())
    return result


# -- trajectories ----------------------------------------------------------------
def ramp(
    start: Sequence[float], speed: float, duration: float, interval: float
) -> list[PlannedPoint]:
    """Constant velocity on every axis from the first point on (every tick moves every axis),
    points ``interval`` apart; the last point keeps the velocity (the robot stops there)."""
    count = round(duration / interval) + 1
    points = []
    for i in range(count):
        t = i * interval
        points.append(
            PlannedPoint(t, tuple(p + speed * t for p in start), tuple(speed for _ in start))
        )
    return points


def ramps(
    starts: Mapping[int, Sequence[float]], speed: float, duration: float, interval: float
) -> dict[int, list[PlannedPoint]]:
    return {g: ramp(p, speed, duration, interval) for g, p in starts.items()}


def oscillations(
    starts: Mapping[int, Sequence[float]],
    amplitude: float,
    period: float,
    duration: float,
    interval: float,
) -> dict[int, list[PlannedPoint]]:
    """Every axis of every group swinging ``amplitude`` either side of its start (a sine of
    ``period`` seconds), points ``interval`` apart: motion for as long as wanted that never
    leaves the neighbourhood of the start (joint ranges)."""
    omega = 2 * math.pi / period
    plans = {}
    for g, start in starts.items():
        points = []
        for i in range(round(duration / interval) + 1):
            t = i * interval
            offset, speed = amplitude * math.sin(omega * t), amplitude * omega * math.cos(omega * t)
            points.append(
                PlannedPoint(t, tuple(p + offset for p in start), tuple(speed for _ in start))
            )
        plans[g] = points
    return plans
