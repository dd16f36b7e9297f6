"""``motocell demo`` against a running cell of three groups: every group moves, each point one
MOTO_JOINT_TRAJ_PT_FULL_EX; with the wrong byte order it stops at once and says which to use."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable

import pytest

from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.running_cell import RunningCell

pytestmark = [
    pytest.mark.cell,
    pytest.mark.parametrize("cell", ["dual-arm-positioner.toml"], indirect=True),
]

Motocell = Callable[..., subprocess.CompletedProcess[str]]


def demo_of(cell: RunningCell, *extra: str) -> list[str]:
    assert cell.config is not None
    return ["demo", "--port-base", str(cell.port_base), "--config", cell.config, *extra]


def test_every_group_moves_with_2016_and_ends_exact(cell: RunningCell, motocell: Motocell) -> None:
    done = motocell(*demo_of(cell, "--points", "6", "--duration", "0.6"), timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert "START_TRAJ_MODE -> SUCCESS (" in lines[0]
    assert "CHECK_MOTION_READY -> SUCCESS" in lines
    assert "points sent:      6 (MOTO_JOINT_TRAJ_PT_FULL_EX, 3 groups each)" in lines
    assert "final error:      0 pulse(s) (max over 15 axes)" in lines
    assert "STOP_TRAJ_MODE -> SUCCESS" in lines
    # Not in the registry the demo reads: it says why there is no following error.
    assert (
        "following error:  not measured (no cell registered on this machine has that port "
        "base, so its Zenoh bus is not known here; --cell NAME drives a cell started here)"
    ) in lines


def test_the_wrong_byte_order_is_named_at_once(cell: RunningCell, motocell: Motocell) -> None:
    # At once: the run may not reach the demo's 120 s readiness deadline.
    done = motocell(*demo_of(cell, "--byte-order", "big"), timeout=60)
    assert done.returncode == 1
    assert done.stdout == "motocell demo: the cell looks little-endian: use --byte-order little\n"
    assert done.stderr == ""


def test_the_following_error_is_reported_from_the_cells_bus(cell: RunningCell) -> None:
    """The cell runs on this machine (its registry): the demo joins its bus as an observer and
    reports every group's following error next to the final error."""
    command = [sys.executable, "-m", "motocell.tools.cli"]
    command += demo_of(cell, "--points", "6", "--duration", "0.6")
    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
    done = subprocess.run(command, capture_output=True, text=True, timeout=60, env=env, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    start = lines.index("following error:  commanded - feedback while moving, per axis (ROS order)")
    assert lines[start - 1] == "final error:      0 pulse(s) (max over 15 axes)"
    for offset, group in enumerate(cell.cell.groups):
        maximum, rms = lines[start + 1 + 2 * offset : start + 3 + 2 * offset]
        assert maximum.startswith(f"  {group.name} max: ")
        assert rms.startswith(f"  {group.name} RMS: ")
        pulses = [int(p) for p in maximum.split(": ")[1].split(" pulses")[0].split()]
        assert len(pulses) == group.axes
        assert max(pulses) > 0, "the servo lags while moving"
