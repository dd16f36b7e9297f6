"""Figure 15's core on a floor of two real cells sharing one router: started two at once,
measured, and every process gone afterwards."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from motocell.testing.processes import alive
from motocell.tools.bench.bench_floor import ROUTER_KIND, floor
from motocell.tools.bench.measuring import cost_window

pytestmark = pytest.mark.cell


def test_a_floor_of_two_cells_starts_is_measured_and_leaves_nothing(tmp_path: Path) -> None:
    with floor(tmp_path, 2, at_once=2, shared=True) as found:
        assert sorted(c.cell.name for c in found.cells) == ["floor1", "floor2"]
        assert len({c.port_base for c in found.cells}) == 2
        assert {c.zenoh_endpoint for c in found.cells} == {found.router and found.router[1]}
        assert len(found.start_s) == 2 and found.ready_s >= max(found.start_s)
        pids = found.pids()
        assert list(pids.values()).count(ROUTER_KIND) == 1
        assert list(pids.values()).count("executor") == 2
        assert {row.pid for row in cost_window(pids, 0.2).rows} == set(pids)
    assert not [pid for pid in pids if alive(pid)]
    assert os.listdir(tmp_path)  # the cells' files, which the figure's workdir removes
