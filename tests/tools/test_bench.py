"""``motocell bench`` writes its results where it is told (by default under the current
directory), never into the installed package."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.cell


def test_the_codec_figure_writes_its_results_to_out(tmp_path: Path) -> None:
    out = tmp_path / "results"
    command = [sys.executable, "-m", "motocell.tools.cli", "bench", "--quick", "--only", "1"]
    done = subprocess.run(
        [*command, "--out", str(out)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert sorted(path.name for path in tmp_path.iterdir()) == ["results"]
    latest = json.loads((out / "latest.json").read_text())
    assert {result["figure"] for result in latest["results"]} == {1}
    assert len(list(out.glob("*.json"))) == 2
