"""Figure 7: cells per machine: idle single-arm cells within half the CPU, and four four-group
cells streaming side by side.

    python -m motocell.tools.bench.run --only 7 [--quick]

Every cell is a whole ``motocell up`` with its own router (``testing.running_cell``); CPU
and wake-ups are every thread's, from /proc, as in figure 10 (``measuring.CostSampler``), in % of
one core for all the cells' processes together.

**Idle cells.** Single-arm cells (the default cell: one arm6 on a YRC1000) are started one by
one, nothing connected and nobody subscribed. At each step (1, 2, 4, 8, 12, 16, 20, 24 cells;
quick: 1 to 4) a window (5 s; quick 2 s) measures them all, after the last start has settled.
Cells are added until the cap or until a step needs more than half the machine's CPU; the
largest count within it is then measured for 3 windows of 10 s (quick 2 s), and reported with
its memory (RSS, and PSS: each process's share of the pages it shares, which adds up) and how
long the last cell took to start beside the others. Goal: >= 20 cells within 50 % of the
machine (2 cells on 2 cores would be a whole core).

**Moving cells.** Four-group cells (``bench_cell``) are started one by one (quick: 2), each with
a state client at the default 10 ms and a motion client in processes of their own. Each cell
is driven as ``motocell demo`` drives one, back to back: rest-to-rest moves of 2 s with 20
points (the demo's defaults), all 4 groups in each MOTO_JOINT_TRAJ_PT_FULL_EX (2016), streamed
like motoman_driver (a BUSY point resent after 5 ms), every axis 0.2 rad away from where the
cell started and back in turn; each move starts where the robot stands. After each cell is
added and driven, a probe window (10 s; quick 1 s) measures CPU and missed periods; with all of
them driven, 3 windows of 20 s (quick 2 s): the 60 s of the goal.

A trajectory is aborted when a point is refused (any reply but SUCCESS and BUSY: NOT_READY,
INVALID, ...) or when, come to rest, the robot is not exactly at its last point: the
commanded and the feedback pulses of every axis equal to the last point's positions as the
wire carried them (float32) in pulses. Goal: 0 aborted, over every trajectory of the figure.

Missed periods are the increase of ``Tick.missed`` over a window, all cells. They are reported
against the machine's floor: this VM's timer delivery misses periods even for a bare C
real-time thread (docs/realtime.md), so 0 in every window is not expected here. The figure
also reports the largest count whose every window had 0 missed periods and CPU within 70 % of
the machine (docs/benchmarks.md, figure 7).
"""

from __future__ import annotations

import contextlib
import itertools
import os
import threading
import time
from collections.abc import Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from motocell.shared.bus.schemas import Tick
from motocell.shared.config import Cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import Result
from motocell.testing.client import ex_messages, smooth_move
from motocell.testing.running_cell import RunningCell, running_cell
from motocell.tools.bench.clients import StateClientProcess, StreamClientProcess, stream_bound_s
from motocell.tools.bench.measuring import (
    PROCESS_KINDS,
    START_TIMEOUT_S,
    LogTail,
    Observer,
    Window,
    alarm_codes,
    bench_cell,
    cost_by_kind,
    cost_window,
    figure_result,
    gc_paused,
    percentiles,
    positions_of,
    process_kinds,
    total,
    workdir,
    write_cell_file,
)

FIGURE = 7

# -- idle cells --------------------------------------------------------------------------------
IDLE_SHARE = 0.5
"""Of the machine's CPU, for all the idle cells' processes together."""
IDLE_COUNT_GOAL = 20
IDLE_STEPS = (1, 2, 4, 8, 12, 16, 20, 24)
QUICK_IDLE_STEPS = (1, 2, 3, 4)
STEP_S = 5.0
QUICK_STEP_S = 2.0
IDLE_WINDOWS = 3
IDLE_WINDOW_S = 10.0
QUICK_IDLE_WINDOW_S = 2.0
IDLE_SETTLE_S = 3.0
"""After the step's last start: its start-up burst passes and its clock comes to rest."""
QUICK_IDLE_SETTLE_S = 2.0

# -- moving cells ------------------------------------------------------------------------------
MOVING_CELLS = 4
QUICK_MOVING_CELLS = 2
MOVING_SHARE = 0.7
"""Figure 7's former limit, of the machine's CPU."""
MOVING_COUNT_GOAL = 2
MOVE_RAD = 0.2
MOVE_S = 2.0
MOVE_POINTS = 20
"""``motocell demo``'s defaults."""
PROBE_S = 10.0
QUICK_PROBE_S = 1.0
WINDOWS = 3
WINDOW_S = 20.0
QUICK_WINDOW_S = 2.0
SETTLE_S = 1.0
"""After a cell is added and driven: its start-up burst passes."""
STILL_TIMEOUT_S = 20.0
ARRIVE_S = 5.0
"""After the last point was taken: how long the robot may take to come to rest at it."""


def share_limit(share: float, cpus: int) -> float:
    """``share`` of the machine, in % of one core."""
    return share * cpus * 100.0


# -- idle cells --------------------------------------------------------------------------------
def idle_steps(quick: bool) -> tuple[int, ...]:
    return QUICK_IDLE_STEPS if quick else IDLE_STEPS


def largest_within(cpu_by_count: Mapping[int, float], limit: float) -> int:
    """The largest count measured within ``limit`` with every smaller count measured within it
    too (0 if even the first is over)."""
    largest = 0
    for count in sorted(cpu_by_count):
        if cpu_by_count[count] > limit:
            break
        largest = count
    return largest


def measure(cells: Sequence[RunningCell], seconds: float) -> Window:
    """Every process of ``cells`` over the next ``seconds``."""
    return cost_window({p: k for c in cells for p, k in process_kinds(c).items()}, seconds)


@dataclass
class IdleFill:
    limit: float
    steps: dict[int, Window] = field(default_factory=dict)
    largest: int = 0
    windows: list[Window] = field(default_factory=list)
    start_s: dict[int, float] = field(default_factory=dict)
    """Per count: how long that cell took to start (spawn -> whole), the others idle."""


def fill_idle(directory: Path, quick: bool) -> IdleFill:
    found = IdleFill(share_limit(IDLE_SHARE, os.cpu_count() or 1))
    settle = QUICK_IDLE_SETTLE_S if quick else IDLE_SETTLE_S
    cells: list[tuple[contextlib.ExitStack, RunningCell]] = []
    try:
        for target in idle_steps(quick):
            while len(cells) < target:
                cells.append(_idle_cell(directory, len(cells) + 1, found))
            time.sleep(settle)
            step = found.steps[target] = measure([c for _, c in cells], _step_s(quick))
            if step.cpu > found.limit:
                break
        found.largest = largest_within({n: w.cpu for n, w in found.steps.items()}, found.limit)
        while len(cells) > found.largest:
            cells.pop()[0].close()
        if cells:
            time.sleep(settle)
            seconds = QUICK_IDLE_WINDOW_S if quick else IDLE_WINDOW_S
            found.windows = [measure([c for _, c in cells], seconds) for _ in range(IDLE_WINDOWS)]
    finally:
        while cells:
            cells.pop()[0].close()
    return found


def _step_s(quick: bool) -> float:
    return QUICK_STEP_S if quick else STEP_S


def _idle_cell(
    directory: Path, number: int, found: IdleFill
) -> tuple[contextlib.ExitStack, RunningCell]:
    config = write_cell_file(directory, f"idle{number}", models=("arm6",))
    stack = contextlib.ExitStack()
    begun = time.monotonic()
    cell = stack.enter_context(
        running_cell(
            config, log=directory / f"idle{number}.log", timeout=START_TIMEOUT_S, attempts=2
        )
    )
    found.start_s[number] = time.monotonic() - begun
    return stack, cell


# -- moving cells ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Trajectory:
    cell: str
    ended_ns: int
    points: int
    error: str
    """The motion client's (``point 7 refused: NOT_READY ...``); empty when every point was
    taken."""
    refused: int
    """The refusing reply's result (0: none)."""
    off_pulses: int
    """At rest, the largest |commanded or feedback pulses - last point| of any axis; -1 when
    not judged (a point was refused)."""
    alarms: tuple[int, ...] = ()
    """An aborted trajectory's alarms: those its cell logged since the last good one."""

    @property
    def aborted(self) -> bool:
        return bool(self.error) or self.off_pulses != 0


def target_pulses(cell: Cell, goal: Mapping[int, Sequence[float]]) -> dict[int, np.ndarray]:
    """Each group's last point in pulses, as the wire carries its positions (float32)."""
    result = {}
    for group in cell.groups:
        wire = np.asarray(goal[group.index], dtype=np.float32).astype(np.float64)
        result[group.index] = AxisMap(group).ros_to_pulses(wire)
    return result


def off_goal_pulses(tick: Tick, targets: Mapping[int, np.ndarray]) -> int:
    """The largest difference, in pulses, between the tick's commanded or feedback position and
    the target, over every axis of every group."""
    worst = 0
    for index, target in targets.items():
        group = tick.groups[index]
        axes = len(target)
        for pulses in (group.command_pulses[:axes], group.feedback_pulses[:axes]):
            worst = max(worst, int(np.max(np.abs(np.asarray(pulses) - target))))
    return worst


def is_still(tick: Tick) -> bool:
    return all(
        g.depth == 0 and not any(g.increment) and not any(g.feedback_moved) for g in tick.groups
    )


def result_name(result: int) -> str:
    try:
        return Result(result).name
    except ValueError:
        return f"result {result}"


def aborted_by_kind(trajectories: Sequence[Trajectory]) -> dict[str, int]:
    """Aborted trajectories by why: the refusing reply's result, or ``not exactly at the end``."""
    kinds: dict[str, int] = {}
    for t in trajectories:
        if not t.aborted:
            continue
        name = result_name(t.refused) if t.error else "not exactly at the end"
        kinds[name] = kinds.get(name, 0) + 1
    return kinds


class DemoCell:
    """A cell (``cell``: entered here, left on ``close``; its log ``directory/<name>.log``)
    with a state client, driven like ``motocell demo`` in a thread of its own until ``stop``."""

    def __init__(
        self, directory: Path, cell: AbstractContextManager[RunningCell], seconds: float
    ) -> None:
        self.done: list[Trajectory] = []
        self.failure: BaseException | None = None
        self.stack = contextlib.ExitStack()
        self._stopping = threading.Event()
        try:
            self._start(directory, cell, seconds)
        except BaseException:
            self.stack.close()
            raise
        self.thread = threading.Thread(target=self._drive, name=f"drive-{self.name}", daemon=True)
        self.thread.start()

    def _start(
        self, directory: Path, cell: AbstractContextManager[RunningCell], seconds: float
    ) -> None:
        stack = self.stack
        self.cell = stack.enter_context(cell)
        self.name = self.cell.cell.name
        self.observer = stack.enter_context(Observer(self.cell))
        self.observer.record_ticks()
        state = StateClientProcess(self.cell, directory / f"{self.name}-state.npz", seconds)
        stack.callback(state.kill)
        self.streamer = stack.enter_context(StreamClientProcess(self.cell, directory))
        self.streamer.start_traj_mode()
        self.log = LogTail(directory / f"{self.name}.log")
        self.here = self.observer.wait_still()
        home = positions_of(self.cell.cell, self.here)
        away = {g: tuple(p + MOVE_RAD for p in ps) for g, ps in home.items()}
        self.goals = [away, home]

    def _drive(self) -> None:
        try:
            for index in itertools.count():
                if self._stopping.is_set():
                    return
                self.done.append(self._move(self.goals[index % 2]))
        except BaseException as exc:
            self.failure = exc

    def _move(self, goal: Mapping[int, tuple[float, ...]]) -> Trajectory:
        cell = self.cell.cell
        start = positions_of(cell, self.here)
        plans = {g: smooth_move(start[g], goal[g], MOVE_S, MOVE_POINTS) for g in start}
        record = self.streamer.stream(ex_messages(plans), stream_bound_s(MOVE_S))
        if record.error:
            refused = int(record.result[-1]) if len(record.result) else 0
            alarms = tuple(sorted(set(alarm_codes(self.log.lines("alarm")))))
            self._recover()
            self.log.skip()
            return Trajectory(
                self.name, time.monotonic_ns(), record.points, record.error, refused, -1, alarms
            )
        self.here, off = self._arrive(target_pulses(cell, goal))
        alarms = ()
        if off:
            alarms = tuple(sorted(set(alarm_codes(self.log.lines("alarm")))))
            self._recover()
        self.log.skip()
        return Trajectory(self.name, time.monotonic_ns(), record.points, "", 0, off, alarms)

    def _arrive(self, targets: Mapping[int, np.ndarray]) -> tuple[Tick, int]:
        """The robot at rest exactly at its last point: the first still tick there, or, after
        ``ARRIVE_S``, the last still tick and how far off it is. A still tick before the end
        (the ring run dry mid-move, motion resuming) is not the end."""
        deadline = time.monotonic() + ARRIVE_S
        while True:
            tick = self._still()
            off = off_goal_pulses(tick, targets)
            if off == 0 or time.monotonic() > deadline:
                return tick, off

    def _still(self) -> Tick:
        """The robot at rest: the next still tick, or the last tick if the clock already rests
        (a resting tick says the cell stays exactly so)."""
        try:
            return self.observer.wait_still(STILL_TIMEOUT_S)
        except TimeoutError:
            tick = self.observer.latest_tick()
            if tick.resting and is_still(tick):
                return tick
            raise

    def _recover(self) -> None:
        """START_TRAJ_MODE until it succeeds (after an alarm), then from wherever it stands."""
        self.streamer.recover()
        self.here = self._still()

    def stop(self) -> None:
        """Let the move under way end, and stop driving."""
        self._stopping.set()
        self.thread.join(STILL_TIMEOUT_S + stream_bound_s(MOVE_S))
        if self.thread.is_alive():
            raise RuntimeError(f"{self.name}: its move did not end")

    def check(self) -> None:
        if self.failure is not None:
            raise RuntimeError(f"{self.name}: driving failed: {self.failure}") from self.failure

    def close(self) -> None:
        with contextlib.suppress(RuntimeError):
            self.stop()
        self.stack.close()


@dataclass(frozen=True)
class MovingWindow:
    window: Window
    missed: int
    lateness_p99_us: float
    cells: int


def measure_moving(
    cells: Sequence[DemoCell], seconds: float, pids: Mapping[int, str] | None = None
) -> MovingWindow:
    """The driven ``cells`` over the next ``seconds``: their missed periods and lateness, and
    the cost of ``pids`` (pid: kind; by default every process of ``cells``)."""
    marks = [c.observer.mark() for c in cells]
    if pids is None:
        window = measure([c.cell for c in cells], seconds)
    else:
        window = cost_window(pids, seconds)
    missed = 0
    lateness: list[float] = []
    for c, mark in zip(cells, marks, strict=True):
        c.check()
        ticks = c.observer.ticks_since(max(0, mark - 1))
        if len(ticks) >= 2:
            missed += ticks[-1].missed - ticks[0].missed
            lateness += [t.lateness_ns / 1000 for t in ticks[1:]]
    return MovingWindow(window, missed, percentiles(lateness, (99,))[0], len(cells))


@dataclass
class Moving:
    limit: float
    probes: dict[int, MovingWindow] = field(default_factory=dict)
    windows: list[MovingWindow] = field(default_factory=list)
    trajectories: list[Trajectory] = field(default_factory=list)


def drive_moving(directory: Path, quick: bool) -> Moving:
    count = QUICK_MOVING_CELLS if quick else MOVING_CELLS
    probe_s = QUICK_PROBE_S if quick else PROBE_S
    window_s = QUICK_WINDOW_S if quick else WINDOW_S
    seconds = count * (probe_s + 60.0) + WINDOWS * window_s + 120.0
    found = Moving(share_limit(MOVING_SHARE, os.cpu_count() or 1))
    cells: list[DemoCell] = []
    try:
        with gc_paused():
            while len(cells) < count:
                four_groups = bench_cell(directory, f"scale{len(cells) + 1}")
                cells.append(DemoCell(directory, four_groups, seconds))
                time.sleep(SETTLE_S)
                if len(cells) < count:
                    found.probes[len(cells)] = measure_moving(cells, probe_s)
            found.windows = [measure_moving(cells, window_s) for _ in range(WINDOWS)]
            for cell in cells:
                cell.stop()
                cell.check()
    finally:
        for cell in cells:
            found.trajectories += cell.done
        while cells:
            cells.pop().close()
    return found


def largest_moving(found: Moving) -> int:
    """The largest count whose windows (probe, or the 3 windows at the full count) all had 0
    missed periods and CPU within the limit, every smaller count too."""
    by_count: dict[int, list[MovingWindow]] = {n: [w] for n, w in found.probes.items()}
    if found.windows:
        by_count[found.windows[0].cells] = found.windows
    largest = 0
    for n in sorted(by_count):
        if not all(w.missed == 0 and w.window.cpu <= found.limit for w in by_count[n]):
            break
        largest = n
    return largest


def ended_within(trajectories: Sequence[Trajectory], window: Window) -> list[Trajectory]:
    return [t for t in trajectories if window.start_ns <= t.ended_ns <= window.end_ns]


def ended_outside(
    trajectories: Sequence[Trajectory], windows: Sequence[Window]
) -> list[Trajectory]:
    """Those that ended in none of the windows: while a cell was being added (or stopped)."""
    return [
        t for t in trajectories if not any(w.start_ns <= t.ended_ns <= w.end_ns for w in windows)
    ]


# -- results -----------------------------------------------------------------------------------
def run(quick: bool) -> list[dict[str, Any]]:
    with workdir() as directory:
        idle = fill_idle(directory, quick)
        moving = drive_moving(directory, quick)
    return idle_results(idle, quick) + moving_results(moving, quick)


def _per_kind(tag: str, windows: Sequence[Window]) -> list[dict[str, Any]]:
    results = []
    kinds = [cost_by_kind(w.rows) for w in windows]
    for kind in PROCESS_KINDS:
        values = [k[kind].cpu_percent for k in kinds if kind in k]
        if values:
            name = f"{tag}   {kind} x{kinds[0][kind].pid}, together"
            results.append(figure_result(FIGURE, name, "% of 1 core", values))
    return results


def idle_results(idle: IdleFill, quick: bool) -> list[dict[str, Any]]:
    seconds = QUICK_IDLE_WINDOW_S if quick else IDLE_WINDOW_S
    cap = idle_steps(quick)[-1]
    n = idle.largest
    tag = f"[{n} idle single-arm cells]"
    totals = [total("all", w.rows) for w in idle.windows]
    results = [
        figure_result(
            FIGURE,
            f"idle single-arm cells within {idle.limit:g} % of a core (cap {cap})",
            "cells",
            [n],
            goal=(">=", IDLE_COUNT_GOAL),
            note=f"{IDLE_WINDOWS} x {seconds:g} s windows at that count",
        ),
        figure_result(
            FIGURE, f"{tag} CPU, all processes", "% of 1 core", [t.cpu_percent for t in totals]
        ),
        figure_result(
            FIGURE,
            f"{tag} CPU per cell",
            "% of 1 core",
            [t.cpu_percent / max(1, n) for t in totals],
        ),
        figure_result(
            FIGURE, f"{tag} wake-ups, all processes", "1/s", [t.wakeups_per_s for t in totals]
        ),
        figure_result(FIGURE, f"{tag} RSS, all processes", "MiB", [t.rss_mib for t in totals]),
        figure_result(FIGURE, f"{tag} PSS, all processes", "MiB", [t.pss_mib for t in totals]),
    ]
    results += _per_kind(tag, idle.windows)
    if n in idle.start_s:
        results.append(
            figure_result(
                FIGURE,
                f"{tag} start of the last cell (spawn -> whole), the others idle",
                "s",
                [idle.start_s[n]],
            )
        )
    for count, step in idle.steps.items():
        results.append(
            figure_result(
                FIGURE, f"  step: {count} idle cells, CPU, all processes", "% of 1 core", [step.cpu]
            )
        )
    return results


def moving_results(moving: Moving, quick: bool) -> list[dict[str, Any]]:
    window_s = QUICK_WINDOW_S if quick else WINDOW_S
    n = moving.windows[0].cells if moving.windows else 0
    tag = f"[{n} four-group cells moving]"
    every = moving.trajectories
    outside = ended_outside(every, [w.window for w in [*moving.probes.values(), *moving.windows]])
    results = [
        figure_result(
            FIGURE,
            "trajectories aborted, every cell, the whole figure",
            "trajectories",
            [sum(t.aborted for t in every)],
            goal=("==", 0),
            note=f"of {len(every)}; {aborted_text(every)}",
        ),
        figure_result(
            FIGURE,
            "  of them while a cell was being started beside them (outside every window)",
            "trajectories",
            [sum(t.aborted for t in outside)],
            note=aborted_text(outside),
        ),
        figure_result(
            FIGURE,
            f"{tag} trajectories ended per window",
            "trajectories",
            [len(ended_within(every, w.window)) for w in moving.windows],
            note=f"{WINDOWS} windows of {window_s:g} s; 2 s demo moves, 4 groups in 2016",
        ),
        figure_result(
            FIGURE,
            f"{tag} trajectories aborted per window",
            "trajectories",
            [sum(t.aborted for t in ended_within(every, w.window)) for w in moving.windows],
            goal=("==", 0),
            rule="all",
        ),
        figure_result(
            FIGURE,
            f"{tag} missed periods, all cells",
            "periods",
            [w.missed for w in moving.windows],
            note="this VM's floor applies (docs/realtime.md)",
        ),
        figure_result(
            FIGURE,
            f"{tag} executor lateness p99",
            "us",
            [w.lateness_p99_us for w in moving.windows],
        ),
        figure_result(
            FIGURE,
            f"{tag} CPU, all processes",
            "% of 1 core",
            [w.window.cpu for w in moving.windows],
        ),
        figure_result(
            FIGURE,
            f"{tag} wake-ups, all processes",
            "1/s",
            [total("all", w.window.rows).wakeups_per_s for w in moving.windows],
        ),
        figure_result(
            FIGURE,
            f"{tag} PSS, all processes",
            "MiB",
            [total("all", w.window.rows).pss_mib for w in moving.windows],
        ),
    ]
    results += _per_kind(tag, [w.window for w in moving.windows])
    for count, probe in moving.probes.items():
        results += [
            figure_result(
                FIGURE,
                f"  probe: {count} moving, CPU, all processes",
                "% of 1 core",
                [probe.window.cpu],
            ),
            figure_result(
                FIGURE, f"  probe: {count} moving, missed periods", "periods", [probe.missed]
            ),
        ]
    results.append(
        figure_result(
            FIGURE,
            f"four-group cells moving with 0 missed periods, CPU <= {moving.limit:g} % of a core",
            "cells",
            [largest_moving(moving)],
            goal=(">=", MOVING_COUNT_GOAL),
            note="figure 7's former goal; probes of 1..N-1 cells, the N cells' windows",
        )
    )
    return results


def alarms_by_code(trajectories: Sequence[Trajectory]) -> dict[int, int]:
    """Per alarm: how many aborted trajectories its cell raised it for."""
    codes: dict[int, int] = {}
    for t in trajectories:
        if t.aborted:
            for code in t.alarms:
                codes[code] = codes.get(code, 0) + 1
    return dict(sorted(codes.items()))


def aborted_text(trajectories: Sequence[Trajectory]) -> str:
    kinds = aborted_by_kind(trajectories)
    if not kinds:
        return "none aborted"
    text = ", ".join(f"{name} {count}" for name, count in sorted(kinds.items()))
    alarms = alarms_by_code(trajectories)
    if alarms:
        text += "; alarms logged: " + ", ".join(f"{c} ({n})" for c, n in alarms.items())
    return text
