"""``python -m motocell.tools.bench.ros2_floor``: a bare rclpy publisher and figure 12's reader
in a process of its own; it says what a message costs, spaced and back to back."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

pytestmark = pytest.mark.cell

TIMEOUT_S = 120.0
"""A bound for a hang: the run takes about three seconds."""


def test_it_measures_a_message_spaced_and_back_to_back() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "motocell.tools.bench.ros2_floor", "--seconds", "1"],
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    said = re.fullmatch(
        r"rclpy alone, 15-joint JointState as CDR bytes to one reader: (\d+) us CPU a message "
        r"every 10 ms "
        r"\(\d+\.\d % of one core\), (\d+) us back to back\n",
        done.stdout,
    )
    assert said is not None, done.stdout
    assert int(said.group(1)) > 0 and int(said.group(2)) > 0
