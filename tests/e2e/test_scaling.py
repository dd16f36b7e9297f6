"""Several controllers on one Zenoh network, and a group's interpolator on another host."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import numpy as np
import pytest
import zenoh

from motocell.shared.bus.session import open_session
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream, stream_ex
from motocell.testing.processes import alive, connectable, wait_until
from motocell.testing.running_cell import RunningCell, router_on_free_port, running_cell
from tests.leftovers import suite_tag

pytestmark = pytest.mark.cell


def named_cell(source: Path, tmp_path: Path, name: str) -> str:
    text = source.read_text()
    lines = [line for line in text.splitlines() if not line.startswith("name =")]
    path = tmp_path / f"{name}.toml"
    path.write_text(f'name = "{name}"\n' + "\n".join(lines) + "\n")
    return str(path)


def run_to(cell: RunningCell, offset: float, results: dict[str, bool]) -> None:
    axis_map = AxisMap(cell.cell.groups[0])
    with cell.motion() as motion, cell.state() as state:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        start = state.wait_still().groups[0].positions[:6]
        goal = tuple(p + offset for p in start)
        ok = stream(motion, smooth_move(start, goal, 1.0, 8)).points == 8
        target = axis_map.ros_to_pulses(np.array(goal))
        state.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and np.array_equal(
                    axis_map.ros_to_pulses(np.array(f.groups[0].positions[:6])), target
                )
            ),
            10.0,
        )
        results[cell.cell.name] = ok


def test_two_cells_on_one_network_are_isolated_and_one_observer_sees_both(
    repo: Path, tmp_path: Path
) -> None:
    single_arm = repo / "shared" / "cells" / "single-arm.toml"
    with ExitStack() as stack:
        endpoint = stack.enter_context(router_on_free_port())
        observer = open_session("client", [endpoint])
        stack.callback(observer.close)
        seen: set[str] = set()
        lock = threading.Lock()

        def watch(sample: zenoh.Sample) -> None:
            with lock:
                seen.add(str(sample.key_expr).split("/")[1])

        stack.callback(observer.declare_subscriber("**", watch).undeclare)
        cells = [
            stack.enter_context(
                running_cell(named_cell(single_arm, tmp_path, name), router=endpoint)
            )
            for name in ("left", "right")
        ]
        results: dict[str, bool] = {}
        threads = [
            threading.Thread(target=run_to, args=(cell, offset, results))
            for cell, offset in zip(cells, (0.3, -0.4), strict=True)
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(timeout=30)
        assert results == {"left": True, "right": True}
        wait_until(lambda: {"left", "right"} <= seen, 5.0, "the observer to see both cells")


@contextmanager
def other_host() -> Iterator[tuple[str, str, str]]:
    """A network namespace joined to this one by a veth pair: (namespace, our address, its
    address). Everything is this test's own, named as the suite's (tests/leftovers.py); it is
    all deleted afterwards, or by the next run if this one is killed first."""
    tag = suite_tag()
    namespace, host_side, ns_side = f"{tag}-host", f"{tag}h", f"{tag}n"
    octet = os.getpid() % 250 + 1
    ours, theirs = f"10.213.{octet}.1", f"10.213.{octet}.2"
    commands = [
        ["ip", "netns", "add", namespace],
        ["ip", "link", "add", host_side, "type", "veth", "peer", "name", ns_side],
        ["ip", "link", "set", ns_side, "netns", namespace],
        ["ip", "addr", "add", f"{ours}/30", "dev", host_side],
        ["ip", "link", "set", host_side, "up"],
        ["ip", "netns", "exec", namespace, "ip", "addr", "add", f"{theirs}/30", "dev", ns_side],
        ["ip", "netns", "exec", namespace, "ip", "link", "set", ns_side, "up"],
        ["ip", "netns", "exec", namespace, "ip", "link", "set", "lo", "up"],
    ]
    try:
        for command in commands:
            subprocess.run(command, check=True, capture_output=True)
        yield namespace, ours, theirs
    finally:
        subprocess.run(["ip", "netns", "delete", namespace], capture_output=True, check=False)
        subprocess.run(["ip", "link", "delete", host_side], capture_output=True, check=False)


def test_a_groups_interpolator_on_another_host_through_a_router(
    repo: Path, network_namespaces: None
) -> None:
    config = str(repo / "shared" / "cells" / "dual-arm-positioner.toml")
    with ExitStack() as stack:
        namespace, ours, _theirs = stack.enter_context(other_host())
        endpoint = stack.enter_context(router_on_free_port(ours))
        cell = stack.enter_context(running_cell(config, router=endpoint, skip=["interpolator/1"]))
        remote_command = [
            "ip",
            "netns",
            "exec",
            namespace,
            sys.executable,
            "-m",
            "motocell.services.interpolator",
            "--group",
            "1",
            "--config",
            config,
            "--zenoh-connect",
            endpoint,
        ]
        env = {**os.environ, "MOTOCELL_LOG": "WARNING"}

        def start_remote() -> subprocess.Popen[bytes]:
            process = subprocess.Popen(remote_command, env=env)
            stack.callback(_stop, process)
            return process

        maps = [AxisMap(group) for group in cell.cell.groups]
        wait_until(
            lambda: all(connectable(cell.host, cell.port_base + i) for i in (0, 1)),
            30.0,
            "the motion port (gateway) and the state port (broadcaster)",
        )
        with cell.motion() as motion, cell.state() as state:
            state.wait_for(lambda f: f.status is not None and f.status.drives_powered != -1, 30)
            reply = motion.command(Command.START_TRAJ_MODE)
            assert (reply.result, reply.subcode) == (
                Result.NOT_READY,
                NotReadySubcode.INC_MOVE_ERROR,
            ), "R2's interpolator is not running anywhere yet"

            remote = start_remote()
            wait_until(
                lambda: motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS,
                30.0,
                "the cell to accept the remote interpolator",
            )
            move_all(motion, state, maps, 0.1)

            remote.send_signal(signal.SIGKILL)
            wait_until(
                lambda: (
                    motion.command(Command.CHECK_MOTION_READY).subcode
                    == NotReadySubcode.INC_MOVE_ERROR
                ),
                5.0,
                "NOT_READY while the remote interpolator is gone",
            )
            start_remote()
            wait_until(
                lambda: motion.command(Command.CHECK_MOTION_READY).result == Result.TRUE,
                30.0,
                "the restarted remote interpolator",
            )
            move_all(motion, state, maps, -0.1)


def move_all(
    motion: MotionClient, state: StateListener, maps: list[AxisMap], offset: float
) -> None:
    still = state.wait_still()
    start = {g: tuple(still.groups[g].positions[: maps[g].axes]) for g in range(3)}
    goals = {g: tuple(p + offset for p in start[g]) for g in range(3)}
    plans = {g: smooth_move(start[g], goals[g], 0.5, 5) for g in range(3)}
    assert stream_ex(motion, plans).points == 5
    targets = {g: maps[g].ros_to_pulses(np.array(goals[g])) for g in range(3)}
    state.wait_for(
        lambda f: (
            f.status is not None
            and f.status.in_motion == 0
            and all(
                np.array_equal(
                    maps[g].ros_to_pulses(np.array(f.groups[g].positions[: maps[g].axes])),
                    targets[g],
                )
                for g in range(3)
            )
        ),
        10.0,
    )


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    assert not alive(process.pid)
