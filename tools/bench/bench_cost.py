"""Figure 10: what a cell costs, idle and moving: CPU time and wake-ups per process.

    python -m motocell.tools.bench.run --only 10 [--quick]

Every process of the cell is measured from /proc over windows of 20 s (quick: 3 s), 3 windows
per case, nothing of the benchmark's own subscribed to the cell while a window runs:

- CPU: each thread's time on a CPU (``/proc/<pid>/task/<tid>/schedstat``, nanoseconds), added
  up per process, in % of one core; a cell's figure is all its processes together (the
  launcher with its Zenoh router, controller, executor, broadcaster, gateway, interpolators).
- wake-ups: each thread's context switches, voluntary and not (``/proc/<pid>/task/<tid>/status``),
  per second: every wake-up counts, whatever it did.
- memory: RSS and PSS (a process's own pages plus its share of the shared ones) at the end.

The cases, each a cell of its own, started for the case:

1. the default cell (one arm6 on a YRC1000, written out as a file so that a state client can
   read it), idle, alternating within the same cell with
2. the same cell with one state client connected (``tools.bench.state_client``, a lean process that
   reads the state port; the default 10 ms state period): windows idle, client, idle, client,
   ... (A/B), the client connected 3 s (quick 2 s) before its window and gone 3 s before the
   next. The client's frames are counted too: the state port must still send every period
   while a client is connected (the rate within 1 % of the configured one);
3. the four-group cell of ``bench_cell``, idle;
4. the same four groups moving (``tools.bench.swinging``: one long 2016 trajectory, every axis
   swinging 0.2 rad, points 0.2 s apart streamed like motoman_driver, as figure 7's cells),
   the state period at one tick (4 ms) and 4 state clients connected. The benchmark's observer
   of the ticks is closed before the windows (its subscription would be measured too); the
   stream's record shows the robot still took points in every window. As a diagnosis, the
   executor's CPU per tick: all its threads, and its clock thread alone (the main thread, which
   runs ``Clock.run``); the rest is Zenoh's threads, mostly the transmit thread each tick's put
   wakes (docs/realtime.md, "The tick's cost").

Goals, all processes of the cell together, median of the windows: (1) <= 3 % of one core,
(2) <= 6 %, (3) <= 5 %, (4) <= 25 %. The measuring clients are processes of their own and not
the cell's; the state client's own CPU is shown as a diagnosis.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from motocell.testing.running_cell import running_cell
from motocell.tools.bench.clients import StateClientProcess, StreamRecord
from motocell.tools.bench.measuring import (
    PROCESS_KINDS,
    START_TIMEOUT_S,
    Window,
    bench_cell,
    cost_by_kind,
    cost_window,
    figure_result,
    process_kinds,
    thread_usage,
    total,
    workdir,
    write_cell_file,
)
from motocell.tools.bench.swinging import SwingingCell

FIGURE = 10
WINDOWS = 3
WINDOW_S = 20.0
QUICK_WINDOW_S = 3.0
SETTLE_S = 3.0
"""After a start, a client's arrival or departure: the burst passes, the clock comes to rest."""
QUICK_SETTLE_S = 2.0
MOVING_STATE_PERIOD_MS = 4.0
MOVING_CLIENTS = 4
RATE_GOAL_PERCENT = 1.0
"""The order of the rows."""
CLIENT = "state client"


@dataclass(frozen=True)
class Case:
    label: str
    goal: float
    """% of one core, all the cell's processes."""


IDLE_ARM = Case("idle single-arm cell", 3.0)
WITH_CLIENT = Case("single-arm cell, 1 state client", 6.0)
IDLE_FOUR = Case("idle four-group cell", 5.0)
MOVING = Case("four-group cell moving, 4 state clients at 4 ms", 25.0)


def rate_hz(received_ns: np.ndarray, start_ns: int, end_ns: int) -> float:
    """Frames per second read between ``start_ns`` and ``end_ns`` (0 with fewer than 2)."""
    inside = received_ns[(received_ns >= start_ns) & (received_ns <= end_ns)]
    if len(inside) < 2:
        return 0.0
    return float((len(inside) - 1) / ((inside[-1] - inside[0]) / 1e9))


def deviation_percent(rate: float, period_ns: int) -> float:
    configured = 1e9 / period_ns
    return abs(rate - configured) / configured * 100.0


def took_points(record: StreamRecord, windows: Sequence[Window]) -> list[bool]:
    """Per window: whether the stream had a point accepted within it (the robot still moving)."""
    accepted = record.accepted_ns[record.accepted_ns > 0]
    return [bool(np.any((accepted >= w.start_ns) & (accepted <= w.end_ns))) for w in windows]


@dataclass
class Measured:
    windows: dict[str, list[Window]]
    """Per case label, its windows (the cell's processes only)."""
    client: list[Window]
    client_deviation: list[float]
    client_rate: list[float]
    moving_period_ns: int = 0
    clock_share: list[float] = field(default_factory=list)
    """Per moving window: the executor's clock thread's CPU time over the window's length."""


def single_arm(directory: Path, count: int, seconds: float, settle: float, found: Measured) -> None:
    config = write_cell_file(directory, "cost1", models=("arm6",))
    with running_cell(
        config, log=directory / "cost1.log", timeout=START_TIMEOUT_S, attempts=2
    ) as cell:
        kinds = process_kinds(cell)
        time.sleep(settle)
        for index in range(count):
            found.windows[IDLE_ARM.label].append(cost_window(kinds, seconds))
            out = directory / f"client{index}.npz"
            client = StateClientProcess(cell, out, seconds + 2 * settle + 30.0)
            try:
                time.sleep(settle)
                pid = client.child.process.pid
                measured = cost_window({**kinds, pid: CLIENT}, seconds)
                received = client.stop()["received_ns"]
            except BaseException:
                client.kill()
                raise
            ours = [r for r in measured.rows if r.kind == CLIENT]
            theirs = [r for r in measured.rows if r.kind != CLIENT]
            found.windows[WITH_CLIENT.label].append(
                Window(theirs, measured.start_ns, measured.end_ns)
            )
            found.client.append(Window(ours, measured.start_ns, measured.end_ns))
            rate = rate_hz(received, measured.start_ns, measured.end_ns)
            found.client_rate.append(rate)
            found.client_deviation.append(deviation_percent(rate, cell.cell.state_period_ns))
            time.sleep(settle)


def idle_four(directory: Path, count: int, seconds: float, settle: float, found: Measured) -> None:
    with bench_cell(directory, "cost4") as cell:
        kinds = process_kinds(cell)
        time.sleep(settle)
        found.windows[IDLE_FOUR.label] = [cost_window(kinds, seconds) for _ in range(count)]


def moving_cell(directory: Path, name: str, seconds: float) -> SwingingCell:
    """The fourth case's cell: four groups swinging for up to ``seconds``, the state period at
    one tick, 4 state clients, no observer of the ticks."""
    return SwingingCell(
        directory,
        name,
        seconds,
        state_period_ms=MOVING_STATE_PERIOD_MS,
        state_clients=MOVING_CLIENTS,
        observe=False,
    )


def moving(directory: Path, count: int, seconds: float, settle: float, found: Measured) -> None:
    cell = moving_cell(directory, "cost-moving", count * seconds + settle + 60.0)
    try:
        kinds = process_kinds(cell.cell)
        executor = next(pid for pid, kind in kinds.items() if kind == "executor")
        time.sleep(settle)
        windows = []
        for _ in range(count):
            before = main_thread_ns(executor)
            windows.append(cost_window(kinds, seconds))
            used = main_thread_ns(executor) - before
            found.clock_share.append(used / (windows[-1].end_ns - windows[-1].start_ns))
        found.moving_period_ns = cell.cell.cell.period_ns
    finally:
        record = cell.close()
    if record is None:
        raise RuntimeError("the moving cell's stream left no record")
    record.check()
    if not all(took_points(record, windows)):
        raise RuntimeError(f"the moving cell stopped taking points: {took_points(record, windows)}")
    found.windows[MOVING.label] = windows


def main_thread_ns(pid: int) -> int:
    """CPU time of ``pid``'s main thread so far (0 once it is gone)."""
    usage = thread_usage(pid).get(pid)
    return 0 if usage is None else usage.cpu_ns


def measure(quick: bool) -> Measured:
    seconds = QUICK_WINDOW_S if quick else WINDOW_S
    settle = QUICK_SETTLE_S if quick else SETTLE_S
    found = Measured({IDLE_ARM.label: [], WITH_CLIENT.label: []}, [], [], [])
    with workdir() as directory:
        single_arm(directory, WINDOWS, seconds, settle, found)
        idle_four(directory, WINDOWS, seconds, settle, found)
        moving(directory, WINDOWS, seconds, settle, found)
    return found


def kind_name(kind: str, count: int) -> str:
    return kind if count == 1 else f"{kind} x{count}, together"


def case_results(case: Case, windows: Sequence[Window], note: str = "") -> list[dict[str, Any]]:
    """All processes (against the goal), then each kind: CPU, wake-ups; memory at the end."""
    tag = f"[{case.label}]"
    totals = [total("all", w.rows) for w in windows]
    kinds = [cost_by_kind(w.rows) for w in windows]
    present = [k for k in PROCESS_KINDS if all(k in found for found in kinds)]
    present += sorted({k for found in kinds for k in found} - set(present))
    results = [
        figure_result(
            FIGURE,
            f"{tag} CPU, all its processes",
            "% of 1 core",
            [t.cpu_percent for t in totals],
            goal=("<=", case.goal),
            note=note,
        )
    ]
    for kind in present:
        values = [found[kind].cpu_percent for found in kinds if kind in found]
        name = kind_name(kind, kinds[0][kind].pid if kind in kinds[0] else 1)
        results.append(figure_result(FIGURE, f"{tag}   {name}", "% of 1 core", values))
    results.append(
        figure_result(
            FIGURE, f"{tag} wake-ups, all its processes", "1/s", [t.wakeups_per_s for t in totals]
        )
    )
    for kind in present:
        values = [found[kind].wakeups_per_s for found in kinds if kind in found]
        name = kind_name(kind, kinds[0][kind].pid if kind in kinds[0] else 1)
        results.append(figure_result(FIGURE, f"{tag}   {name}", "1/s", values))
    results += [
        figure_result(FIGURE, f"{tag} RSS, all its processes", "MiB", [t.rss_mib for t in totals]),
        figure_result(FIGURE, f"{tag} PSS, all its processes", "MiB", [t.pss_mib for t in totals]),
    ]
    return results


def run(quick: bool) -> list[dict[str, Any]]:
    found = measure(quick)
    seconds = QUICK_WINDOW_S if quick else WINDOW_S
    note = f"{WINDOWS} windows of {seconds:g} s"
    results = case_results(IDLE_ARM, found.windows[IDLE_ARM.label], note + "; A/B with the next")
    results += case_results(WITH_CLIENT, found.windows[WITH_CLIENT.label])
    results += [
        figure_result(
            FIGURE,
            f"[{WITH_CLIENT.label}] state frames read, rate",
            "Hz",
            found.client_rate,
        ),
        figure_result(
            FIGURE,
            f"[{WITH_CLIENT.label}] state rate's deviation from the configured",
            "%",
            found.client_deviation,
            goal=("<=", RATE_GOAL_PERCENT),
        ),
        figure_result(
            FIGURE,
            f"[{WITH_CLIENT.label}]   diagnosis: the state client's own CPU",
            "% of 1 core",
            [total(CLIENT, w.rows).cpu_percent for w in found.client],
        ),
    ]
    results += case_results(IDLE_FOUR, found.windows[IDLE_FOUR.label])
    results += case_results(MOVING, found.windows[MOVING.label])
    results += per_tick_results(found)
    return results


def per_tick_results(found: Measured) -> list[dict[str, Any]]:
    """The moving executor's CPU per tick (µs): all its threads, and its clock thread."""
    period_us = found.moving_period_ns / 1000
    executors = [cost_by_kind(w.rows)["executor"] for w in found.windows[MOVING.label]]
    tag = f"[{MOVING.label}]"
    return [
        figure_result(
            FIGURE,
            f"{tag}   diagnosis: executor CPU per tick, all its threads",
            "us",
            [e.cpu_percent / 100 * period_us for e in executors],
        ),
        figure_result(
            FIGURE,
            f"{tag}   diagnosis: executor CPU per tick, its clock thread",
            "us",
            [share * period_us for share in found.clock_share],
        ),
    ]
