"""A user's own tests of a Simple Message client against motocell, run from outside the
repository against an installed motocell (tests/testing/test_installed_plugin.py copies it
there as test_client.py): one passes, one fails on purpose, one starts two cells with the
factory, one asks for a cell it cannot have."""

import pytest

from motocell.shared.protocol.constants import Command, Result
from motocell.testing import CellUnderTest, ConfigError, StartCell
from motocell.testing.client import MotionClient, smooth_move, stream


def test_the_robot_moves_to_the_last_point(motocell_cell: CellUnderTest) -> None:
    cell = motocell_cell
    start = cell.positions()
    goal = tuple(position + 0.2 for position in start)
    with MotionClient(cell.host, cell.motion_port) as motion:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        streamed = stream(motion, smooth_move(start, goal, duration=1.0, points=11))
        assert streamed.outcome == "SUCCESS"
        cell.wait_at_rest()  # before closing: a motion client that leaves stops the robot
    assert cell.positions() == pytest.approx(goal, abs=1e-4)
    assert 0 < max(cell.following_error().max_units) < 0.05


def test_trajectory_mode_under_an_estop_fails_on_purpose(
    motocell_session_cell: CellUnderTest,
) -> None:
    cell = motocell_session_cell
    cell.fault("estop", "on")
    with MotionClient(cell.host, cell.motion_port) as motion:
        reply = motion.command(Command.START_TRAJ_MODE)
    assert reply.result == Result.SUCCESS, "fails on purpose: the E-stop is on"


def test_a_big_endian_four_group_cell_beside_a_default_one(motocell_cells: StartCell) -> None:
    four = motocell_cells(config="four-group", byte_order="big")
    one = motocell_cells()
    assert (four.byte_order, len(four.config.groups)) == ("big", 4)
    assert four.name != one.name
    assert four.motion_port != one.motion_port
    assert len(four.positions(group=3)) == four.config.groups[3].axes


def test_a_setting_a_cell_cannot_take_is_refused_before_it_starts(
    motocell_cells: StartCell,
) -> None:
    with pytest.raises(ConfigError, match=r"byte_order: .*one of: little, big"):
        motocell_cells(byte_order="middle")
