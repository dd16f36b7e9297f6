"""A tick's joints as the state carries them: per group, in ROS order and units."""

from __future__ import annotations

import pytest

from motocell.services.broadcaster.core.joints import JointStates
from tests.services.broadcaster.scripted import cell, group_tick, tick

ARM6_PPU = (58670.0, 58670.0, 58670.0, 32594.0, 32594.0, 21990.0)
ARM7_PPU = (65536.0, 65536.0, 65536.0, 65536.0, 36408.0, 36408.0, 24576.0)
"""ROS order S-L-E-U-R-B-T, from shared/models.toml."""


def test_positions_are_pulses_over_pulses_per_radian() -> None:
    pulses = [58670, -58670, 29335, 32594, 0, 21990, 0, 0]
    (state,) = JointStates(cell()).groups(tick(1, 0, group_tick(pulses)))
    assert state.positions == pytest.approx([1.0, -1.0, 0.5, 1.0, 0.0, 1.0])


def test_a_seven_axis_arm_reports_in_ros_order() -> None:
    # Motoman order S-L-U-R-B-T-E: the E axis (ROS index 2) is the seventh pulse.
    moto_ppu = [ARM7_PPU[i] for i in (0, 1, 3, 4, 5, 6, 2)]
    pulses = [round(moto_ppu[i] * (i + 1) / 10) for i in range(7)] + [0]
    (state,) = JointStates(cell("arm7")).groups(tick(1, 0, group_tick(pulses)))
    assert state.positions == pytest.approx([0.1, 0.2, 0.7, 0.3, 0.4, 0.5, 0.6], abs=1e-4)


def test_velocities_are_what_the_feedback_moved_per_period_in_radians_per_second() -> None:
    moved = [235.0, 0, 0, 0, 0, -176.0, 0, 0]
    (state,) = JointStates(cell(period_ms=4)).groups(tick(1, 0, group_tick(moved=moved)))
    expected = [235 / ARM6_PPU[0] / 0.004, 0, 0, 0, 0, -176 / ARM6_PPU[5] / 0.004]
    assert state.velocities == pytest.approx(expected)


def test_a_servo_lag_gives_feedback_and_commanded_velocities_each_in_ros_order() -> None:
    """The feedback's velocity is what the servo moved (fractional pulses), the commanded one
    the increment; the 7-axis arm's E axis (seventh pulse) is ROS index 2 in both."""
    moto_ppu = [ARM7_PPU[i] for i in (0, 1, 3, 4, 5, 6, 2)]
    increment = [round(moto_ppu[i] * (i + 1) * 0.004) for i in range(7)] + [0]
    moved = [inc / 2 + 0.25 for inc in increment[:7]] + [0.0]
    lagging = group_tick(increment=increment, moved=moved)
    (state,) = JointStates(cell("arm7")).groups(tick(1, 0, lagging))
    per_second = [m / ppu / 0.004 for m, ppu in zip(moved, moto_ppu, strict=False)]
    commanded = [i / ppu / 0.004 for i, ppu in zip(increment, moto_ppu, strict=False)]
    ros_of_moto = (0, 1, 3, 4, 5, 6, 2)
    assert state.velocities == pytest.approx([per_second[ros_of_moto.index(r)] for r in range(7)])
    assert state.command_velocities == pytest.approx(
        [commanded[ros_of_moto.index(r)] for r in range(7)]
    )
    assert state.command_velocities[2] == pytest.approx(7.0, abs=1e-3)


def test_velocities_scale_with_the_interpolation_period() -> None:
    moved = [587.0, 0, 0, 0, 0, 0, 0, 0]
    (state,) = JointStates(cell(period_ms=10)).groups(tick(1, 0, group_tick(moved=moved)))
    assert state.velocities[0] == pytest.approx(587 / ARM6_PPU[0] / 0.010)


def test_command_positions_come_from_the_command_pulses() -> None:
    command = [58670, 0, 0, 0, 0, 0, 0, 0]
    lagging = group_tick(command=command, feedback=[0] * 8)
    (state,) = JointStates(cell()).groups(tick(1, 0, lagging))
    assert state.command_positions[0] == pytest.approx(1.0)
    assert state.positions[0] == 0.0


def test_every_group_reports_its_own_axes_and_number() -> None:
    groups = JointStates(cell("arm6", "arm7", "positioner2")).groups(
        tick(1, 0, group_tick(), group_tick(), group_tick())
    )
    assert [g.group_no for g in groups] == [0, 1, 2]
    assert [len(g.positions) for g in groups] == [6, 7, 2]
    assert [len(g.velocities) for g in groups] == [6, 7, 2]


def test_a_linear_axis_reports_metres() -> None:
    (state,) = JointStates(cell("track1")).groups(tick(1, 0, group_tick([250_000] + [0] * 7)))
    assert state.positions == pytest.approx([0.25])


def test_a_tick_with_the_wrong_number_of_groups_is_refused() -> None:
    with pytest.raises(ValueError):
        JointStates(cell("arm6", "arm6")).groups(tick(1, 0, group_tick()))
