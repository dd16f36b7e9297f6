"""``motocell demo``: drive a cell the way motoman_driver does and report how it went.

START_TRAJ_MODE (robot_enable), CHECK_MOTION_READY, stream a trajectory that starts at the
current position (resending on BUSY after 5 ms), wait until the robot has arrived (feedback
at the goal and in_motion false, as joint_trajectory_action judges it, and the servos at rest),
STOP_TRAJ_MODE. A cell of one group gets JOINT_TRAJ_PT_FULL (14); on a cell of several, every
group moves and each point is one MOTO_JOINT_TRAJ_PT_FULL_EX (2016), as motoman_driver streams
such a cell. The following error (commanded - feedback while moving, max and RMS per axis)
comes from the executor's ticks on the cell's Zenoh bus, next to the final error.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zenoh

from motocell.shared import registry
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.keys import CellKeys
from motocell.shared.config import Cell, ConfigError, Group, load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.ports import port_base_argument
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import Command, Result, describe_reply
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import MotoMotionReply
from motocell.shared.registry import CellEntry
from motocell.testing.client import (
    Feedback,
    MotionClient,
    PlannedPoint,
    StateListener,
    StreamResult,
    WrongByteOrderError,
    smooth_move,
    stream,
    stream_ex,
)
from motocell.testing.following import FollowingError, following_errors
from motocell.testing.processes import connectable, wait_until
from motocell.testing.running_cell import TickLog, running_cell
from motocell.tools.cells import JoinError, Target, join

GOAL_TOLERANCE_RAD = 1e-4
READY_TIMEOUT_S = 120.0
"""How long to wait for a cell to start and its ports to answer: a loaded machine can need more
than 20 s; a cell that is not coming fails long before."""
OFFSETS = (0.4, -0.3, 0.25, 0.8, -0.5, 1.2, 0.6, 0.3)
"""How far each axis moves (rad; m for a linear axis): the other way where it would pass a
joint limit."""
LOG_LINES = 20


def add_arguments(demo: argparse.ArgumentParser) -> None:
    """The options of ``motocell demo`` (``tools.cli`` names the command)."""
    demo.description = __doc__
    demo.add_argument(
        "--cell",
        metavar="NAME",
        help="drive the cell of this name running here (`motocell up`, `motocell ps` lists "
        "them): its ports, bus and cell file from the registry of running cells",
    )
    demo.add_argument(
        "--port-base",
        type=port_base_argument,
        metavar="N",
        help="drive the running cell at this port base (a cell started elsewhere: its "
        "following error is not measured)",
    )
    demo.add_argument(
        "--host", help="the running cell's address (default: its registry entry's, or 127.0.0.1)"
    )
    demo.add_argument(
        "--config",
        help="cell TOML file: of the cell the demo starts, or of the running cell (its groups; "
        "default with --cell: the one it runs)",
    )
    demo.add_argument(
        "--byte-order",
        choices=[order.value for order in ByteOrder],
        help="the running cell's byte order (default: the cell file's: FS100 big, others little)",
    )
    demo.add_argument("--points", type=int, default=20, help="trajectory points (2 or more)")
    demo.add_argument("--duration", type=float, default=2.0, help="trajectory seconds")
    demo.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.points < 2 or not args.duration > 0:
        return _failed("--points must be 2 or more and --duration above 0", status=2)
    if args.cell is not None and args.port_base is not None:
        return _failed("--cell and --port-base each name a running cell: give one", status=2)
    try:
        if args.cell is None and args.port_base is None:
            return _started(args, load_cell(args.config))
        running = find_running(args)
    except (ConfigError, registry.NoSuchCellError) as exc:
        return _failed(str(exc), status=2)
    with ExitStack() as stack:
        bus, unmeasured = _observe(running.entry)
        if bus is not None:
            stack.callback(bus.close)
        return _reported(
            running.cell, running.host, running.port_base, args, bus=bus, unmeasured=unmeasured
        )


@dataclass(frozen=True)
class RunningTarget:
    """A running cell to drive: where its ports are, and its registry entry if it was
    started on this machine (its bus, for the following error)."""

    cell: Cell
    host: str
    port_base: int
    entry: CellEntry | None


def find_running(args: argparse.Namespace) -> RunningTarget:
    """The cell ``--cell`` names (NoSuchCellError if none of that name runs here), or the one
    at ``--port-base``: the entry registered with that port base, whatever its name, if any."""
    if args.cell is not None:
        entry: CellEntry | None = registry.find(args.cell)
    else:
        entry = next((e for e in registry.running() if e.port_base == args.port_base), None)
    if entry is None:
        return RunningTarget(
            load_cell(args.config), args.host or LOOPBACK, args.port_base, entry=None
        )
    # The cell file it runs, under the name it runs as (`motocell up --name`).
    cell = load_cell(args.config or entry.config or None, entry.name)
    return RunningTarget(cell, args.host or _reachable(entry.host), entry.port_base, entry)


LOOPBACK = "127.0.0.1"


def _reachable(host: str) -> str:
    """Where this machine reaches ports listening on ``host``: a wildcard is loopback."""
    return LOOPBACK if host in ("0.0.0.0", "::", "") else host


def _observe(entry: CellEntry | None) -> tuple[zenoh.Session | None, str]:
    """The cell's Zenoh bus as its read-only observer, or None and why not."""
    if entry is None:
        return None, (
            "no cell registered on this machine has that port base, so its Zenoh bus is not "
            "known here; --cell NAME drives a cell started here"
        )
    credentials = Path(entry.credentials) if entry.credentials else None
    target = Target(entry.zenoh_endpoint, (entry.name,), credentials, entry.pid)
    try:
        return join(target, Identity(Role.OBSERVER)), ""
    except JoinError as exc:
        return None, f"its Zenoh bus could not be joined: {exc}"


def _started(args: argparse.Namespace, cell: Cell) -> int:
    """Start a cell of ``cell``'s file, drive it, stop it."""
    print("starting a cell ...", flush=True)
    status: int | None = None
    with tempfile.TemporaryDirectory(prefix="motocell-demo-") as scratch:
        log = Path(scratch) / "cell.log"
        try:
            with running_cell(
                args.config,
                log=log,
                log_level=os.environ.get("MOTOCELL_LOG", "INFO"),
                timeout=READY_TIMEOUT_S,
                attempts=2,
            ) as started:
                print(
                    f"cell {cell.name} up on {started.host}:{started.port_base}-"
                    f"{started.port_base + 2}"
                )
                bus = started.session()
                try:
                    status = _reported(
                        cell, started.host, started.port_base, args, bus=bus, unmeasured=""
                    )
                finally:
                    bus.close()
        except (TimeoutError, ChildProcessError, OSError) as exc:
            status = _failed(f"the cell did not start: {exc}")
        except AssertionError as exc:  # the harness's stop, after the report
            if status is None:
                raise
            print(f"motocell demo: stopping the cell: {exc} (killed: nothing is left running)")
        if status != 0:
            _print_tail(log)
        return status


def _reported(
    cell: Cell,
    host: str,
    port_base: int,
    args: argparse.Namespace,
    *,
    bus: zenoh.Session | None,
    unmeasured: str,
) -> int:
    """``drive``, with what stopped it said in one line."""
    try:
        return drive(
            cell,
            host,
            port_base,
            byte_order=ByteOrder(args.byte_order or cell.byte_order),
            points=args.points,
            duration=args.duration,
            bus=bus,
            unmeasured=unmeasured,
        )
    except WrongByteOrderError as exc:
        order = exc.byte_order.value
        return _failed(f"the cell looks {order}-endian: use --byte-order {order}")
    except PeerProtocolError as exc:
        return _failed(f"the cell sent something unreadable: {exc}")
    except (TimeoutError, OSError) as exc:
        return _failed(str(exc))


def _failed(problem: str, status: int = 1) -> int:
    print(f"motocell demo: {problem}", flush=True)
    return status


def _print_tail(log: Path) -> None:
    try:
        lines = log.read_text(errors="replace").splitlines()[-LOG_LINES:]
    except OSError:
        return
    if lines:
        print("the cell's last log lines:")
        print("\n".join(f"  {line}" for line in lines))


def drive(
    cell: Cell,
    host: str,
    port_base: int,
    *,
    byte_order: ByteOrder,
    points: int,
    duration: float,
    bus: zenoh.Session | None = None,
    unmeasured: str = "no Zenoh bus was given",
) -> int:
    """``bus``: the cell's Zenoh bus, for the following error (without it, ``unmeasured``
    says why it is not reported). A status other than 0 comes with a line that says why."""
    wait_until(
        lambda: connectable(host, port_base + 1),
        READY_TIMEOUT_S,
        f"the state port {host}:{port_base + 1}",
    )
    with ExitStack() as stack:
        state = stack.enter_context(StateListener(host, port_base + 1, byte_order).start())
        first = state.wait_for(lambda f: f.status is not None, READY_TIMEOUT_S)
        if sorted(first.groups) != [group.index for group in cell.groups]:
            return _failed(
                f"the cell reports groups {sorted(first.groups)}, the cell file "
                f"{len(cell.groups)}: give the running cell's file with --config",
                status=2,
            )
        # The motion port is the gateway's, the state port the broadcaster's: either can be
        # up first.
        motion = stack.enter_context(
            MotionClient.once_listening(host, port_base, byte_order, READY_TIMEOUT_S)
        )
        ticks = None if bus is None else TickLog(bus, CellKeys(cell.name))
        if ticks is not None:
            stack.callback(ticks.subscriber.undeclare)
        started = time.monotonic()
        reply = motion.command(Command.START_TRAJ_MODE)
        _show("START_TRAJ_MODE", reply, f" ({(time.monotonic() - started) * 1e3:.0f} ms)")
        reply = motion.command(Command.CHECK_MOTION_READY)
        _show("CHECK_MOTION_READY", reply)
        if reply.result != Result.SUCCESS:
            return _failed("the cell is not ready to move (CHECK_MOTION_READY above)")
        here = state.latest()
        assert here is not None
        goals = {
            group.index: goal_within(_positions(here, group), group.joint_limits)
            for group in cell.groups
        }
        trajectories = {
            g: smooth_move(_positions(here, cell.groups[g]), goal, duration, points)
            for g, goal in goals.items()
        }
        result = _stream(motion, trajectories)
        if result.points != points:
            return _failed(f"streaming stopped at point {result.points}: {result.outcome}")
        arrived = state.wait_for(lambda f: _arrived(f, cell, goals), timeout=duration + 10.0)
        elapsed = (arrived.received_ns - result.first_sent_ns) / 1e9
        error = max(_pulse_error(arrived, group, goals[group.index]) for group in cell.groups)
        reply = motion.command(Command.STOP_TRAJ_MODE)
        axes = sum(group.axes for group in cell.groups)
        print(f"points sent:      {result.points}" + _message_kind(cell))
        print(f"BUSY replies:     {result.busy}")
        print(
            f"duration:         {elapsed:.3f} s (nominal {duration:.3f} s, "
            f"{(elapsed - duration) * 1e3:+.0f} ms incl. state sampling and the servo settling)"
        )
        print(f"final error:      {error} pulse(s) (max over {axes} axes)")
        if ticks is None:
            print(f"following error:  not measured ({unmeasured})")
        else:
            _print_following(following_errors(cell, ticks.since(0)))
        _show("STOP_TRAJ_MODE", reply)
        if error != 0:
            return _failed(f"the robot came to rest {error} pulse(s) from its goal")
        if reply.result != Result.SUCCESS:
            return _failed("STOP_TRAJ_MODE was refused (above)")
        return 0


def _print_following(errors: list[FollowingError]) -> None:
    print("following error:  commanded - feedback while moving, per axis (ROS order)")
    for found in errors:
        name = found.group.name
        linear = "linear" in found.group.model.axis_types
        unit = (
            "mm"
            if linear and found.group.axes == 1
            else "mrad (mm if linear)"
            if linear
            else "mrad"
        )
        for kind, pulses, units in (
            ("max", found.max_pulses, found.max_units),
            ("RMS", found.rms_pulses, found.rms_units),
        ):
            counts = " ".join(f"{p:.0f}" for p in pulses)
            milli = " ".join(f"{u * 1e3:.2f}" for u in units)
            print(f"  {name} {kind}: {counts} pulses = {milli} {unit}")


def _show(command: str, reply: MotoMotionReply, extra: str = "") -> None:
    print(f"{command} -> {describe_reply(reply.result, reply.subcode)}{extra}")


def _message_kind(cell: Cell) -> str:
    if len(cell.groups) == 1:
        return ""
    return f" (MOTO_JOINT_TRAJ_PT_FULL_EX, {len(cell.groups)} groups each)"


def _stream(motion: MotionClient, trajectories: dict[int, list[PlannedPoint]]) -> StreamResult:
    if len(trajectories) == 1:
        ((group, trajectory),) = trajectories.items()
        return stream(motion, trajectory, group)
    return stream_ex(motion, trajectories)


def goal_within(start: Sequence[float], limits: Sequence[tuple[float, float]]) -> tuple[float, ...]:
    """``start`` moved by OFFSETS, each axis the other way where it would pass a limit (and
    no further than the limit where the range is narrower than the move)."""
    goal = []
    for value, offset, (lower, upper) in zip(start, OFFSETS[: len(start)], limits, strict=True):
        target = value + offset if lower <= value + offset <= upper else value - offset
        goal.append(as_sent(min(max(target, lower), upper), lower, upper))
    return tuple(goal)


def as_sent(value: float, lower: float, upper: float) -> float:
    """``value`` as a point's float32 carries it, kept within [lower, upper].

    The goal the demo measures against must be the one the controller received: a float64
    goal and its float32 on the wire can round to pulses one apart (a goal within about 0.005
    pulse of a half pulse; the fourth demo run on a fresh single-arm cell is one), which once
    read as a final error of 1 pulse although the robot stood exactly where it was sent."""
    sent = np.float32(value)
    if float(sent) > upper:
        sent = np.nextafter(sent, np.float32(lower))
    elif float(sent) < lower:
        sent = np.nextafter(sent, np.float32(upper))
    return float(sent)


def _positions(feedback: Feedback, group: Group) -> tuple[float, ...]:
    return feedback.groups[group.index].positions[: group.axes]


def _arrived(feedback: Feedback, cell: Cell, goals: dict[int, tuple[float, ...]]) -> bool:
    return (
        feedback.status is not None
        and feedback.status.in_motion == 0
        # At rest: in_motion drops within 30 pulses of the command; the servo settles after.
        and not any(any(g.velocities) for g in feedback.groups.values())
        and all(
            group.index in feedback.groups
            and all(
                abs(a - b) <= GOAL_TOLERANCE_RAD
                for a, b in zip(_positions(feedback, group), goals[group.index], strict=True)
            )
            for group in cell.groups
        )
    )


def _pulse_error(feedback: Feedback, group: Group, goal: tuple[float, ...]) -> int:
    axis_map = AxisMap(group)
    final = axis_map.ros_to_pulses(np.array(_positions(feedback, group)))
    return int(np.abs(final - axis_map.ros_to_pulses(np.array(goal))).max())
