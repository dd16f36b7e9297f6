"""``motocell demo`` without a cell: its options, and the goals it picks."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from motocell.shared.config import load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.tools import demo
from motocell.tools.demo import OFFSETS, goal_within

LIMITS = ((-1.0, 1.0), (-1.0, 1.0), (-0.1, 0.1))


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    demo.add_arguments(parser)
    return parser.parse_args(argv)


def test_byte_order_is_an_option() -> None:
    args = parse("--port-base", "50240", "--byte-order", "big")
    assert (args.port_base, args.byte_order) == (50240, "big")


def test_goals_move_away_from_the_limits() -> None:
    goal = goal_within((0.0, 0.9, 0.0), LIMITS)
    assert goal[0] == pytest.approx(OFFSETS[0])
    assert goal[1] == pytest.approx(0.9 + OFFSETS[1])
    # Neither way fits a 0.2-wide range: as far as it goes, on the inside of the limit.
    assert -0.1 <= goal[2] == pytest.approx(-0.1)


def test_goals_are_what_a_points_float32_carries() -> None:
    """The goal the demo measures against is the one the controller receives."""
    goal = goal_within((0.0, 0.9, 0.0), LIMITS)
    assert all(float(np.float32(value)) == value for value in goal)


def test_the_goal_of_the_fourth_run_on_a_fresh_arm_is_the_pulse_it_was_sent() -> None:
    """Found by demo runs back to back: one axis of the fourth goal from the arm's initial
    position lies within 0.01 pulse of a half pulse, so its float64 and its float32 round to
    pulses one apart; the robot stood on the float32's pulse and the demo measured 1 pulse."""
    cell = load_cell(None)
    (group,) = cell.groups
    axis_map = AxisMap(group)
    here = tuple(group.initial_position)
    for _ in range(4):
        goal = goal_within(here, group.joint_limits)
        sent = np.array(goal, dtype=np.float32).astype(np.float64)
        assert (axis_map.ros_to_pulses(sent) == axis_map.ros_to_pulses(np.array(goal))).all()
        reached = axis_map.pulses_to_ros(axis_map.ros_to_pulses(sent)).astype(np.float32)
        here = tuple(float(value) for value in reached)  # what the state port reports


def test_a_goal_past_the_upper_limit_turns_back() -> None:
    goal = goal_within((0.8, 0.0, 0.0), LIMITS)
    assert goal[0] == pytest.approx(0.8 - OFFSETS[0])


@pytest.mark.parametrize("argv", [["--points", "1"], ["--duration", "0"]])
def test_a_trajectory_that_cannot_be_made_is_refused_in_one_line(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    args = parse("--port-base", "1", *argv)
    assert args.run(args) == 2
    assert capsys.readouterr().out.count("\n") == 1


def test_a_bad_cell_file_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    args = parse("--config", "/nonexistent/cell.toml")
    assert args.run(args) == 2
    out = capsys.readouterr().out
    assert out.startswith("motocell demo: /nonexistent/cell.toml: cannot read")


@pytest.mark.parametrize("port_base", ["0", "65534"])
def test_a_port_base_without_three_ports_is_refused(
    port_base: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # 0 is no port: refused like any other out of range, never read as "start a cell".
    with pytest.raises(SystemExit) as exited:
        parse("--port-base", port_base)
    assert exited.value.code == 2
    assert "must lie within 1-65535" in capsys.readouterr().err


def test_a_cell_and_a_port_base_together_are_refused_in_one_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    args = parse("--cell", "arm", "--port-base", "50240")
    assert args.run(args) == 2
    assert capsys.readouterr().out == (
        "motocell demo: --cell and --port-base each name a running cell: give one\n"
    )


def test_a_cell_not_running_here_is_one_line_naming_those_that_are(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv(RUNTIME_DIR_ENV, str(tmp_path))
    args = parse("--cell", "arm")
    assert args.run(args) == 2
    assert capsys.readouterr().out == (
        "motocell demo: no cell named arm is running here (running: none)\n"
    )


def test_a_slow_stop_after_the_report_is_one_line_not_a_traceback(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The harness kills a launcher that outlives its stop deadline and says so with an
    AssertionError; after a report the demo says it in one line and keeps the report's
    status."""

    class Started:
        host, port_base = "127.0.0.1", 50240

        def session(self) -> Bus:
            return Bus()

    class Bus:
        def close(self) -> None:
            """Nothing was opened."""

    @contextmanager
    def slow_to_stop(config: object, **_: object) -> Iterator[Started]:
        yield Started()
        raise AssertionError("the launcher did not stop within 10.0 s of SIGTERM")

    def report(*_: object, **__: object) -> int:
        print("final error:      0 pulse(s) (max over 6 axes)")
        return 0

    monkeypatch.setattr(demo, "running_cell", slow_to_stop)
    monkeypatch.setattr(demo, "_reported", report)
    args = parse()
    assert args.run(args) == 0
    assert capsys.readouterr().out.splitlines()[-1] == (
        "motocell demo: stopping the cell: the launcher did not stop within 10.0 s of SIGTERM "
        "(killed: nothing is left running)"
    )


def test_a_cell_that_does_not_start_shows_its_last_log_lines(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    @contextmanager
    def never_ready(config: object, *, log: Path, **_: object) -> Iterator[None]:
        log.write_text("".join(f"line {n}\n" for n in range(30)))
        raise TimeoutError("timed out after 120.0 s waiting for every service to start")
        yield

    monkeypatch.setattr(demo, "running_cell", never_ready)
    args = parse()
    assert args.run(args) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == [
        "starting a cell ...",
        "motocell demo: the cell did not start: timed out after 120.0 s waiting for every "
        "service to start",
        "the cell's last log lines:",
    ]
    assert out[3:] == [f"  line {n}" for n in range(10, 30)]
