"""Figure 3: executor lateness and missed periods under load.

    python -m motocell.tools.bench.run --only 3 [--quick]

A 4-group cell (arm6, arm6, arm7, positioner2, YRC1000, 4 ms period) with the state period set
to one tick (4 ms), 4 state clients connected (each its own process), and all 4 groups moving
(a constant-velocity 2016 trajectory, points 100 ms apart, streamed like motoman_driver by a
motion client in its own process, so the gateway also answers a BUSY point every ~5 ms); see
``tools.bench.loaded``. Each run is one window (60 s; 2 s in quick mode) of the ``executor/tick``
stream, observed from a Zenoh client on the cell's router.

Lateness is the executor's own figure per tick (wake time - absolute deadline, CLOCK_MONOTONIC);
missed periods are the increase of ``Tick.missed`` over the window (ticks woken a whole period
late or more; they are caught up, not skipped). Percentiles come from the raw per-tick samples
of each run; the table shows the median and [min-max] of the per-run figures.

The same runs give figure 6 (``tools.bench.bench_state``).

The servo model's share of a tick is measured apart, in this process with no cell: ``Servos.step``
for the same 4 groups all moving, plus the feedback the tick report takes from it, timed per
tick (``perf_counter_ns``); the figure-3 lateness above already includes it, since the cell runs
the catalogue's position loops. So is the executor's whole tick path, after a sleep to each
deadline as in the clock (``tools.bench.tick_path``: the real core and outputs on a Zenoh session):
CPU time per tick, in this process with no cell.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from motocell.shared.config import load_catalogue
from motocell.shared.motion.servo import Servos
from motocell.shared.protocol.constants import MAX_AXES
from motocell.tools.bench.loaded import loaded_runs
from motocell.tools.bench.measuring import GROUP_MODELS, figure_result, percentiles
from motocell.tools.bench.tick_path import tick_path_us

FIGURE = 3
RUNS = 3
SECONDS = 60.0
QUICK_RUNS = 3
QUICK_SECONDS = 2.0
P99_GOAL_US = 200.0
SERVO_TICKS = 50_000
QUICK_SERVO_TICKS = 10_000
TICK_PATH_TICKS = 2_000
QUICK_TICK_PATH_TICKS = 500
SERVO_STEP_PULSES = 5
"""Every used axis moves this much a tick: the servo never rests, so no tick takes the shortcut
of an axis at rest."""


def settings(quick: bool) -> tuple[int, float]:
    return (QUICK_RUNS, QUICK_SECONDS) if quick else (RUNS, SECONDS)


def servo_tick_us(ticks: int) -> np.ndarray:
    """Microseconds per tick that the servo model takes for the figure's 4 moving groups."""
    catalogue = load_catalogue()
    models = [catalogue[name] for name in GROUP_MODELS]
    command = np.zeros((len(models), MAX_AXES), dtype=np.int64)
    step = np.zeros_like(command)
    for g, model in enumerate(models):
        step[g, : model.axes] = SERVO_STEP_PULSES
    servos = Servos([model.servo for model in models], 0.004, command.tolist())
    taken = np.empty(ticks)
    for i in range(ticks):
        command += step
        rows = command.tolist()
        start = time.perf_counter_ns()
        servos.step(rows)
        servos.feedback_pulses()
        [list(row) for row in servos.moved]  # the copy the tick report takes
        taken[i] = time.perf_counter_ns() - start
    return taken / 1000.0


def in_process_results(
    name: str, measure: Callable[[int], np.ndarray], ticks: int, how: str
) -> list[dict[str, Any]]:
    """p50 and p99 of ``measure``'s microseconds per tick, RUNS runs of ``ticks`` ticks each."""
    per_run = [percentiles(measure(ticks), (50, 99)) for _ in range(RUNS)]
    where = f"{RUNS} x {ticks:,} ticks in-process, {how}"
    return [
        figure_result(FIGURE, f"{name} p50", "us", [p[0] for p in per_run], note=where),
        figure_result(FIGURE, f"{name} p99", "us", [p[1] for p in per_run]),
    ]


def run(quick: bool) -> list[dict[str, Any]]:
    runs = loaded_runs(*settings(quick))
    per_run: dict[str, list[float]] = {k: [] for k in ("p50", "p99", "p99.9", "max")}
    missed, ticks, gaps = [], [], []
    for r in runs:
        lateness_us = r.lateness_ns / 1000.0
        for name, value in zip(per_run, percentiles(lateness_us, (50, 99, 99.9, 100)), strict=True):
            per_run[name].append(value)
        missed.append(float(r.missed))
        ticks.append(r.ticks / r.window_s)
        gaps.append(float(r.tick_gaps))
    seconds = runs[0].window_s
    where = f"{len(runs)} x {seconds:g} s, 4 groups moving, 4 state clients at 4 ms"
    return [
        figure_result(FIGURE, "executor lateness p50", "us", per_run["p50"], note=where),
        figure_result(
            FIGURE, "executor lateness p99", "us", per_run["p99"], goal=("<=", P99_GOAL_US)
        ),
        figure_result(FIGURE, "executor lateness p99.9", "us", per_run["p99.9"]),
        figure_result(FIGURE, "executor lateness max", "us", per_run["max"]),
        figure_result(
            FIGURE, "executor missed periods", "periods", missed, goal=("==", 0), rule="all"
        ),
        figure_result(FIGURE, "executor ticks observed", "ticks/s", ticks),
        figure_result(FIGURE, "executor tick samples lost (observer)", "gaps", gaps),
        *in_process_results(
            "servo model per tick",
            servo_tick_us,
            QUICK_SERVO_TICKS if quick else SERVO_TICKS,
            "4 groups moving (arm6, arm6, arm7, positioner2)",
        ),
        *in_process_results(
            "executor tick path CPU per tick",
            tick_path_us,
            QUICK_TICK_PATH_TICKS if quick else TICK_PATH_TICKS,
            "each after a sleep to its deadline",
        ),
    ]
