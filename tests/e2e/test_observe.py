"""Observing a running cell through Zenoh: a subscriber of one's own with the cell's observer
credentials, `motocell ps` and `motocell watch` (which find the cell with no flags)."""

from __future__ import annotations

import subprocess
import threading
from collections.abc import Callable

import pytest
import zenoh

from shared.bus import catalog
from shared.bus.catalog import ROUTES, Op, Role
from shared.ports import free_port
from shared.protocol.constants import Command, Result
from shared.registry import ENV as RUNTIME_DIR_ENV
from testkit.cell import RunningCell
from testkit.client import MotionClient, StateListener, smooth_move, stream
from testkit.processes import cmdline, wait_until

pytestmark = pytest.mark.cell

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
        assert f"services.{service}" in cmdline(int(row[4]))
        assert int(row[4]) in cell.children()
        assert row[6] == "0.1.0"
        assert row[7] == ("yes" if service == "executor" else "-")  # the tests run as root
    assert buses == (
        f"cell {cell.cell.name}: Zenoh {cell.zenoh_endpoint}, credentials {cell.credentials}\n"
    )


def test_ps_and_watch_fail_clearly_without_a_router(motocell: Motocell) -> None:
    nowhere = f"tcp/127.0.0.1:{free_port()}"
    for command in ("ps", "watch"):
        result = motocell(command, "--zenoh-connect", nowhere, timeout=10)
        assert result.returncode == 1
        assert result.stderr.startswith(f"motocell {command}: no Zenoh router answers at {nowhere}")
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
    assert "lateness p50" in frame and "SCHED_FIFO" in frame
    assert "clients: motion 1  state 1" in frame
    assert "services alive: broadcaster/0 controller/0 executor/0 gateway/0 interpolator/0" in frame
    position_line = next(line for line in frame.splitlines() if "position rad" in line)
    shown = [float(v) for v in position_line.split("rad")[1].split()]
    assert shown == pytest.approx(latest.groups[0].positions[:6], abs=1e-4)
