"""`motocell watch` as text, from samples fed as Zenoh would hand them over: live values from
the live keys, their age once they stop (by the heartbeat their stream announces: a resting cell
says once a second that nothing changed), the cell's last-heard age, services gone, what a first
frame waits for and that it wakes for each sample instead of polling; and waiting for a cell or
a router instead of exiting (as processes, ended with Ctrl-C)."""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import msgspec
import pytest

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.liveness import STALE_HEARTBEATS
from motocell.shared.bus.schemas import (
    CommandRequest,
    ExecutorMetrics,
    GroupState,
    LateTicks,
    MotionHolder,
    Percentiles,
    QueueState,
    RobotStatusFields,
    State,
    encode,
)
from motocell.shared.ports import free_port
from motocell.shared.protocol.constants import NotReadySubcode
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.shared.service import StopFlag
from motocell.testing.statuses import ready_status
from motocell.tools.watch import STALE_S, Watcher, add_arguments, render

KEYS = CellKeys("arm")
EVERY_SERVICE = ("controller", "executor", "broadcaster", "gateway")
T0 = 1000.0


REST_MS = 1000
"""The heartbeat of a stream while nothing can move (``shared.bus.liveness``)."""


def queue_state(depth: int, tick: int = 7, heartbeat_ms: int = 100) -> bytes:
    return encode(QueueState(1, 0, depth, 200, [0] * 8, tick, True, heartbeat_ms))


def state(*positions: float) -> bytes:
    group = GroupState(0, list(positions), [0.0] * len(positions), list(positions))
    status = RobotStatusFields(1, 0, 0, 0, 1, 2, 1)
    return encode(State(1, 7, 0, [group], status))


def executor_metrics(depths: list[int]) -> bytes:
    return encode(ExecutorMetrics(7, Percentiles(250, 12.0, 40.0, 90.0), 0, depths, True))


def alive(watcher: Watcher, *services: str) -> None:
    """Only ``services`` have a liveliness token now."""
    with watcher.lock:
        watcher.tokens(frozenset(KEYS.alive(*service.split("/")) for service in services))


def frame(watcher: Watcher, now: float) -> list[str]:
    return render(watcher, [], now).splitlines()


def line_with(lines: list[str], text: str) -> str:
    return next(line for line in lines if text in line)


def test_the_queue_depth_is_the_executors_latest_not_its_metrics_of_the_last_second() -> None:
    watcher = Watcher()
    watcher.received(KEYS.metrics("executor"), executor_metrics([0]), T0)
    watcher.received(KEYS.group_queue(0), queue_state(164, tick=900), T0 + 0.1)
    lines = frame(watcher, T0 + 0.2)
    assert line_with(lines, "group 0").strip() == "group 0  queue 164/200"
    assert line_with(lines, "executor:").startswith("  executor: tick 900   lateness (last second)")
    watcher.received(KEYS.group_queue(0), queue_state(0, tick=950), T0 + 0.3)
    assert line_with(frame(watcher, T0 + 0.3), "group 0").strip() == "group 0  queue 0/200"


def test_periods_the_clock_missed_are_shown_with_how_long_ago() -> None:
    watcher = Watcher()
    watcher.received(KEYS.metrics("executor"), executor_metrics([0]), T0)
    assert not any("clock late" in line for line in frame(watcher, T0))
    late = LateTicks(tick=812, deadline_ns=1, lateness_ns=9_400_000, periods=2, missed_total=5)
    watcher.received(KEYS.executor_late, encode(late), T0)
    assert line_with(frame(watcher, T0 + 3.2), "clock late").strip() == (
        "clock late 3 s ago: 2 period(s) missed, the worst tick 812 9.4 ms late (5 since start)"
    )


def test_positions_come_from_the_state_and_show_their_age_once_it_stops() -> None:
    watcher = Watcher()
    watcher.received(KEYS.state, state(0.5, -0.25), T0)
    watcher.received(KEYS.group_queue(0), queue_state(0), T0)
    live = line_with(frame(watcher, T0 + STALE_S / 2), "position rad")
    assert live.split("rad")[1].split() == ["+0.5000", "-0.2500"]
    stopped = line_with(frame(watcher, T0 + 4.25), "position rad")
    assert stopped.endswith("(4.2 s old)")


def test_at_rest_values_show_their_age_only_once_heartbeats_were_missed() -> None:
    # Resting: the status, the queue state and the state each come once a second, so a value
    # is up to a second old (and a little more) just before the next one.
    watcher = Watcher()
    resting = ready_status(motion_ready=False, servo_on=False, heartbeat_ms=REST_MS)
    watcher.received(KEYS.controller_status, encode(resting), T0)
    watcher.received(KEYS.group_queue(0), queue_state(0, heartbeat_ms=REST_MS), T0)
    watcher.received(KEYS.state, state(0.5), T0)
    shown = ("motion-ready", "group 0", "position rad")
    late = frame(watcher, T0 + 1.6)
    assert [line_with(late, text).endswith(" old)") for text in shown] == [False] * 3
    gone = T0 + STALE_HEARTBEATS * REST_MS / 1000 + 0.2
    stopped = frame(watcher, gone)
    assert [line_with(stopped, text).endswith("(5.2 s old)") for text in shown] == [True] * 3


def test_a_moving_cells_values_show_their_age_after_a_second() -> None:
    watcher = Watcher()
    watcher.received(KEYS.controller_status, encode(ready_status()), T0)  # 100 ms heartbeat
    watcher.received(KEYS.group_queue(0), queue_state(3), T0)
    assert line_with(frame(watcher, T0 + 1.2), "group 0").endswith("(1.2 s old)")
    assert line_with(frame(watcher, T0 + 1.2), "motion-ready").endswith("(1.2 s old)")


def test_each_cell_says_when_it_was_last_heard_from() -> None:
    watcher = Watcher()
    alive(watcher, *(f"{service}/0" for service in EVERY_SERVICE))
    assert "cell arm   nothing heard yet" in frame(watcher, T0)
    watcher.received(KEYS.controller_status, encode(ready_status()), T0)
    assert "cell arm   last heard 2.5 s ago" in frame(watcher, T0 + 2.5)


def test_services_whose_tokens_went_are_marked_and_a_cell_with_none_left_is_stopped() -> None:
    watcher = Watcher()
    alive(watcher, "controller/0", "gateway/0")
    watcher.received(KEYS.controller_status, encode(ready_status()), T0)
    alive(watcher, "controller/0")
    lines = frame(watcher, T0)
    assert "  services alive: controller/0   MISSING: gateway/0" in lines
    alive(watcher)
    assert "cell arm   STOPPED: no service alive; last heard 9.0 s ago" in frame(watcher, T0 + 9)


def test_services_the_controller_misses_are_marked_while_its_status_is_live() -> None:
    watcher = Watcher()
    alive(watcher, "controller/0")
    status = ready_status(missing_services=["interpolator/1"], motion_ready=False)
    watcher.received(KEYS.controller_status, encode(status), T0)
    assert "  services alive: controller/0   MISSING: interpolator/1" in frame(watcher, T0)
    assert "  services alive: controller/0" in frame(watcher, T0 + 2 * STALE_S)


def test_not_ready_is_shown_with_its_subcode_named() -> None:
    watcher = Watcher()
    status = ready_status(motion_ready=False, not_ready_subcode=NotReadySubcode.ESTOP)
    watcher.received(KEYS.controller_status, encode(status), T0)
    assert frame(watcher, T0)[3].startswith("  motion-ready NO: NOT_READY 5003 (E-stop)   servo")


def test_client_counts_come_from_each_ports_own_notices() -> None:
    watcher = Watcher()
    connections = KEYS.controller_cmd("connections")
    alive(watcher, "gateway/0", "broadcaster/0")
    assert line_with(frame(watcher, T0), "clients:") == "  clients: motion ?  state ?  io ?"
    watcher.received(connections, encode(CommandRequest(args=[1, -1, 0])), T0)  # the gateway
    watcher.received(connections, encode(CommandRequest(args=[-1, 3, -1])), T0)  # broadcaster
    assert line_with(frame(watcher, T0), "clients:") == "  clients: motion 1  state 3  io 0"


@pytest.mark.parametrize(
    ("holder", "words"),
    [
        (MotionHolder.NOBODY, "free"),
        (MotionHolder.MOTION_PORT, "held by the motion port's client"),
        (MotionHolder.ROS2_FACE, "held by the ROS 2 face"),
    ],
)
def test_the_gateways_notice_says_which_face_holds_trajectory_mode(
    holder: MotionHolder, words: str
) -> None:
    watcher = Watcher()
    notice = CommandRequest(args=[1, -1, 0, int(holder)])
    watcher.received(KEYS.controller_cmd("connections"), encode(notice), T0)
    line = line_with(frame(watcher, T0), "clients:")
    assert line.endswith(f"   trajectory mode: {words}")


def test_the_first_frame_waits_for_what_each_live_service_publishes() -> None:
    watcher = Watcher()
    alive(watcher, "controller/0", "executor/0", "interpolator/0", "interpolator/1")
    assert watcher.awaited() == {
        "arm": ["controller/status", "executor/metrics", "group/0/queue", "group/1/queue"]
    }
    watcher.received(KEYS.controller_status, encode(ready_status()), T0)
    watcher.received(KEYS.metrics("executor"), executor_metrics([0, 0]), T0)
    watcher.received(KEYS.group_queue(0), queue_state(0), T0)
    assert watcher.awaited() == {"arm": ["group/1/queue"]}
    watcher.received(KEYS.group_queue(1), queue_state(0), T0)
    assert watcher.awaited() == {}


def test_the_first_frame_wakes_for_the_sample_that_completes_it() -> None:
    watcher = Watcher()
    alive(watcher, "controller/0")
    arrive = threading.Thread(
        target=watcher.received, args=(KEYS.controller_status, encode(ready_status()), T0)
    )
    arrive.start()
    watcher.wait_until_complete(StopFlag(), timeout=600)  # a missed wake-up: pytest-timeout
    arrive.join()
    assert watcher.awaited() == {}


def test_the_first_frame_stops_waiting_at_a_stop() -> None:
    watcher = Watcher()
    alive(watcher, "controller/0")
    stop = StopFlag()
    threading.Thread(target=stop.set).start()
    watcher.wait_until_complete(stop, timeout=600)
    assert watcher.awaited() == {"arm": ["controller/status"]}


def test_an_undecodable_sample_is_ignored() -> None:
    watcher = Watcher()
    watcher.received(KEYS.controller_status, msgspec.msgpack.encode([1, 2]), T0)
    assert watcher.cells == {}


# -- waiting instead of exiting ---------------------------------------------------------------


def watch_until_it_says(argv: list[str], said: str, runtime: Path) -> tuple[int, str]:
    """Run ``motocell watch`` until its stderr says ``said``, then Ctrl-C it: its exit status
    and everything it wrote to stderr."""
    env = {**os.environ, RUNTIME_DIR_ENV: str(runtime)}
    command = [sys.executable, "-m", "motocell.tools.cli", "watch", *argv]
    process = subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert process.stderr is not None
        first = process.stderr.readline()  # blocks until it says something (or exits)
        process.send_signal(signal.SIGINT)
        out, rest = process.communicate(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert said in first, first + rest
    assert out == ""
    return process.returncode, first + rest


@pytest.mark.cell
def test_with_no_cell_running_watch_waits_for_one_and_says_so_once(tmp_path: Path) -> None:
    status, err = watch_until_it_says(["--count", "1"], "waiting for a cell", tmp_path)
    assert status == 0
    assert err == "motocell watch: waiting for a cell to start here (`motocell up`) ...\n"


@pytest.mark.cell
def test_with_no_router_watch_waits_for_one_and_says_so_once(tmp_path: Path) -> None:
    nowhere = f"tcp/127.0.0.1:{free_port()}"
    argv = ["--count", "1", "--zenoh-connect", nowhere]
    status, err = watch_until_it_says(argv, "waiting for a Zenoh router", tmp_path)
    assert status == 0
    assert err == f"motocell watch: waiting for a Zenoh router at {nowhere} ...\n"


@pytest.mark.cell
def test_watch_refuses_a_cell_name_not_running_at_once(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "motocell.tools.cli", "watch", "--cell", "arm"],
        env={**os.environ, RUNTIME_DIR_ENV: str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert result.returncode == 2
    assert result.stderr.startswith("motocell watch: no cell named arm is running here")


@pytest.mark.parametrize("option", [["--interval", "0"], ["--interval", "nan"], ["--count", "0"]])
def test_an_interval_or_count_that_would_spin_or_show_nothing_is_refused(
    option: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    parser = argparse.ArgumentParser(prog="motocell watch")
    add_arguments(parser)
    with pytest.raises(SystemExit) as exit_:
        parser.parse_args(option)
    assert exit_.value.code == 2
    assert option[1] in capsys.readouterr().err


def test_a_sensible_interval_and_count_are_taken() -> None:
    parser = argparse.ArgumentParser(prog="motocell watch")
    add_arguments(parser)
    args = parser.parse_args(["--interval", "0.2", "--count", "1"])
    assert (args.interval, args.count) == (0.2, 1)
