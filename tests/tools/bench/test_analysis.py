"""The benchmarks' pure parts: counting, searching, judging a run's conditions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motocell.shared.config import load_cell
from motocell.tools.bench.bench_streaming import empty_periods, slot_turnaround_ms
from motocell.tools.bench.measuring import ExecutorModes, oscillations, write_cell_file
from motocell.tools.bench.run import conditions, load_limit, load_warning, warnings
from motocell.tools.bench.stream_client import stream_capacity

# -- empty-queue periods ---------------------------------------------------------------------


def test_a_group_that_moves_every_tick_has_no_empty_period() -> None:
    numbers = np.arange(10, 20)
    moving = np.array([False, False, True, True, True, True, True, True, False, False])
    assert empty_periods(numbers, moving) == (0, 0)


def test_ticks_that_did_not_move_between_the_first_and_last_moving_tick_are_empty() -> None:
    numbers = np.arange(8)
    moving = np.array([True, False, True, False, False, True, True, False])
    assert empty_periods(numbers, moving) == (3, 0)


def test_a_tick_the_observer_never_got_is_lost_not_empty() -> None:
    numbers = np.array([1, 2, 4, 5, 9])
    moving = np.array([True, True, True, False, True])
    assert empty_periods(numbers, moving) == (1, 4)


def test_a_group_that_never_moved_is_an_error() -> None:
    with pytest.raises(RuntimeError, match="never moved"):
        empty_periods(np.arange(3), np.zeros(3, dtype=bool))


# -- slot turnaround ---------------------------------------------------------------------------


def test_turnaround_runs_from_the_success_to_the_first_slot_report_covering_the_point() -> None:
    accepted = np.array([1_000_000, 9_000_000, 0])
    points = [(0, 41), (1, 42), (2, 43)]
    # An old report (40), one covering 41, a 2 Hz repeat, then 42 and 43 together.
    taken = [(500_000, 40), (1_500_000, 41), (5_000_000, 41), (11_000_000, 43)]
    # Point 2 was never accepted (0): skipped.
    assert slot_turnaround_ms(accepted, points, taken) == [0.5, 2.0]


def test_points_without_a_covering_report_yet_are_left_out() -> None:
    assert slot_turnaround_ms(np.array([1, 2]), [(0, 5), (1, 6)], [(10, 5)]) == [9e-6]


# -- run conditions ----------------------------------------------------------------------------


def test_a_load_average_above_seventy_percent_of_the_cpus_makes_a_figure_unreliable() -> None:
    assert load_limit(2) == pytest.approx(1.4)
    assert load_warning(0.5, 1.4, 2) is None
    assert load_warning(1.5, 0.2, 2) is not None
    warning = load_warning(0.3, 2.2, 2)
    assert warning is not None
    assert "2.20 at end" in warning
    assert "unreliable" in warning


def test_the_executor_mode_is_realtime_only_if_every_sample_said_so() -> None:
    modes = ExecutorModes()
    assert modes.realtime() is None
    modes.note(True)
    assert modes.realtime() is True
    modes.note(False)
    assert modes.realtime() is False
    modes.clear()
    assert modes.realtime() is None


def entry(realtime: bool | None, unreliable: str | None) -> dict[str, object]:
    return {
        "title": "executor lateness",
        "loadavg_before": (0.5, 0.4, 0.3),
        "loadavg_after": (1.8, 0.9, 0.5),
        "executor_realtime": realtime,
        "unreliable": unreliable,
        "seconds": 63.2,
    }


def test_the_conditions_table_states_the_executor_mode_and_reliability() -> None:
    text = conditions(
        {"3": entry(True, None), "7": entry(False, "too loaded"), "1": entry(None, None)}
    )
    lines = text.splitlines()
    assert "SCHED_FIFO" in lines[2]
    assert "yes" in lines[2]
    assert "NOT SCHED_FIFO" in lines[3]
    assert "NO" in lines[3]
    assert "| -" in lines[4]


def test_warnings_name_unreliable_figures_and_an_executor_without_sched_fifo() -> None:
    found = warnings({"3": entry(True, None), "7": entry(False, "too loaded")})
    assert found == [
        "WARNING: figure 7: too loaded",
        "WARNING: figure 7: the executor ran without SCHED_FIFO "
        "(run as root, or grant CAP_SYS_NICE and an rtprio limit)",
    ]


# -- records and plans -------------------------------------------------------------------------


def test_a_stream_record_holds_every_success_and_one_busy_per_back_off() -> None:
    # 100 points over at most 2 s with a 5 ms back-off: 100 + 400 requests, and one spare.
    assert stream_capacity(100, 2.0, 0.005) == 501


def test_oscillations_stay_within_their_amplitude_and_start_where_asked() -> None:
    plans = oscillations({0: (0.5, -0.5)}, 0.2, 4.0, 8.0, 0.1)
    points = plans[0]
    assert len(points) == 81
    assert points[0].positions == (0.5, -0.5)
    offsets = np.array([p.positions for p in points]) - np.array([0.5, -0.5])
    assert np.abs(offsets).max() == pytest.approx(0.2, abs=1e-3)


def test_the_cell_file_names_extensions_only_when_asked(tmp_path: Path) -> None:
    assert "pending_points" not in write_cell_file(tmp_path, "one").read_text()
    extensions = (("pending_points", 4), ("start_buffer_periods", 3))
    text = write_cell_file(tmp_path, "four", extensions=extensions).read_text()
    assert "pending_points = 4" in text
    assert "start_buffer_periods = 3" in text
    assert load_cell(tmp_path / "four.toml").start_buffer_periods == 3
