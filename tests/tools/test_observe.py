"""`motocell ps` as text: the RT column, and a line for every clock without real-time priority."""

from __future__ import annotations

import os
import socket

from shared.bus.schemas import ServiceInfo
from shared.realtime import ELSEWHERE, fix_command
from tools.observe import Row, render_clock_warnings, render_ps
from tools.realtime import fix_for

NOW_NS = 10**18


def row(cell: str, service: str, host: str = "robot-pc", pid: int = 42) -> Row:
    info = ServiceInfo(cell, service, "0", host, pid, NOW_NS - 61 * 10**9, "0.1.0")
    return Row(cell, service, "0", info)


def test_the_rt_column_is_the_executors_alone() -> None:
    rows = [
        row("a", "controller"),
        row("a", "executor"),
        row("b", "executor"),
        Row("c", "executor", "0", None),
    ]
    lines = render_ps(rows, NOW_NS, {"a": True, "b": False}).splitlines()
    assert lines[0].split()[-1] == "RT"
    assert [line.split()[-1] for line in lines[1:]] == ["-", "yes", "NO", "?"]
    assert lines[1].split()[5] == "0:01:01"


def test_every_clock_without_real_time_priority_gets_a_line() -> None:
    rows = [row("a", "executor"), row("b", "executor"), row("b", "gateway")]
    warnings = render_clock_warnings(rows, {"a": True, "b": False}).splitlines()
    assert len(warnings) == 1
    assert warnings[0].startswith("cell b: the executor runs WITHOUT real-time priority")
    assert warnings[0].endswith(f"to allow it: {ELSEWHERE}")  # robot-pc is another host


def test_an_executor_on_this_host_is_looked_at_in_proc() -> None:
    here = ServiceInfo("a", "executor", "0", socket.gethostname(), os.getpid(), 0, "0.1.0")
    assert fix_for(here) == fix_command(os.getpid())
    assert fix_for(None) == ELSEWHERE
