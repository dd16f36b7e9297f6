"""Figure 14's suite run: a user's test file with a cell per test, run by pytest in a process
of its own, its wall time and the CPU of everything it started."""

from __future__ import annotations

from pathlib import Path

import pytest

from motocell.tools.bench.bench_plugin import TEST_FILE, run_suite

pytestmark = pytest.mark.cell


def test_a_suite_of_two_cells_runs_and_its_cost_is_counted(tmp_path: Path) -> None:
    (tmp_path / "test_cells.py").write_text(TEST_FILE.format(tests=2))
    wall, cpu = run_suite(tmp_path, workers=1)
    # Two cells started and stopped: several processes' start-up each, all reaped and counted.
    assert wall > 0 and cpu > 0.2


def test_a_failing_suite_is_an_error_not_a_figure(tmp_path: Path) -> None:
    (tmp_path / "test_cells.py").write_text("def test_fails():\n    assert False\n")
    with pytest.raises(RuntimeError, match="the suite failed"):
        run_suite(tmp_path, workers=1)
