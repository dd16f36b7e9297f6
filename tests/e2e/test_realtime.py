"""A clock without real-time priority is loud: `motocell up` says so once, with the command that
allows it, and `motocell ps` and `motocell watch` mark it.

The cell's launcher runs without CAP_SYS_NICE in its bounding set, so as root (how these tests
run) the executor is refused SCHED_FIFO exactly as an ordinary user would be (rtprio limit 0).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing import running_cell as cell_module
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, running_cell

pytestmark = [
    pytest.mark.cell,
    pytest.mark.skipif(
        os.geteuid() != 0 or shutil.which("setpriv") is None,
        reason="needs root and setpriv to take CAP_SYS_NICE away from a cell",
    ),
]

NOTICE = "motocell WARNING the executor runs WITHOUT real-time priority"


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("realtime") / "cell.log"


@pytest.fixture(scope="module")
def cell(log: Path) -> Iterator[RunningCell]:
    with pytest.MonkeyPatch.context() as patch:
        unprivileged = ("setpriv", "--bounding-set", "-sys_nice", *cell_module.LAUNCHER)
        patch.setattr(cell_module, "LAUNCHER", unprivileged)
        with running_cell(log=log, log_level="INFO") as running:
            yield running


def test_up_says_once_that_the_clock_runs_without_sched_fifo_and_how_to_allow_it(
    cell: RunningCell, log: Path
) -> None:
    wait_until(lambda: NOTICE in log.read_text(), 10.0, "the launcher's notice")
    notices = [line for line in log.read_text().splitlines() if NOTICE in line]
    assert len(notices) == 1
    interpreter = os.path.realpath(sys.executable)
    assert f"to allow it: sudo setcap cap_sys_nice+ep {interpreter} " in notices[0]


def motocell(cell: RunningCell, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
    command = [sys.executable, "-m", "motocell.tools.cli", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=30, env=env, check=False)


def test_ps_marks_the_executor_and_says_what_allows_it(cell: RunningCell) -> None:
    result = motocell(cell, "ps")
    assert result.returncode == 0, result.stderr
    table, warning, _buses = result.stdout.split("\n\n")
    executor = next(line.split() for line in table.splitlines() if " executor " in line)
    assert executor[-1] == "NO"
    interpreter = os.path.realpath(sys.executable)
    assert warning.startswith(f"cell {cell.cell.name}: the executor runs WITHOUT real-time")
    assert f"to allow it: sudo setcap cap_sys_nice+ep {interpreter} " in warning


def test_watch_shows_the_clock_without_real_time_priority(cell: RunningCell) -> None:
    result = motocell(cell, "watch", "--count", "4", "--interval", "0.6")
    assert result.returncode == 0, result.stderr
    frame = result.stdout.split("motocell watch")[-1]
    assert "NO REAL-TIME PRIORITY" in frame
    assert "`motocell ps` says what allows it" in frame
