"""``motocell echo`` and ``motocell hz`` on a running cell, found by name as a cell started on
this machine is; Ctrl-C ends them cleanly, and SIGTERM ends hz at once; hz says when the
cell's clock rests; every sample says it is msgpack."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.catalog import ROUTES, Op, Role
from motocell.shared.bus.session import ENCODING
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, TickLog, moving

pytestmark = pytest.mark.cell

Motocell = Callable[..., subprocess.CompletedProcess[str]]
RATE = re.compile(
    r"average rate [\d.]+ Hz  min [\d.]+ s  max [\d.]+ s  std dev [\d.]+ s  window (\d+)$"
)


@pytest.fixture(autouse=True)
def registry_of(cell: RunningCell, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(RUNTIME_DIR_ENV, str(cell.runtime_dir))


def test_echo_prints_decoded_samples_as_json_lines(cell: RunningCell, motocell: Motocell) -> None:
    result = motocell("echo", "state", "--count", "3", "--cell", cell.cell.name)
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert len(lines) == 3
    assert {line["key"] for line in lines} == {cell.keys.state}
    assert [line["payload"]["groups"][0]["group_no"] for line in lines] == [0, 0, 0]
    assert lines[0]["payload"]["seq"] < lines[1]["payload"]["seq"] < lines[2]["payload"]["seq"]


def test_echo_takes_every_group_of_a_key(cell: RunningCell, motocell: Motocell) -> None:
    result = motocell("echo", "group/*/queue", "--count", "1")
    assert result.returncode == 0, result.stderr
    (line,) = [json.loads(line) for line in result.stdout.splitlines()]
    assert line["key"] == f"{cell.keys.prefix}/group/0/queue"
    assert line["payload"]["capacity"] == 200


def test_hz_reports_the_rate_of_a_key(cell: RunningCell, motocell: Motocell) -> None:
    with moving(cell, seconds=6.0):  # ticks come every period only while the robot moves
        result = motocell("hz", "executor/tick", "--count", "2")
    assert result.returncode == 0, result.stderr
    subscribed, *reports = result.stdout.splitlines()
    assert subscribed == f"subscribed to {cell.keys.executor_tick}"
    windows = []
    for report in reports:
        key, _, shown = report.partition(": ")
        assert key == cell.keys.executor_tick
        match = RATE.fullmatch(shown)
        assert match is not None, shown
        windows.append(int(match[1]))
    assert len(windows) == 2 and 0 < windows[0] < windows[1]


def test_a_key_no_cell_publishes_is_refused_in_one_line(motocell: Motocell) -> None:
    for command in ("echo", "hz"):
        result = motocell(command, "stat")
        assert result.returncode == 2
        assert result.stderr.startswith(f"motocell {command}: no cell publishes 'stat'; did you")
        assert result.stderr.count("\n") == 1


@pytest.mark.parametrize("command", ["echo", "hz"])
def test_ctrl_c_ends_them_cleanly(command: str) -> None:
    process = subprocess.Popen(
        [sys.executable, "-m", "motocell.tools.cli", command, "executor/tick"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=os.environ.copy(),  # with the module cell's registry
    )
    try:
        assert process.stdout is not None
        # Output shows the command is running with its signal handling in place.
        first = process.stdout.readline()
        assert first, process.stderr.read() if process.stderr else ""
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 0
    assert "Traceback" not in err and "KeyboardInterrupt" not in err


STOP_DEADLINE_S = 1.0
"""From SIGTERM to the exit of an ``hz`` waiting for samples: its wait is a poll that the stop
flag's pipe ends, and what remains (closing its Zenoh session, Python's exit) took 25 ms on
an idle 2-core machine; a second bounds that on a loaded one."""


def test_hz_says_the_clock_rests_and_a_sigterm_ends_it_at_once(
    cell: RunningCell, observer: zenoh.Session
) -> None:
    ticks = TickLog(observer, cell.keys)
    try:
        wait_until(lambda: any(t.resting for t in ticks.since(0)), 10.0, "a resting tick")
    finally:
        ticks.subscriber.undeclare()
    process = subprocess.Popen(
        [sys.executable, "-m", "motocell.tools.cli", "hz", "executor/tick"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None
        subscribed, first = process.stdout.readline(), process.stdout.readline()
        assert subscribed == f"subscribed to {cell.keys.executor_tick}\n"
        # One resting tick a second: one or two by the first report, no rate from them.
        assert re.fullmatch(
            r".*: [12] samples? over [\d.]+ s: too few for a rate \(it takes 3 over 0.5 s\)"
            r"; the executor's clock rests while nothing moves: its last tick again every 1 s\n",
            first,
        ), first
        process.send_signal(signal.SIGTERM)
        process.wait(timeout=STOP_DEADLINE_S)
    finally:
        if process.poll() is None:
            process.kill()
        _, err = process.communicate()
    assert process.returncode == 0, err
    assert err == ""


@pytest.fixture
def observer(cell: RunningCell) -> Iterator[zenoh.Session]:
    session = cell.session(Role.OBSERVER)
    yield session
    session.close()


def test_every_sample_says_it_is_msgpack(cell: RunningCell, observer: zenoh.Session) -> None:
    suffixes = [
        route.suffix for route in ROUTES if route.op is Op.PUT and Role.OBSERVER in route.receivers
    ]
    steady = ["controller/status", "executor/tick", "executor/metrics", "gateway/metrics"]
    steady += ["controller/cmd/connections"]
    # A group's slot is published only when it changes (a gateway asks for it otherwise).
    steady += ["state", "group/*/queue", "group/*/metrics"]
    encodings: dict[str, set[str]] = {}
    lock = threading.Lock()

    def seen(sample: zenoh.Sample) -> None:
        with lock:
            encodings.setdefault(str(sample.key_expr), set()).add(str(sample.encoding))

    subscribers = [
        observer.declare_subscriber(f"{cell.keys.prefix}/{suffix}", seen) for suffix in suffixes
    ]
    try:
        wanted = {f"{cell.keys.prefix}/{s}".replace("*", "0") for s in steady}
        wait_until(lambda: wanted <= set(encodings), 10.0, "a sample of every steady key")
    finally:
        for subscriber in subscribers:
            subscriber.undeclare()
    with lock:
        assert encodings == {key: {str(ENCODING)} for key in encodings}


def test_the_subscriber_example_of_the_readme_works(cell: RunningCell, repo: Path) -> None:
    page = (repo / "README.md").read_text()
    (example,) = re.findall(r"```python\n(.*?)```", page, re.DOTALL)
    # The example's cell, at this cell's endpoint and credentials.
    here = example.replace("tcp/127.0.0.1:7447", cell.zenoh_endpoint).replace(
        'Path.home() / ".local/state/motocell/credentials/cell1"',
        f"Path({str(cell.credentials)!r})",
    )
    assert here.count(cell.zenoh_endpoint) == 1 and str(cell.credentials) in here
    process = subprocess.Popen(
        [sys.executable, "-c", here], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout is not None
        line = process.stdout.readline()
    finally:
        process.kill()
        _, err = process.communicate()
    assert line, err
    seq, positions = line.split(" ", 1)
    assert int(seq) > 0
    assert len(json.loads(positions)) == 6
