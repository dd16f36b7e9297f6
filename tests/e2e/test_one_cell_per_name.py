"""One cell per name, one process per service name (docs/topology.md).

A second ``motocell up`` with a running cell's name is refused by the registry, a second
service of a running cell by its name claim on the bus; neither disturbs the running cell. Of
two launchers started at the same instant exactly one runs.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from motocell.shared.ports import free_port_besides, free_port_block
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import LAUNCHER, RunningCell, wait_for_whole_cell
from tests.launched import launched, named

pytestmark = pytest.mark.cell

REFUSAL_TIMEOUT_S = 20.0
"""A deadline for a hang, not a performance bound: a refusal takes about a second."""


def launcher(*extra: str) -> list[str]:
    """A launcher's command on ports picked free, for a start refused for its name (the name is
    checked before the ports: a port taken meanwhile cannot change the answer)."""
    port_base = free_port_block(3)
    listen = f"tcp/127.0.0.1:{free_port_besides(range(port_base, port_base + 3))}"
    return [*LAUNCHER, "--port-base", str(port_base), "--zenoh-listen", listen, *extra]


def env_for(runtime_dir: Path) -> dict[str, str]:
    return {**os.environ, RUNTIME_DIR_ENV: str(runtime_dir), "MOTOCELL_LOG": "WARNING"}


def still_moves(motion: MotionClient, state: StateListener) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = state.wait_still().groups[0].positions[:6]
    result = stream(motion, smooth_move(start, [p + 0.05 for p in start], 0.3, 4))
    assert result.points == 4, result.last_reply


def test_a_second_cell_of_the_same_name_is_refused_naming_the_first(
    cell: RunningCell, motion: MotionClient, state: StateListener
) -> None:
    result = subprocess.run(
        launcher(),
        env=env_for(cell.runtime_dir),
        capture_output=True,
        text=True,
        timeout=REFUSAL_TIMEOUT_S,
        check=False,
    )
    assert result.returncode == 2, result.stderr
    assert f"a cell named {cell.cell.name} is already running" in result.stderr
    assert f"pid {cell.process.pid}" in result.stderr
    assert f"ports 127.0.0.1:{cell.port_base}-{cell.port_base + 2}" in result.stderr
    assert "another --name" in result.stderr
    assert "Traceback" not in result.stderr
    still_moves(motion, state)


def test_another_name_for_the_same_file_runs_beside_it(cell: RunningCell, tmp_path: Path) -> None:
    process, port_base = launched(named("beside"), env_for(cell.runtime_dir), tmp_path / "up.log")
    try:
        wait_for_whole_cell("127.0.0.1", port_base, cell.byte_order, REFUSAL_TIMEOUT_S)
        with MotionClient("127.0.0.1", port_base, cell.byte_order) as motion:
            assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    finally:
        process.terminate()
        process.wait(timeout=10)


def test_a_second_gateway_on_the_cells_bus_is_refused(
    cell: RunningCell, motion: MotionClient, state: StateListener
) -> None:
    assert cell.credentials is not None
    command = [
        *(
            sys.executable,
            "-m",
            "motocell.services.gateway",
            "--port-base",
            str(free_port_block(3)),
        ),
        *("--zenoh-connect", cell.zenoh_endpoint, "--credentials", str(cell.credentials)),
    ]
    result = subprocess.run(
        command, capture_output=True, text=True, timeout=REFUSAL_TIMEOUT_S, check=False
    )
    assert result.returncode == 2, result.stderr
    gateway_pid = next(iter(cell.service_pids("gateway")))
    assert f"a gateway of cell {cell.cell.name} is already running" in result.stderr
    assert f"pid {gateway_pid}" in result.stderr
    assert "Traceback" not in result.stderr
    still_moves(motion, state)


@pytest.mark.parametrize("attempt", range(3))
def test_of_two_cells_started_together_exactly_one_runs(tmp_path: Path, attempt: int) -> None:
    runtime_dir = tmp_path / "runtime"
    commands = [launcher(), launcher()]
    logs = [tmp_path / f"launcher{index}.log" for index in range(2)]
    processes = []
    for command, log in zip(commands, logs, strict=True):
        with log.open("w") as out:
            processes.append(
                subprocess.Popen(command, env=env_for(runtime_dir), stderr=out, stdout=out)
            )
    try:
        wait_until(
            lambda: any(p.poll() is not None for p in processes),
            REFUSAL_TIMEOUT_S,
            "one of the two launchers to give up",
        )
        loser = next(index for index, p in enumerate(processes) if p.poll() is not None)
        assert processes[loser].returncode == 2
        assert "already running" in logs[loser].read_text()
        winner = 1 - loser
        port_base = int(commands[winner][commands[winner].index("--port-base") + 1])
        wait_for_whole_cell("127.0.0.1", port_base, ByteOrder.LITTLE, REFUSAL_TIMEOUT_S)
        assert processes[winner].poll() is None, logs[winner].read_text()
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            process.wait(timeout=10)
