"""ROBOT_STATUS's fields (motoros1 §6): in_motion from the ticks, the rest from the controller."""

from __future__ import annotations

import pytest

from motocell.services.broadcaster.core.robot_status import (
    IN_MOTION_PULSES,
    in_motion,
    robot_status,
)
from motocell.shared.bus.schemas import Alarm
from tests.services.broadcaster.scripted import STATUS, group_tick, status, tick


def test_an_idle_cell_is_not_in_motion() -> None:
    assert not in_motion(tick(1, 0, group_tick((5,) * 8)))


def test_entries_in_the_ring_mean_in_motion() -> None:
    assert in_motion(tick(1, 0, group_tick(depth=1)))


def test_a_lag_of_exactly_the_limit_is_not_motion() -> None:
    lagging = group_tick(command=[0] * 8, feedback=[IN_MOTION_PULSES, 0, 0, 0, 0, 0, 0, 0])
    assert not in_motion(tick(1, 0, lagging))


@pytest.mark.parametrize("lag", [IN_MOTION_PULSES + 1, -IN_MOTION_PULSES - 1])
def test_a_lag_beyond_the_limit_either_way_is_motion(lag: int) -> None:
    lagging = group_tick(command=[0] * 8, feedback=[0, 0, lag, 0, 0, 0, 0, 0])
    assert in_motion(tick(1, 0, lagging))


def test_a_lag_on_the_last_axis_counts() -> None:
    lagging = group_tick(command=[0] * 8, feedback=[0] * 7 + [IN_MOTION_PULSES + 1])
    assert in_motion(tick(1, 0, lagging))


def test_any_group_moving_makes_the_cell_in_motion() -> None:
    assert in_motion(tick(1, 0, group_tick(), group_tick(), group_tick(depth=3)))


def test_a_ready_controller_gives_every_field() -> None:
    fields = robot_status(STATUS, tick(), controller_alive=True)
    assert fields.drives_powered == 1
    assert fields.e_stopped == 0
    assert (fields.error_code, fields.in_error) == (0, 0)
    assert fields.in_motion == 0
    assert fields.mode == 1
    assert fields.motion_possible == 1


def test_no_status_yet_leaves_everything_unknown_and_motion_impossible() -> None:
    fields = robot_status(None, tick(1, 0, group_tick(depth=2)), controller_alive=True)
    assert fields.drives_powered == fields.e_stopped == fields.error_code == -1
    assert fields.in_error == fields.mode == -1
    assert fields.motion_possible == 0
    assert fields.in_motion == 1, "in_motion comes from the ticks, not the controller"


def test_a_status_from_a_controller_that_is_gone_is_not_believed() -> None:
    fields = robot_status(STATUS, tick(), controller_alive=False)
    assert (fields.drives_powered, fields.motion_possible, fields.mode) == (-1, 0, -1)


@pytest.mark.parametrize(
    ("servo_on", "eco", "powered"), [(True, False, 1), (True, True, 0), (False, False, 0)]
)
def test_drives_are_powered_with_servo_on_outside_energy_saving(
    servo_on: bool, eco: bool, powered: int
) -> None:
    fields = robot_status(status(servo_on=servo_on, eco=eco), tick(), controller_alive=True)
    assert fields.drives_powered == powered


def test_estop_is_reported() -> None:
    assert robot_status(status(estop=True), tick(), controller_alive=True).e_stopped == 1


def test_the_first_alarm_is_the_error_code() -> None:
    alarms = [Alarm(4107, 3), Alarm(9999)]
    fields = robot_status(status(alarms=alarms), tick(), controller_alive=True)
    assert (fields.error_code, fields.in_error) == (4107, 1)


def test_an_error_without_an_alarm_is_not_in_error() -> None:
    fields = robot_status(status(error=3), tick(), controller_alive=True)
    assert (fields.error_code, fields.in_error) == (0, 0)


@pytest.mark.parametrize(("play", "mode"), [(True, 2), (False, 1)])
def test_mode_is_two_in_play_else_one(play: bool, mode: int) -> None:
    assert robot_status(status(play=play), tick(), controller_alive=True).mode == mode


def test_motion_possible_follows_motion_ready() -> None:
    fields = robot_status(status(motion_ready=False), tick(), controller_alive=True)
    assert fields.motion_possible == 0
