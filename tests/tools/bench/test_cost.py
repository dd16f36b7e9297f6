"""Figure 10's pure parts, and the measuring module's CPU and wake-ups from /proc."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motocell.tools.bench.bench_cost import (
    MOVING,
    Measured,
    deviation_percent,
    per_tick_results,
    rate_hz,
    took_points,
)
from motocell.tools.bench.clients import StreamRecord
from motocell.tools.bench.measuring import (
    LogTail,
    ProcessCost,
    Usage,
    Window,
    alarm_codes,
    cost_by_kind,
    parse_schedstat,
    parse_switches,
    process_cost,
    refusal_text,
    total,
    usage_between,
    without_timestamp,
)

# -- /proc -------------------------------------------------------------------------------------

STATUS = """Name:\tpython
State:\tS (sleeping)
Threads:\t9
voluntary_ctxt_switches:\t1200
nonvoluntary_ctxt_switches:\t34
"""


def test_schedstat_gives_the_time_on_a_cpu_in_nanoseconds() -> None:
    assert parse_schedstat("860848 254368 12\n") == 860_848


def test_every_context_switch_counts_voluntary_or_not() -> None:
    assert parse_switches(STATUS) == 1234


def test_a_process_uses_what_its_threads_used_since_the_first_look() -> None:
    before = {1: Usage(1_000, 10), 2: Usage(5_000, 3), 3: Usage(9_000, 1)}
    # Thread 3 ended (not counted), thread 4 started since (all of it counted).
    after = {1: Usage(4_000, 12), 2: Usage(5_000, 3), 4: Usage(700, 5)}
    assert usage_between(before, after) == Usage(3_700, 7)


def test_usage_becomes_percent_of_a_core_and_wake_ups_per_second() -> None:
    cost = process_cost("executor", 7, Usage(200_000_000, 500), 20.0, rss=50.0, pss=20.0)
    assert cost.cpu_percent == pytest.approx(1.0)
    assert cost.wakeups_per_s == pytest.approx(25.0)


def cost(kind: str, cpu: float, wakeups: float = 10.0) -> ProcessCost:
    return ProcessCost(kind, 1, cpu, wakeups, 40.0, 15.0)


def test_processes_of_a_kind_add_up_and_are_counted() -> None:
    rows = [cost("executor", 1.0), cost("interpolator", 0.5), cost("interpolator", 0.25)]
    kinds = cost_by_kind(rows)
    assert list(kinds) == ["executor", "interpolator"]
    assert kinds["interpolator"].pid == 2
    assert kinds["interpolator"].cpu_percent == pytest.approx(0.75)
    everything = total("all", rows)
    assert everything.cpu_percent == pytest.approx(1.75)
    assert everything.wakeups_per_s == pytest.approx(30.0)
    assert everything.pss_mib == pytest.approx(45.0)


# -- figure 10 ---------------------------------------------------------------------------------


def test_the_state_rate_counts_frames_read_within_the_window() -> None:
    received = np.arange(0, 3_000_000_000, 10_000_000, dtype=np.int64)  # 100 Hz for 3 s
    assert rate_hz(received, 1_000_000_000, 2_000_000_000) == pytest.approx(100.0)
    assert rate_hz(received, 5_000_000_000, 6_000_000_000) == 0.0
    assert deviation_percent(99.0, 10_000_000) == pytest.approx(1.0)


def record(accepted_ns: list[int]) -> StreamRecord:
    empty = np.zeros(0, dtype=np.int64)
    return StreamRecord(
        *(empty, empty, empty),
        accepted_ns=np.array(accepted_ns, dtype=np.int64),
        probe_rtt_ns=empty,
        probe_index=empty,
        points=len(accepted_ns),
        busy=0,
        first_sent_ns=0,
        last_accepted_ns=max(accepted_ns, default=0),
        dropped=0,
        error="",
    )


def test_a_moving_cell_took_points_in_every_window_it_moved() -> None:
    windows = [Window([], 0, 100), Window([], 100, 200), Window([], 200, 300)]
    assert took_points(record([50, 150, 0]), windows) == [True, True, False]


def test_the_moving_executor_s_cpu_per_tick_counts_every_thread_and_its_clock_apart() -> None:
    windows = [Window([cost("executor", 10.0), cost("gateway", 3.0)], 0, 1)]
    found = Measured({MOVING.label: windows}, [], [], [], 4_000_000, [0.075])
    every_thread, clock = per_tick_results(found)
    assert every_thread["median"] == pytest.approx(400.0)  # 10 % of 4 ms
    assert clock["median"] == pytest.approx(300.0)  # 7.5 % of 4 ms
    assert "all its threads" in every_thread["name"] and "clock thread" in clock["name"]


# -- the cell's log ------------------------------------------------------------------------------


def test_a_log_tail_gives_the_lines_written_since_the_last_look(tmp_path: Path) -> None:
    log = tmp_path / "cell.log"
    log.write_text("2026-11-26 04:13:15,000 gateway/0[1] INFO up\n")
    tail = LogTail(log)
    with log.open("a") as out:
        out.write(
            "2026-11-26 04:13:15,926 executor/0[1635] ERROR no controller status heard; "
            "stopping motion (alarm 4200)\n"
            "2026-11-26 04:13:16,000 gateway/0[1] INFO nothing\n"
        )
    alarms = tail.lines("alarm")
    assert alarms == [
        "executor/0[1635] ERROR no controller status heard; stopping motion (alarm 4200)"
    ]
    assert alarm_codes(alarms) == [4200]
    assert tail.lines() == []
    assert LogTail(tmp_path / "none.log").lines() == []


def test_a_refusal_names_the_last_alarms_logged() -> None:
    assert refusal_text("point 0 refused", []) == "point 0 refused"
    text = refusal_text("point 0 refused", ["a (alarm 1)", "b (alarm 2)", "c", "d"], most=2)
    assert text == "point 0 refused; the cell's log: c | d"
    assert without_timestamp("no timestamp here") == "no timestamp here"
