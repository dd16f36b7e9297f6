"""Zenoh's threads in a running cell (``shared/bus/runtime.py``): every process, service or
router, receives on Zenoh's application thread and keeps its transmit thread."""

from __future__ import annotations

from pathlib import Path

import pytest

from motocell.testing.running_cell import RunningCell
from motocell.tools.bench.measuring import process_kinds

pytestmark = pytest.mark.cell

RECEIVING = "rx-"


def thread_names(pid: int) -> set[str]:
    return {(task / "comm").read_text().strip() for task in Path(f"/proc/{pid}/task").iterdir()}


def test_services_receive_on_zenoh_s_application_thread(cell: RunningCell) -> None:
    kinds = process_kinds(cell)
    services = {pid: kinds[pid] for pid in cell.services()}
    assert {"controller", "executor", "broadcaster", "gateway", "interpolator"} <= set(
        services.values()
    )
    for pid, kind in services.items():
        names = thread_names(pid)
        assert "app-0" in names, (kind, names)
        assert "tx-0" in names, (kind, names)
        assert not any(name.startswith(RECEIVING) for name in names), (kind, names)


def test_the_router_receives_and_accepts_on_the_application_thread(cell: RunningCell) -> None:
    names = thread_names(cell.process.pid)
    assert {"app-0", "tx-0"} <= names
    assert not any(name.startswith((RECEIVING, "acc-")) for name in names), names
