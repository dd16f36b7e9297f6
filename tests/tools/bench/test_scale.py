"""Figure 7's pure parts: idle cells within half the machine, aborted trajectories, the
largest moving count."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motocell.shared.bus.schemas import GroupTick, Tick
from motocell.shared.config import load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import Result
from motocell.tools.bench.bench_scale import (
    Moving,
    MovingWindow,
    Trajectory,
    aborted_by_kind,
    aborted_text,
    alarms_by_code,
    ended_outside,
    ended_within,
    idle_steps,
    is_still,
    largest_moving,
    largest_within,
    off_goal_pulses,
    share_limit,
    target_pulses,
)
from motocell.tools.bench.measuring import ProcessCost, Window, write_cell_file


def cost(kind: str, cpu: float) -> ProcessCost:
    return ProcessCost(kind, 1, cpu, 10.0, 40.0, 15.0)


# -- figure 7: idle cells ----------------------------------------------------------------------


def test_half_the_machine_is_a_core_on_two() -> None:
    assert share_limit(0.5, 2) == pytest.approx(100.0)
    assert share_limit(0.7, 2) == pytest.approx(140.0)


def test_the_steps_end_at_the_cap() -> None:
    assert idle_steps(quick=False)[-1] == 24
    assert idle_steps(quick=True) == (1, 2, 3, 4)


def test_the_largest_count_within_the_limit_has_every_smaller_one_within_it_too() -> None:
    assert largest_within({1: 2.0, 2: 4.0, 4: 9.0}, 100.0) == 4
    assert largest_within({1: 2.0, 2: 120.0, 4: 90.0}, 100.0) == 1
    assert largest_within({1: 101.0}, 100.0) == 0


# -- figure 7: moving cells, aborted trajectories ----------------------------------------------


def group_tick(command: list[int], feedback: list[int], moving: bool = False) -> GroupTick:
    step = [1 if moving else 0] * len(command)
    return GroupTick(command, feedback, step, 0, [0.0] * len(command))


def test_the_goal_is_in_pulses_as_the_wire_carries_it(tmp_path: Path) -> None:
    cell = load_cell(write_cell_file(tmp_path, "one", models=("arm6",)))
    goal = {0: (0.1, -0.2, 0.3, 0.0, 0.5, -1.0)}
    wire = np.array(goal[0], dtype=np.float32).astype(np.float64)
    expected = AxisMap(cell.groups[0]).ros_to_pulses(wire)
    assert np.array_equal(target_pulses(cell, goal)[0], expected)


def test_a_robot_off_its_last_point_by_a_pulse_commanded_or_felt_is_off() -> None:
    target = {0: np.array([100, 200]), 1: np.array([5])}
    exact = Tick(1, 0, 0, 0, True, [group_tick([100, 200, 0], [100, 200, 0]), group_tick([5], [5])])
    assert off_goal_pulses(exact, target) == 0
    felt = Tick(1, 0, 0, 0, True, [group_tick([100, 200], [100, 199]), group_tick([5], [5])])
    assert off_goal_pulses(felt, target) == 1
    commanded = Tick(1, 0, 0, 0, True, [group_tick([100, 200], [100, 200]), group_tick([8], [5])])
    assert off_goal_pulses(commanded, target) == 3


def test_a_tick_is_still_when_nothing_is_queued_or_moves() -> None:
    assert is_still(Tick(1, 0, 0, 0, True, [group_tick([1], [1])]))
    assert not is_still(Tick(1, 0, 0, 0, True, [group_tick([1], [1], moving=True)]))


def trajectory(ended_ns: int, error: str = "", refused: int = 0, off: int = 0) -> Trajectory:
    return Trajectory("c", ended_ns, 20, error, refused, off)


def test_trajectories_abort_on_a_refused_point_or_off_their_end() -> None:
    done = [
        trajectory(1),
        trajectory(2, "point 3 refused: NOT_READY", int(Result.NOT_READY), -1),
        trajectory(3, "point 0 refused: INVALID", int(Result.INVALID), -1),
        trajectory(4, off=2),
        trajectory(5, "point 1 refused", 99, -1),
    ]
    assert [t.aborted for t in done] == [False, True, True, True, True]
    assert aborted_by_kind(done) == {
        "NOT_READY": 1,
        "INVALID": 1,
        "not exactly at the end": 1,
        "result 99": 1,
    }
    assert [t.ended_ns for t in ended_within(done, Window([], 2, 4))] == [2, 3, 4]
    assert [t.ended_ns for t in ended_outside(done, [Window([], 2, 3), Window([], 5, 9)])] == [1, 4]


def moving_window(cells: int, missed: int, cpu: float) -> MovingWindow:
    return MovingWindow(Window([cost("executor", cpu)], 0, 1), missed, 50.0, cells)


def test_the_largest_moving_count_had_no_missed_period_within_the_cpu_limit() -> None:
    found = Moving(140.0, probes={1: moving_window(1, 0, 30.0), 2: moving_window(2, 0, 60.0)})
    found.windows = [moving_window(3, 0, 90.0), moving_window(3, 1, 90.0)]
    assert largest_moving(found) == 2
    found.windows = [moving_window(3, 0, 90.0)] * 3
    assert largest_moving(found) == 3
    found.probes[1] = moving_window(1, 2, 30.0)
    assert largest_moving(found) == 0


def test_aborted_trajectories_name_the_alarms_their_cells_logged() -> None:
    done = [
        Trajectory("a", 1, 20, "point 3 refused", int(Result.NOT_READY), -1, (4200,)),
        Trajectory("b", 2, 20, "", 0, 5, (4200, 4416)),
        Trajectory("c", 3, 20, "", 0, 0),
    ]
    assert alarms_by_code(done) == {4200: 2, 4416: 1}
    assert aborted_text(done) == (
        "NOT_READY 1, not exactly at the end 1; alarms logged: 4200 (2), 4416 (1)"
    )
    assert aborted_text(done[2:]) == "none aborted"
