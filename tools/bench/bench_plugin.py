"""Figure 14: a user's test suite with a cell per test, through the pytest plugin.

    python -m motocell.tools.bench.run --only 14 [--quick]

Writes a test file of ``TESTS`` tests (quick: ``QUICK_TESTS``), each asking for its own
``motocell_cell`` (a whole single-arm cell, started and stopped for that test alone) and
reading its positions, and runs it with pytest in a process of its own, as a user runs their
suite: serially, and with ``-n 2`` where pytest-xdist is installed (it is not one of motocell's
dependencies). Wall time from the spawn to pytest's exit, and the CPU of pytest and everything
it started (every cell's processes are reaped within the run, so the children's rusage holds
them all). Goal (issue 33): 50 tests serially in <= 60 s on the project's 2-core machine, and
faster under ``-n 2``. Runs of 3.
"""

from __future__ import annotations

import importlib.util
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from motocell.tools.bench.measuring import figure_result, workdir

FIGURE = 14
RUNS = 3
TESTS = 50
QUICK_TESTS = 10
GOAL_S = 60.0
"""For ``TESTS`` tests serially."""
TIMEOUT_S = 900.0
"""A bound for a hang: 50 cells at a load of 20 took minutes."""

TEST_FILE = """
import pytest


@pytest.mark.parametrize("index", range({tests}))
def test_a_cell_of_its_own(motocell_cell, index):
    assert len(motocell_cell.positions()) == 6
"""


def run_suite(directory: Path, workers: int) -> tuple[float, float]:
    """Wall and CPU seconds of one pytest run of the file in ``directory``."""
    options = ["-n", str(workers)] if workers > 1 else []
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *options]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.monotonic()
    done = subprocess.run(
        [*command, str(directory)],
        cwd=directory,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    wall = time.monotonic() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"the suite failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def run(quick: bool) -> list[dict[str, Any]]:
    tests = QUICK_TESTS if quick else TESTS
    worker_counts = [1, 2] if importlib.util.find_spec("xdist") is not None else [1]
    rows: list[dict[str, Any]] = []
    with workdir() as directory:
        (directory / "test_cells.py").write_text(TEST_FILE.format(tests=tests))
        for workers in worker_counts:
            measured = [run_suite(directory, workers) for _ in range(RUNS)]
            walls, cpus = [m[0] for m in measured], [m[1] for m in measured]
            how = "serially" if workers == 1 else f"-n {workers}"
            goal = ("<=", GOAL_S * tests / TESTS) if workers == 1 else None
            rows += [
                figure_result(
                    FIGURE, f"{tests} tests, a cell each, {how}: wall", "s", walls, goal=goal
                ),
                figure_result(FIGURE, "  their CPU, pytest and every cell", "s", cpus),
                figure_result(FIGURE, "  per test", "s", [wall / tests for wall in walls]),
            ]
    if len(worker_counts) == 1:
        rows.append(
            figure_result(FIGURE, "-n 2: not measured (pytest-xdist is not installed)", "", [])
        )
    return rows
