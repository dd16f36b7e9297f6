"""The services exactly as compose.yaml runs them: same commands, same cell file, Zenoh client
mode through a router. Only what must differ on a shared test machine is rewritten: the router
endpoint (a free loopback port instead of the zenohd container), paths inside the image, and
the gateway's listen address and port base."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

from shared.config import load_cell
from shared.motion.kinematics import AxisMap
from shared.ports import free_port, free_port_block
from shared.protocol.codec import ByteOrder
from shared.protocol.constants import Command, Result
from testkit.cell import wait_for_whole_cell, zenoh_router
from testkit.client import MotionClient, StateListener, smooth_move, stream_ex
from testkit.processes import alive, wait_until

pytestmark = pytest.mark.cell


def compose_commands(repo: Path, router: str, port_base: int) -> dict[str, list[str]]:
    compose = yaml.safe_load((repo / "compose.yaml").read_text())
    commands = {}
    for name, service in compose["services"].items():
        if name == "zenohd":
            assert service["image"] == "eclipse/zenoh:1.10.2"
            continue
        command = [str(part) for part in service["command"]]
        assert command[:2] == ["python", "-m"], f"{name}: runs a motocell module"
        rewritten = [sys.executable, "-m"]
        for original in command[2:]:
            part = original.replace("tcp/zenohd:7447", router)
            part = part.replace("/etc/motocell/cells/", f"{repo}/deploy/cells/")
            rewritten.append({"0.0.0.0": "127.0.0.1", "50240": str(port_base)}.get(part, part))
        assert (
            "--zenoh-mode" in rewritten
            and rewritten[rewritten.index("--zenoh-mode") + 1] == "client"
        )
        commands[name] = rewritten
    return commands


@pytest.fixture
def compose_cell(repo: Path) -> Iterator[int]:
    port_base = free_port_block(3)
    env = {**os.environ, "MOTOCELL_LOG": "WARNING"}
    processes: list[subprocess.Popen[bytes]] = []
    # As `docker compose down`: services first, the router they depend on last.
    with zenoh_router(f"tcp/127.0.0.1:{free_port()}") as router:
        try:
            for command in compose_commands(repo, router, port_base).values():
                processes.append(subprocess.Popen(command, env=env))
            yield port_base
        finally:
            stop_services(processes)


def stop_services(processes: list[subprocess.Popen[bytes]]) -> None:
    for process in reversed(processes):
        process.send_signal(signal.SIGTERM)
    for process in reversed(processes):
        try:
            process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise AssertionError(f"{process.args!r} ignored SIGTERM") from None
    wait_until(lambda: not any(alive(p.pid) for p in processes), 5.0, "services to exit")


def test_compose_services_execute_a_trajectory(repo: Path, compose_cell: int) -> None:
    cell = load_cell(repo / "deploy" / "cells" / "dual-arm-positioner.toml")
    maps = [AxisMap(group) for group in cell.groups]
    byte_order = ByteOrder(cell.byte_order)

    wait_for_whole_cell("127.0.0.1", compose_cell, byte_order)
    with (
        StateListener("127.0.0.1", compose_cell + 1, byte_order) as state,
        MotionClient("127.0.0.1", compose_cell, byte_order) as motion,
    ):
        reply = motion.command(Command.START_TRAJ_MODE)
        assert (reply.result, reply.subcode) == (Result.SUCCESS, 0)
        still = state.wait_still()
        start = {g: tuple(still.groups[g].positions[: m.axes]) for g, m in enumerate(maps)}
        goals = {g: tuple(p + 0.2 for p in start[g]) for g in start}
        result = stream_ex(motion, {g: smooth_move(start[g], goals[g], 0.5, 6) for g in start})
        assert result.points == 6, result.last_reply
        targets = {g: m.ros_to_pulses(np.array(goals[g])) for g, m in enumerate(maps)}
        state.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and all(
                    np.array_equal(
                        m.ros_to_pulses(np.array(f.groups[g].positions[: m.axes])), targets[g]
                    )
                    for g, m in enumerate(maps)
                )
            ),
            10.0,
        )
        reply = motion.command(Command.STOP_TRAJ_MODE)
        assert (reply.result, reply.subcode) == (Result.SUCCESS, 0)


def test_compose_file_runs_every_service_and_an_interpolator_per_group(repo: Path) -> None:
    commands = compose_commands(repo, "tcp/127.0.0.1:1", 1)
    modules = sorted(command[2] for command in commands.values())
    assert modules == [
        "services.broadcaster",
        "services.controller",
        "services.executor",
        "services.gateway",
        "services.interpolator",
        "services.interpolator",
        "services.interpolator",
    ]
    groups = sorted(c[c.index("--group") + 1] for c in commands.values() if "--group" in c)
    assert groups == ["0", "1", "2"]
    assert (repo / "deploy" / "Dockerfile").exists()
