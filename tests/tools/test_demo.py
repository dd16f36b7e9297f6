"""``motocell demo`` without a cell: its options, and the goals it picks."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

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
    assert goal[0] == OFFSETS[0]
    assert goal[1] == pytest.approx(0.9 + OFFSETS[1])
    # Neither way fits a 0.2-wide range: as far as it goes.
    assert goal[2] == -0.1


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
