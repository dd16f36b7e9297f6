"""Figure 9: start-up and stop of a whole cell.

    python -m motocell.tools.bench.run --only 9 [--quick]

Each run spawns ``motocell up`` (a 4-group cell: launcher with its router, controller,
executor, broadcaster, 4 interpolators, gateway) and measures from the spawn (CLOCK_MONOTONIC):

- the first ROBOT_STATUS frame on the state port (the port is polled every 10 ms);
- every service alive: CHECK_MOTION_READY no longer answers NOT_READY 5012 (polled);
- START_TRAJ_MODE's own reply time, and spawn -> motion-ready (its SUCCESS reply);
- stop: SIGTERM to the launcher -> every process of the cell has exited.

Goals, on an idle 2-core machine: first ROBOT_STATUS <= 1 s and motion-ready <= 1.2 s after
the spawn. 5 runs (3 in quick mode). After the first run's measurements an observer waits for
the executor's metrics, so the figure states whether it ran SCHED_FIFO.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.testing.client import MotionClient, StateListener
from motocell.testing.processes import connectable, wait_until
from motocell.testing.running_cell import RunningCell, start_cell
from motocell.tools.bench.measuring import Observer, figure_result, workdir, write_cell_file

FIGURE = 9
RUNS = 5
QUICK_RUNS = 3
TIMEOUT_S = 60.0
FIRST_STATUS_GOAL_MS = 1000.0
MOTION_READY_GOAL_MS = 1200.0
METRICS_WAIT_S = 3.0
"""The executor publishes its metrics every second."""


def note_executor_mode(cell: RunningCell) -> None:
    """Wait for one ``executor/metrics`` sample; the observer notes its ``realtime`` flag."""
    with Observer(cell) as observer:
        wait_until(lambda: bool(observer.metrics), METRICS_WAIT_S, "the executor's metrics")


def once(directory: Path, index: int) -> dict[str, float]:
    config = write_cell_file(directory, f"bench9x{index}")
    cell = start_cell(config, log=directory / f"startup{index}.log")
    try:
        times = milestones(cell)
        if index == 0:
            note_executor_mode(cell)
        stopping = time.monotonic_ns()
    finally:
        cell.stop()
    stopped = time.monotonic_ns()
    return {**times, "stop": (stopped - stopping) / 1e6}


def milestones(cell: RunningCell) -> dict[str, float]:
    """From the spawn to motion-ready, ms: the first ROBOT_STATUS, every service alive,
    START_TRAJ_MODE's own reply time and its SUCCESS (figures 9 and 13)."""
    spawned = cell.spawned_ns
    wait_until(lambda: connectable(cell.host, cell.port_base + 1), TIMEOUT_S, "state port")
    with StateListener(cell.host, cell.port_base + 1, cell.byte_order).start() as state:
        first = state.wait_for(lambda f: f.status is not None, TIMEOUT_S)
    first_status = (first.received_ns - spawned) / 1e6
    # Connected once, as a client would: a probe first would make the gateway keep this one
    # waiting while it closes the probe (MotoROS's 50 ms pause, ``testing.client``).
    with MotionClient.once_listening(
        cell.host, cell.port_base, cell.byte_order, TIMEOUT_S
    ) as motion:
        while True:
            reply = motion.command(Command.CHECK_MOTION_READY)
            if reply.subcode != NotReadySubcode.INC_MOVE_ERROR:
                break
            if time.monotonic_ns() - spawned > TIMEOUT_S * 1e9:
                raise TimeoutError("the cell's services did not all come up")
            time.sleep(0.005)
        all_alive = (time.monotonic_ns() - spawned) / 1e6
        sent = time.monotonic_ns()
        reply = motion.command(Command.START_TRAJ_MODE)
        done = time.monotonic_ns()
        if reply.result != Result.SUCCESS:
            raise RuntimeError(f"START_TRAJ_MODE refused: {reply}")
    return {
        "first_status": first_status,
        "all_alive": all_alive,
        "start_traj_mode": (done - sent) / 1e6,
        "motion_ready": (done - spawned) / 1e6,
    }


def run(quick: bool) -> list[dict[str, Any]]:
    rows: dict[str, list[float]] = {}
    with workdir() as directory:
        for index in range(QUICK_RUNS if quick else RUNS):
            for key, value in once(directory, index).items():
                rows.setdefault(key, []).append(value)
    return [
        figure_result(
            FIGURE,
            "spawn -> first ROBOT_STATUS",
            "ms",
            rows["first_status"],
            goal=("<=", FIRST_STATUS_GOAL_MS),
            note="4-group cell, 9 processes",
        ),
        figure_result(FIGURE, "spawn -> every service alive (no 5012)", "ms", rows["all_alive"]),
        figure_result(FIGURE, "START_TRAJ_MODE reply", "ms", rows["start_traj_mode"]),
        figure_result(
            FIGURE,
            "spawn -> motion-ready",
            "ms",
            rows["motion_ready"],
            goal=("<=", MOTION_READY_GOAL_MS),
        ),
        figure_result(FIGURE, "SIGTERM -> every process exited", "ms", rows["stop"]),
    ]
