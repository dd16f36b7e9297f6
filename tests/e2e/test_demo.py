"""``motocell demo`` against a running cell of three groups: every group moves, each point one
MOTO_JOINT_TRAJ_PT_FULL_EX; with the wrong byte order it stops at once and says which to use."""

from __future__ import annotations

import subprocess
from collections.abc import Callable

import pytest

from motocell.testkit.cell import RunningCell

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


def test_the_wrong_byte_order_is_named_at_once(cell: RunningCell, motocell: Motocell) -> None:
    # At once: the run may not reach the demo's 120 s readiness deadline.
    done = motocell(*demo_of(cell, "--byte-order", "big"), timeout=60)
    assert done.returncode == 1
    assert done.stdout == "motocell demo: the cell looks little-endian: use --byte-order little\n"
    assert done.stderr == ""
