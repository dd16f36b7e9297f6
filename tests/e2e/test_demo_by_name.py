"""``motocell demo --cell NAME`` against a cell started with ``motocell up --name``: the demo
finds it by the name it runs under, not its file's, measures its following error, and run after
run finds the robot exactly at the goal it sent."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from motocell.shared.config import load_cell
from tests.e2e.test_start_and_stop import run_to_the_end, up_on_free_ports

pytestmark = pytest.mark.cell

NAME = "renamed"


def test_demo_finds_a_renamed_cell_by_its_name_and_measures_its_following_error(
    tmp_path: Path,
) -> None:
    assert load_cell(None).name != NAME
    renamed = up_on_free_ports(tmp_path, "--name", NAME, until=f"cell {NAME} ready: ", auto=True)
    with renamed as (up, _):
        options = ("--cell", NAME, "--points", "6", "--duration", "0.6")
        # The fourth run from the initial position has a goal whose float64 and float32 round
        # to pulses one apart: each run must come to rest exactly on the goal it sent.
        runs = [run_to_the_end(tmp_path, "demo", *options) for _ in range(4)]
        up.process.send_signal(signal.SIGTERM)
        assert up.finish() == 0
    for status, output in runs:
        assert status == 0, output
        assert "final error:      0 pulse(s) (max over 6 axes)" in output.splitlines()
    lines = runs[0][1].splitlines()
    start = lines.index("following error:  commanded - feedback while moving, per axis (ROS order)")
    assert lines[start + 1].startswith("  R1 max: ")
