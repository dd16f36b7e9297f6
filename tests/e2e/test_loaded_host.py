"""A loaded host does not make a live cell lose a service (docs/liveness.md, Checked on a loaded
host).

A CPU hog per core at normal priority runs while a four-group cell moves MOVES trajectories one
after another: the controller declares no service missing, every trajectory ends exactly on its
last point, and whatever the cell refuses meanwhile it refuses as NOT_READY and is ready again
afterwards. How often a loaded cell refuses, and how late it runs, are timings for the
benchmark, not for a test that must pass on a machine of any load.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import pytest
import zenoh

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ControllerStatus, Decoder
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.messages import MotoMotionReply
from motocell.testing.client import Feedback, MotionClient, StateListener, smooth_move, stream_ex
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell
from tests.e2e.stalling import WITHIN_LEASE_S, beyond_the_lease, stall

pytestmark = [
    pytest.mark.cell,
    pytest.mark.parametrize("cell", ["four-group.toml"], indirect=True),
]

MOVES = 8
"""Trajectories streamed while the hogs run, out and back: a count, not a duration, so a loaded
machine moves as much as an idle one."""
MOST_REFUSALS = 100
"""A cell that refuses this often is not recovering: the test stops trying."""
HOG = (sys.executable, "-c", "while True: pass")
MOVE_S = 1.0
POINTS = 6
OFFSETS = (0.21, 0.17, 0.05, 0.31)
"""How far each group moves and back: radians, metres for the track (B1)."""
RETRY_S = 0.1
"""Between two START_TRAJ_MODE attempts after a refusal."""
DEADLINE_S = 60.0
"""A bound for a lost trajectory or a cell that never gets ready: a hang, not a speed."""
STALL_S = WITHIN_LEASE_S / 2
"""Half the longest stall the cell must ride out (``WITHIN_LEASE_S``), the other half left to
the machine's load: longer than a loaded host stalls a process (about 1 s: docs/liveness.md,
section 2); a test whose process went longer without running skips (``stalling``)."""


@contextmanager
def cpu_hogs(count: int) -> Iterator[None]:
    """``count`` busy processes at normal priority, killed (and reaped) on exit."""
    hogs = [subprocess.Popen(HOG) for _ in range(count)]
    try:
        yield
    finally:
        for hog in hogs:
            hog.kill()
        for hog in hogs:
            hog.wait()


class MissingWatch:
    """Every time the controller starts declaring a service missing, as any observer sees
    its ``controller/status``."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        self.flaps: list[tuple[float, list[str]]] = []
        self._missing: list[str] = []
        self._lock = threading.Lock()
        decoder = Decoder(ControllerStatus)

        def on_status(sample: zenoh.Sample) -> None:
            missing = decoder.decode(sample.payload.to_bytes()).missing_services
            with self._lock:
                if missing and missing != self._missing:
                    self.flaps.append((time.monotonic(), missing))
                self._missing = missing

        self.subscriber = session.declare_subscriber(keys.controller_status, on_status)


@dataclass
class Run:
    """What the trajectories met under load."""

    maps: list[AxisMap]
    moves: int = 0
    refusals: list[MotoMotionReply] = field(default_factory=list)
    """Every reply that refused a point or START_TRAJ_MODE."""
    misses: list[dict[int, list[int]]] = field(default_factory=list)
    """Per trajectory that did not end on its last point: each group's pulse error."""


def pulses(axis_map: AxisMap, ros: tuple[float, ...]) -> list[int]:
    """As the cell converts a position it received: Simple Message carries float32."""
    return axis_map.pad_moto(axis_map.ros_to_pulses(np.array(ros, dtype=np.float32)))


def positions(feedback: Feedback, run: Run) -> dict[int, tuple[float, ...]]:
    return {
        g: tuple(feedback.groups[g].positions[: axis_map.axes])
        for g, axis_map in enumerate(run.maps)
    }


def start_traj_mode(motion: MotionClient, run: Run) -> None:
    """START_TRAJ_MODE until the cell is motion-ready, each refusal counted."""

    def ready() -> bool:
        reply = motion.command(Command.START_TRAJ_MODE)
        if reply.result != Result.SUCCESS:
            run.refusals.append(reply)
            time.sleep(RETRY_S)  # a client's pause between attempts, as motoman_driver's
            return False
        return motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE

    wait_until(ready, DEADLINE_S, "the cell to be motion-ready again")


def move(motion: MotionClient, state: StateListener, run: Run, sign: int) -> bool:
    """One trajectory of every group, out or back; whether every point was accepted."""
    start = positions(state.wait_still(DEADLINE_S), run)
    goals = {g: tuple(p + sign * OFFSETS[g] for p in start[g]) for g in start}
    plans = {g: smooth_move(start[g], goals[g], MOVE_S, POINTS) for g in start}
    result = stream_ex(motion, plans)
    if result.points != POINTS:
        assert result.last_reply is not None
        run.refusals.append(result.last_reply)
        return False
    targets = {g: pulses(run.maps[g], goals[g]) for g in goals}

    def errors(feedback: Feedback) -> dict[int, list[int]]:
        now = {g: pulses(run.maps[g], p) for g, p in positions(feedback, run).items()}
        return {
            g: [a - b for a, b in zip(now[g], targets[g], strict=True)]
            for g in targets
            if now[g] != targets[g]
        }

    try:
        state.wait_for(lambda f: f.status is not None and not errors(f), DEADLINE_S)
    except TimeoutError:
        latest = state.latest()
        assert latest is not None
        run.misses.append(errors(latest))
    run.moves += 1
    return True


def test_a_loaded_host_loses_no_service_and_stops_no_trajectory(
    cell: RunningCell, bus: zenoh.Session, motion: MotionClient, state: StateListener
) -> None:
    run = Run([AxisMap(group) for group in cell.cell.groups])
    watch = MissingWatch(bus, cell.keys)
    try:
        with cpu_hogs(os.cpu_count() or 2):
            sign = 1
            while run.moves < MOVES and len(run.refusals) < MOST_REFUSALS:
                start_traj_mode(motion, run)
                if move(motion, state, run, sign):
                    sign = -sign
    finally:
        watch.subscriber.undeclare()

    assert not watch.flaps, f"services declared missing under load: {watch.flaps}"
    refused = Counter((reply.result, reply.subcode) for reply in run.refusals)
    assert {result for result, _ in refused} <= {Result.NOT_READY}, dict(refused)
    assert run.moves == MOVES, f"{run.moves} trajectories; (result, subcode): {dict(refused)}"
    assert not run.misses, f"trajectories off their last point (pulses): {run.misses}"


def test_a_service_stalled_for_less_than_the_lease_is_not_declared_missing(
    cell: RunningCell, bus: zenoh.Session, motion: MotionClient, state: StateListener
) -> None:
    """A stall is what a loaded host does to a process at worst: no CPU for a while. The
    broadcaster stops for STALL_S."""
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    watch = MissingWatch(bus, cell.keys)
    (broadcaster,) = cell.service_pids("broadcaster")
    try:
        lived = stall([broadcaster], STALL_S)
        resumed_ns = time.monotonic_ns()
        state.wait_for(lambda f: f.received_ns > resumed_ns, DEADLINE_S)
        wait_until(
            lambda: motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE,
            DEADLINE_S,
            "motion-ready",
        )
    finally:
        watch.subscriber.undeclare()

    reason = beyond_the_lease(lived, "the broadcaster")
    if reason:
        pytest.skip(reason)
    assert not watch.flaps, f"declared missing while stalled: {watch.flaps}"
