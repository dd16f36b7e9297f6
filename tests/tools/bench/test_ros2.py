"""Figure 12's pure parts: its cell file, what the subscriber got within a window, the A/B ratio."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motocell.shared.config import load_cell
from motocell.tools.bench.bench_ros2 import (
    CLIENT,
    FACE,
    PERIOD_MS,
    TOPICS,
    cell_only,
    pair_ratios,
    received_within,
    ros2_table,
)
from motocell.tools.bench.measuring import ProcessCost, Window, write_cell_file

MS = 1_000_000


def test_the_figures_cell_is_the_four_groups_with_a_face_on_its_own_domain(
    tmp_path: Path,
) -> None:
    table = ros2_table(42, "/bench7_ros2_on0")
    cell = load_cell(write_cell_file(tmp_path, "ros2_on0", tables=table))
    assert cell.ros2 is not None
    assert (cell.ros2.ros_domain_id, cell.ros2.node_namespace) == (42, "/bench7_ros2_on0")
    assert cell.ros2.update_periods.controller_status_monitor_period == PERIOD_MS
    assert len(cell.groups) + 1 == TOPICS


def record(mono_ms: list[float], ages_ms: list[float], fresh: list[int]) -> dict[str, np.ndarray]:
    """The subscriber's columns: CLOCK_REALTIME runs 1e9 s ahead of CLOCK_MONOTONIC."""
    mono = np.array([round(t * MS) for t in mono_ms], dtype=np.int64)
    received = mono + 10**18
    stamps = received - np.array([round(a * MS) for a in ages_ms], dtype=np.int64)
    return {
        "received_ns": received,
        "received_mono_ns": mono,
        "stamp_ns": stamps,
        "fresh": np.array(fresh, dtype=np.int64),
    }


def test_only_messages_within_the_window_and_stamped_with_a_tick_count_for_the_age() -> None:
    # 0 and 70 ms are outside the window; the held messages (fresh 0) are 0.5 ms old.
    got = record(
        [0, 10, 20, 30, 40, 50, 60, 70],
        [99.0, 2.0, 0.5, 4.0, 3.0, 0.5, 1.0, 99.0],
        [1, 1, 0, 1, 1, 0, 1, 1],
    )
    seen = received_within(got, 10 * MS, 60 * MS)
    assert seen.rate_hz == pytest.approx(100.0)
    assert seen.deviation_percent == pytest.approx(0.0)
    assert seen.fresh_percent == pytest.approx(100 * 4 / 6)
    p50, p99, pmax = seen.age_ms
    assert p50 == pytest.approx(2.5)
    assert pmax == pytest.approx(4.0)
    assert 3.0 < p99 <= 4.0
    assert seen.held_age_ms[0] == pytest.approx(0.5)


def test_a_slow_face_deviates_from_its_rate() -> None:
    got = record([0, 11, 22, 33, 44], [1.0] * 5, [1] * 5)
    seen = received_within(got, 0, 44 * MS)
    assert seen.deviation_percent == pytest.approx(100 * (1 - 1 / 1.1))


def test_a_window_without_a_tick_stamped_message_has_no_age() -> None:
    seen = received_within(record([0, 10, 20], [0.3, 0.3, 0.3], [0, 0, 0]), 0, 20 * MS)
    assert seen.fresh_percent == 0.0
    assert all(math.isnan(a) for a in seen.age_ms)


def cost(kind: str, cpu: float) -> ProcessCost:
    return ProcessCost(kind, 1, cpu, 100.0, 40.0, 15.0)


def test_the_ratio_compares_the_cell_but_the_face_with_the_cell_without_it() -> None:
    with_face = [
        cell_only(Window([cost("executor", 10.0), cost(FACE, 9.0), cost(CLIENT, 5.0)], 0, 1)),
        cell_only(Window([cost("executor", 12.0), cost(FACE, 9.0)], 2, 3)),
    ]
    without = [Window([cost("executor", 10.0)], 1, 2), Window([cost("executor", 8.0)], 3, 4)]
    assert pair_ratios(with_face, without) == [pytest.approx(1.0), pytest.approx(1.5)]
