"""Zenoh's threads in a running cell: an interpolator receives on Zenoh's application thread
(``services/interpolator/__main__.py`` ``ZENOH_RUNTIME``), a service with Zenoh's defaults on
two receive workers of its own."""

from __future__ import annotations

from pathlib import Path

import pytest

from motocell.bench.harness import process_kinds
from motocell.testkit.cell import RunningCell

pytestmark = pytest.mark.cell


def thread_names(pid: int) -> set[str]:
    return {(task / "comm").read_text().strip() for task in Path(f"/proc/{pid}/task").iterdir()}


def test_an_interpolator_receives_on_zenoh_s_application_thread(cell: RunningCell) -> None:
    kinds = process_kinds(cell)
    interpolators = [pid for pid, kind in kinds.items() if kind == "interpolator"]
    assert interpolators
    for pid in interpolators:
        names = thread_names(pid)
        assert "app-0" in names
        assert not any(name.startswith("rx-") for name in names), names
    executor = next(pid for pid, kind in kinds.items() if kind == "executor")
    assert {"rx-0", "rx-1"} <= thread_names(executor)
