"""``python -m motocell.tools.bench.thread_cost``: a cell's cost by process and thread."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.cell

TIMEOUT_S = 120.0
"""A bound for a hang: the run takes a few seconds."""


def test_an_idle_cell_is_read_per_service_and_thread(tmp_path: Path) -> None:
    out = tmp_path / "threads.json"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "motocell.tools.bench.thread_cost",
            "idle",
            "--seconds",
            "1",
            "--windows",
            "1",
            "--json",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    [window] = json.loads(out.read_text())
    for kind in ("controller", "executor", "interpolator", "broadcaster", "gateway"):
        assert "main" in window[kind] or "python" in window[kind], kind
        for cpu, wakeups in window[kind].values():
            assert cpu >= 0 and wakeups >= 0
    assert "all processes:" in done.stdout
