"""`motocell ps` as text: the RT column, a line for every clock without real-time priority, and
a line per cell with its bus and TCP ports."""

from __future__ import annotations

import os
import socket
from pathlib import Path

from motocell.shared.bus.schemas import Listening, ServiceInfo
from motocell.shared.realtime import ELSEWHERE, fix_command
from motocell.tools.cells import Target
from motocell.tools.ps import Row, render_cells, render_clock_warnings, render_ps
from motocell.tools.realtime import fix_for

NOW_NS = 10**18


def row(
    cell: str,
    service: str,
    host: str = "robot-pc",
    pid: int = 42,
    listening: tuple[Listening, ...] = (),
) -> Row:
    started = NOW_NS - 61 * 10**9
    info = ServiceInfo(cell, service, "0", host, pid, started, "0.1.0", list(listening))
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


def test_each_cell_shows_its_bus_and_the_ports_its_services_serve() -> None:
    gateway = (Listening("motion", "127.0.0.1", 50240), Listening("io", "127.0.0.1", 50242))
    state = (Listening("state", "0.0.0.0", 50241),)
    arm = [
        row("arm", "gateway", listening=gateway),
        row("arm", "broadcaster", listening=state),
        row("arm", "controller"),
    ]
    secured = Target("tcp/127.0.0.1:7447", ("arm",), Path("/run/arm"), launcher=7)
    open_bus = Target("tcp/robot:7447", ())
    lines = render_cells([(secured, arm), (open_bus, [row("b", "broadcaster", listening=state)])])
    assert lines.splitlines() == [
        "cell arm: Zenoh tcp/127.0.0.1:7447, credentials /run/arm; "
        "TCP motion 127.0.0.1:50240, state 0.0.0.0:50241, io 127.0.0.1:50242",
        "cell b: Zenoh tcp/robot:7447, open bus; TCP motion ?, state 0.0.0.0:50241, io ?",
    ]


def test_a_registered_cell_with_no_live_service_still_gets_its_line() -> None:
    target = Target("tcp/127.0.0.1:7447", ("arm",), None, launcher=7)
    assert render_cells([(target, [])]) == (
        "cell arm: Zenoh tcp/127.0.0.1:7447, open bus; TCP motion ?, state ?, io ?"
    )
