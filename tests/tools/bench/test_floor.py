"""Figure 15's pure parts: its judgements of a floor's start, rest and streaming, and the
closing of every cell's stack whatever the others do."""

from __future__ import annotations

from contextlib import ExitStack
from typing import Any

import pytest

from motocell.tools.bench.bench_floor import (
    CellStacks,
    Measured,
    floor_results,
    memory_totals,
    per_cell,
    reached,
)
from motocell.tools.bench.bench_scale import MovingWindow, Trajectory
from motocell.tools.bench.bench_start_cost import ProcessRead
from motocell.tools.bench.measuring import ProcessCost, Window


def window(cpu: float, start_ns: int = 0, end_ns: int = 10) -> Window:
    return Window([ProcessCost("executor", 1, cpu, 5.0, 40.0, 15.0)], start_ns, end_ns)


def trajectory(ended_ns: int, *, error: str = "", off: int = 0) -> Trajectory:
    return Trajectory("floor1", ended_ns, 20, error, 0, off)


def measured(**changes: Any) -> Measured:
    values: dict[str, Any] = {
        "label": "own routers",
        "count": 100,
        "at_once": 2,
        "start_s": [0.9, 1.1],
        "ready_s": 52.0,
        "rest": [window(40.0)] * 3,
        "memory": [ProcessRead("executor", 0.1, 50.0, 40.0, 300.0)] * 100,
        "moving": [MovingWindow(window(90.0, 0, 100), 0, 80.0, 8)] * 3,
        "trajectories": [trajectory(50), trajectory(60)],
    }
    return Measured(**(values | changes))


def row(rows: list[dict[str, Any]], ending: str) -> dict[str, Any]:
    (found,) = [r for r in rows if r["name"].endswith(ending)]
    return found


def test_per_cell_divides_by_the_cells_and_never_by_zero() -> None:
    assert per_cell([50.0, 40.0], 100) == [0.5, 0.4]
    assert per_cell([3.0], 0) == [3.0]


def test_a_goal_is_reached_only_by_a_trajectory_taken_whole_and_ended_exactly_there() -> None:
    judged = [trajectory(1), trajectory(2, error="point 3 refused"), trajectory(3, off=1)]
    assert reached(judged) == 1


def test_memory_totals_add_every_process() -> None:
    reads = [ProcessRead("a", 0.0, 10.0, 8.0, 30.0), ProcessRead("b", 0.0, 5.0, 4.0, 20.0)]
    assert memory_totals(reads) == {"PSS": 15.0, "private": 12.0, "RSS": 50.0}


def test_a_floor_within_every_goal_meets_them_all() -> None:
    rows = floor_results(measured())
    judged = {r["name"]: r["met"] for r in rows if "met" in r}
    assert len(judged) == 5 and all(judged.values())
    assert row(rows, "at rest: CPU per cell")["median"] == pytest.approx(0.4)
    assert row(rows, "PSS per cell")["median"] == pytest.approx(50.0)


def test_a_floor_over_its_goals_says_which() -> None:
    rows = floor_results(
        measured(
            ready_s=121.0,
            rest=[window(51.0)] * 3,
            memory=[ProcessRead("executor", 0.1, 62.0, 40.0, 300.0)] * 100,
            trajectories=[trajectory(50), trajectory(60, off=2)],
        )
    )
    missed = {r["name"].split("] ", 1)[1] for r in rows if r.get("met") is False}
    assert missed == {
        "first spawn -> every cell ready",
        "at rest: CPU, every process",
        "at rest: PSS, every process",
        "8 streaming: trajectories aborted, the whole figure",
        "8 streaming: goals reached, the whole figure",
    }


def test_a_floor_that_streamed_nothing_reports_no_streaming_rows() -> None:
    rows = floor_results(measured(moving=[], trajectories=[]))
    assert not [r for r in rows if "streaming" in r["name"]]


def test_every_cell_is_closed_though_one_fails_and_the_failure_is_raised() -> None:
    closed: list[int] = []
    stacks = CellStacks()

    def fail() -> None:
        raise RuntimeError("cell 2 did not stop")

    for number in (1, 2, 3):
        stack = ExitStack()
        stack.callback(closed.append, number)
        if number == 2:
            stack.callback(fail)
        stacks.add(stack)
    with pytest.raises(RuntimeError, match="cell 2"):
        stacks.close(at_once=2)
    assert sorted(closed) == [1, 2, 3]
    stacks.close(at_once=2)  # nothing left to close
    assert sorted(closed) == [1, 2, 3]
