"""``motocell demo``: drive a cell the way motoman_driver does and report how it went.

START_TRAJ_MODE (robot_enable), CHECK_MOTION_READY, stream a trajectory that starts at the
current position (resending on BUSY after 5 ms), wait until the robot has arrived (feedback
at the goal and in_motion false, as joint_trajectory_action judges it), STOP_TRAJ_MODE.
"""

from __future__ import annotations

import argparse
import os
import time
from contextlib import ExitStack

import numpy as np

from shared.config import Cell, load_cell
from shared.motion.kinematics import AxisMap
from shared.protocol.codec import ByteOrder
from shared.protocol.constants import Command, Result
from testkit.cell import running_cell
from testkit.client import MotionClient, StateListener, smooth_move, stream
from testkit.processes import connectable, wait_until

GOAL_TOLERANCE_RAD = 1e-4
CONNECT_TIMEOUT_S = 20.0


def drive(cell: Cell, host: str, port_base: int, points: int, duration: float) -> int:
    byte_order = ByteOrder(cell.byte_order)
    axis_map = AxisMap(cell.groups[0])
    axes = axis_map.axes
    wait_until(lambda: connectable(host, port_base + 1), CONNECT_TIMEOUT_S, "the state port")
    with ExitStack() as stack:
        state = stack.enter_context(StateListener(host, port_base + 1, byte_order))
        state.wait_for(lambda f: f.status is not None, CONNECT_TIMEOUT_S)
        motion = stack.enter_context(MotionClient(host, port_base, byte_order))
        started = time.monotonic()
        reply = motion.command(Command.START_TRAJ_MODE)
        print(
            f"START_TRAJ_MODE -> {Result(reply.result).name} {reply.subcode} "
            f"({(time.monotonic() - started) * 1e3:.0f} ms)"
        )
        reply = motion.command(Command.CHECK_MOTION_READY)
        print(f"CHECK_MOTION_READY -> {Result(reply.result).name} {reply.subcode}")
        if reply.result != Result.SUCCESS:
            return 1
        latest = state.latest()
        assert latest is not None
        start = latest.groups[0].positions[:axes]
        offsets = (0.4, -0.3, 0.25, 0.8, -0.5, 1.2, 0.6, 0.3)
        goal = tuple(p + offsets[i] for i, p in enumerate(start))
        trajectory = smooth_move(start, goal, duration, points)
        result = stream(motion, trajectory)
        if result.points != len(trajectory):
            print(f"streaming stopped at point {result.points}: {result.last_reply}")
            return 1
        arrived = state.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and all(
                    abs(a - b) <= GOAL_TOLERANCE_RAD
                    for a, b in zip(f.groups[0].positions[:axes], goal, strict=True)
                )
            ),
            timeout=duration + 10.0,
        )
        elapsed = (arrived.received_ns - result.first_sent_ns) / 1e9
        final = np.array(arrived.groups[0].positions[:axes])
        error = np.abs(axis_map.ros_to_pulses(final) - axis_map.ros_to_pulses(np.array(goal)))
        reply = motion.command(Command.STOP_TRAJ_MODE)
        print(f"points sent:      {result.points}")
        print(f"BUSY replies:     {result.busy}")
        print(
            f"duration:         {elapsed:.3f} s (nominal {duration:.3f} s, "
            f"+{(elapsed - duration) * 1e3:.0f} ms incl. state sampling)"
        )
        print(f"final error:      {int(error.max())} pulse(s) (max over {axes} axes)")
        print(f"STOP_TRAJ_MODE -> {Result(reply.result).name} {reply.subcode}")
        return 0 if reply.result == Result.SUCCESS and error.max() == 0 else 1


def run(args: argparse.Namespace) -> int:
    cell = load_cell(args.config)
    if args.port_base:
        return drive(cell, args.host, args.port_base, args.points, args.duration)
    print("starting a cell ...", flush=True)
    log_level = os.environ.get("MOTOCELL_LOG", "WARNING")
    with running_cell(args.config, log_level=log_level) as started:
        print(f"cell {cell.name} up on {started.host}:{started.port_base}-{started.port_base + 2}")
        return drive(cell, started.host, started.port_base, args.points, args.duration)
