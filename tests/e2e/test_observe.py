"""Observing a running cell through Zenoh: a subscriber of one's own with the cell's observer
credentials, `motocell ps` and `motocell watch` (which find the cell with no flags, and wait
for a router that is not there yet)."""

from __future__ import annotations

import itertools
import math
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import IO

import pytest
import zenoh

from motocell.shared.bus import catalog
from motocell.shared.bus.catalog import ROUTES, Op, Role
from motocell.shared.bus.schemas import Decoder, QueueState
from motocell.shared.ports import free_port
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.protocol.messages import Message
from motocell.shared.protocol.replies import traj_point
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream
from motocell.testing.processes import cmdline, wait_until
from motocell.testing.running_cell import RunningCell, running_cell, zenoh_router

pytestmark = pytest.mark.cell

SWING_S = 40.0
"""The period of the arm's swing while a snapshot is taken: 20 s out, 20 s back."""
WHOLE_CELL = ("broadcaster/0", "controller/0", "executor/0", "gateway/0", "interpolator/0")

Motocell = Callable[..., subprocess.CompletedProcess[str]]


@pytest.fixture(autouse=True)
def registry_of(cell: RunningCell, monkeypatch: pytest.MonkeyPatch) -> None:
    """The commands run here find the module's cell as they find a cell started on this
    machine: in the registry its launcher wrote."""
    monkeypatch.setenv(RUNTIME_DIR_ENV, str(cell.runtime_dir))


def test_a_plain_subscriber_sees_and_decodes_every_key_of_the_cell(
    cell: RunningCell, motion: MotionClient, state: StateListener
) -> None:
    seen: dict[str, int] = {}
    undecodable: list[str] = []
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        try:
            payload = catalog.decode(key, sample.payload.to_bytes())
        except Exception:
            # Any failure to decode is exactly what this test looks for: record, don't raise
            # on Zenoh's thread.
            payload = None
        with lock:
            seen[catalog.suffix_of(key)] = seen.get(catalog.suffix_of(key), 0) + 1
            if payload is None:
                undecodable.append(key)

    # Key by key, as the catalogue lists what an observer receives: the router refuses a
    # subscription to anything wider ("**").
    observed = [r.suffix for r in ROUTES if r.op is Op.PUT and Role.OBSERVER in r.receivers]
    bus = cell.session(Role.OBSERVER)
    subscribers = [bus.declare_subscriber(f"{cell.keys.prefix}/{s}", on_sample) for s in observed]
    try:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        start = state.wait_still().groups[0].positions[:6]
        assert stream(motion, smooth_move(start, [p + 0.1 for p in start], 0.3, 4)).points == 4
        expected = {
            "controller/status",
            "controller/cmd/connections",
            "executor/tick",
            "executor/metrics",
            "gateway/metrics",
            "state",
            "group/*/point",
            "group/*/slot",
            "group/*/increments",
            "group/*/queue",
            "group/*/metrics",
        }
        wait_until(lambda: expected <= set(seen), 5.0, f"every key (seen {sorted(seen)})")
    finally:
        for subscriber in subscribers:
            subscriber.undeclare()
        bus.close()
    assert undecodable == []


def test_ps_lists_every_live_service_with_its_details(
    cell: RunningCell, motocell: Motocell
) -> None:
    result = motocell("ps")
    assert result.returncode == 0, result.stderr
    table, buses = result.stdout.split("\n\n")
    lines = table.splitlines()
    header = ["CELL", "SERVICE", "GROUP", "HOST", "PID", "UPTIME", "VERSION", "RT"]
    assert lines[0].split() == header
    rows = {(r.split()[1], r.split()[2]): r.split() for r in lines[1:]}
    assert set(rows) == {
        ("broadcaster", "-"),
        ("controller", "-"),
        ("executor", "-"),
        ("gateway", "-"),
        ("interpolator", "0"),
    }
    for (service, _group), row in rows.items():
        assert row[0] == cell.cell.name
        assert f"motocell.services.{service}" in cmdline(int(row[4]))
        assert int(row[4]) in cell.children()
        assert row[6] == "0.1.0"
        assert row[7] == ("yes" if service == "executor" else "-")  # the tests run as root
    host, base = cell.host, cell.port_base
    assert buses == (
        f"cell {cell.cell.name}: Zenoh {cell.zenoh_endpoint}, credentials {cell.credentials}; "
        f"TCP motion {host}:{base}, state {host}:{base + 1}, io {host}:{base + 2}\n"
    )


def test_ps_fails_clearly_without_a_router(motocell: Motocell) -> None:
    """``watch`` waits for one instead (below, and tests/tools/test_watch.py)."""
    nowhere = f"tcp/127.0.0.1:{free_port()}"
    result = motocell("ps", "--zenoh-connect", nowhere, timeout=10)
    assert result.returncode == 1
    assert result.stderr.startswith(f"motocell ps: no Zenoh router answers at {nowhere}")
    assert result.stderr.count("\n") == 1, result.stderr


def test_watch_shows_status_groups_lateness_clients_and_services(
    cell: RunningCell, motion: MotionClient, state: StateListener, motocell: Motocell
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    latest = state.wait_still()
    result = motocell("watch", "--count", "4", "--interval", "0.6")
    assert result.returncode == 0, result.stderr
    frame = result.stdout.split("motocell watch")[-1]
    assert f"cell {cell.cell.name}" in frame
    assert "motion-ready YES" in frame
    assert "lateness (last second) p50" in frame and "SCHED_FIFO" in frame
    assert "clients: motion 1  state 1" in frame
    assert "services alive: broadcaster/0 controller/0 executor/0 gateway/0 interpolator/0" in frame
    position_line = next(line for line in frame.splitlines() if "position rad" in line)
    shown = [float(v) for v in position_line.split("rad")[1].split()]
    assert shown == pytest.approx(latest.groups[0].positions[:6], abs=1e-4)
    assert frame.splitlines()[2].startswith(f"cell {cell.cell.name}   last heard ")


def test_every_one_shot_snapshot_has_heard_the_whole_cell(
    cell: RunningCell, motion: MotionClient, state: StateListener, motocell: Motocell
) -> None:
    """``watch --count 1`` renders only once it has heard the cell: a snapshot taken before
    anything arrived would say ``0 cell(s)``."""
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    state.wait_still()
    for _ in range(3):
        result = motocell("watch", "--count", "1")
        assert result.returncode == 0, result.stderr
        lines = result.stdout.splitlines()
        assert lines[0].endswith("1 cell(s)")
        assert lines[2].startswith(f"cell {cell.cell.name}   last heard")
        assert "  motion-ready YES" in result.stdout
        assert "  executor: tick " in result.stdout and "lateness (last second)" in result.stdout
        assert "  clients: motion 1  state 1  io 0" in result.stdout
        assert "  group 0  queue 0/200" in lines
        assert "position rad" in result.stdout and "?" not in result.stdout


def swing(start: Sequence[float], amplitude: float) -> Iterator[Message]:
    """JOINT_TRAJ_PT_FULL points 1 s apart, without end, of a cosine swing out from ``start``
    by ``amplitude`` radians and back every SWING_S: each 1 s segment fills the executor's
    200-entry ring, which stays full for as long as the points keep coming."""
    for sequence in itertools.count():
        phase = 2 * math.pi * sequence / SWING_S
        positions = tuple(p + amplitude * (1 - math.cos(phase)) / 2 for p in start)
        speed = amplitude * math.pi / SWING_S * math.sin(phase)
        yield traj_point(0, sequence, float(sequence), positions, (speed,) * len(start))


def test_a_snapshot_while_the_arm_moves_shows_its_queue_filled(
    cell: RunningCell, motion: MotionClient, state: StateListener, motocell: Motocell
) -> None:
    """The queue depth shown is the executor's latest, not one of the last second's metrics
    (which can read 0 while the arm moves). The arm is kept moving, its ring full, until the
    snapshot is taken, however long ``watch`` takes to start."""
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    start = state.wait_still().groups[0].positions[:6]
    depths: list[int] = []
    bus = cell.session(Role.OBSERVER)
    queue = Decoder(QueueState)
    subscriber = bus.declare_subscriber(
        cell.keys.group_queue(0), lambda s: depths.append(queue.decode(s.payload.to_bytes()).depth)
    )
    done = threading.Event()

    def drive() -> None:
        for point in swing(start, 0.3):
            while motion.motion(point).result == Result.BUSY:
                if done.wait(0.005):
                    break
            if done.is_set():
                break
        motion.command(Command.STOP_TRAJ_MODE)

    driver = threading.Thread(target=drive)
    driver.start()
    try:
        wait_until(lambda: bool(depths) and depths[-1] > 100, 10.0, "the ring to fill")
        result = motocell("watch", "--count", "1")
    finally:
        done.set()
        driver.join()
        subscriber.undeclare()
        bus.close()
    assert result.returncode == 0, result.stderr
    shown = next(line for line in result.stdout.splitlines() if line.startswith("  group 0"))
    assert int(shown.split("queue ")[1].split("/")[0]) > 0, shown


class Output:
    """Lines a process writes to a pipe, read by a thread of their own as they come."""

    def __init__(self, pipe: IO[str]) -> None:
        self.lines: list[str] = []
        self._thread = threading.Thread(target=self._read, args=(pipe,))
        self._thread.start()

    def _read(self, pipe: IO[str]) -> None:
        for line in pipe:
            self.lines.append(line.rstrip("\n"))

    def last_frame(self) -> list[str]:
        lines = list(self.lines)
        starts = [i for i, line in enumerate(lines) if line.startswith("motocell watch ")]
        return lines[starts[-1] :] if starts else []

    def join(self) -> None:
        self._thread.join()


def test_watch_waits_for_a_router_then_follows_its_cell_until_it_stops() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    command = [sys.executable, "-m", "motocell.tools.cli", "watch", "--zenoh-connect", endpoint]
    watch = subprocess.Popen(
        [*command, "--interval", "0.2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert watch.stdout is not None and watch.stderr is not None
    out, err = Output(watch.stdout), Output(watch.stderr)
    try:
        said = f"motocell watch: waiting for a Zenoh router at {endpoint} ..."
        wait_until(lambda: said in err.lines, 10.0, "watch to say it waits")
        with zenoh_router(endpoint), running_cell(router=endpoint) as other:
            whole = f"  services alive: {' '.join(WHOLE_CELL)}"
            wait_until(lambda: whole in out.last_frame(), 30.0, "the cell in a frame")
            assert out.last_frame()[2].startswith(f"cell {other.cell.name}   last heard")
            other.stop()
            wait_until(
                lambda: "STOPPED: no service alive" in " ".join(out.last_frame()),
                30.0,
                "the cell shown stopped",
            )
    finally:
        watch.send_signal(signal.SIGINT)
        status = watch.wait(timeout=10)
        out.join()
        err.join()
        watch.stdout.close()
        watch.stderr.close()
    assert status == 0
    assert err.lines == [said]
