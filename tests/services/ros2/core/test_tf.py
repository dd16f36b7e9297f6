"""MotoROS2's ``tf`` from a state sample the broadcaster made: robots only, numbered among the
robots, MotoROS2's frame names and order, and transforms that chain to the poses the state
port carries (the flange turned x out of the face, tool0 Motoman's flange, the TCP of the
selected tool)."""

from __future__ import annotations

import numpy as np
import pytest
from msgspec.structs import replace

from motocell.services.broadcaster.core.poses import Poses
from motocell.services.ros2.core.tf import Frames, FrameTransform, multiply
from motocell.shared.bus.schemas import CartesianPose, State
from motocell.shared.config import Cell, parse_cell
from motocell.shared.motion.forward_kinematics import FloatArray, tool_transform
from tests.services.ros2.scripted import MS, sample

TOOL = [0.01, -0.02, 0.15, 0.1, -0.2, 0.3]


def two_arm_cell(prefix: str = "") -> Cell:
    """R1, a positioner, and R2 placed 1.5 m along y and turned a quarter about z."""
    return parse_cell(
        {
            "groups": [
                {"name": "R1", "model": "arm6"},
                {"name": "S1", "model": "positioner2"},
                {"name": "R2", "model": "arm7", "base": {"xyz": [0, 1.5, 0], "rpy": [0, 0, 1.57]}},
            ],
            "tools": [[0.0] * 6, TOOL],
            "ros2": {"tf_frame_prefix": prefix},
        }
    )


def state_of(cell: Cell, tools: list[int]) -> State:
    """Every axis at 0.3 (commanded too), with the poses the broadcaster adds."""
    state = sample(cell, 8 * MS, position=0.3)
    groups = [replace(group, command_positions=group.positions) for group in state.groups]
    return Poses(cell).add(replace(state, groups=groups), tools)


def frames_of(cell: Cell) -> Frames:
    assert cell.ros2 is not None
    return Frames(cell, cell.ros2)


def matrix(translation: tuple[float, ...], rotation: tuple[float, ...]) -> FloatArray:
    x, y, z, w = rotation
    result = np.eye(4)
    result[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    result[:3, 3] = translation
    return result


def of(transform: FrameTransform) -> FloatArray:
    return matrix(transform.translation, transform.rotation)


def of_pose(pose: CartesianPose | None) -> FloatArray:
    assert pose is not None
    return matrix(tuple(pose.position), tuple(pose.orientation))


def test_each_robot_has_motoros2s_four_frames_and_positioners_none() -> None:
    cell = two_arm_cell("left/")
    transforms = frames_of(cell).transforms(state_of(cell, [1, 0, 0]))
    assert [(one.parent, one.child) for one in transforms] == [
        ("left/world", "left/r1/base"),
        ("left/r1/base", "left/r1/flange"),
        ("left/r1/flange", "left/r1/tool0"),
        ("left/r1/flange", "left/r1/tcp_1"),
        ("left/world", "left/r2/base"),
        ("left/r2/base", "left/r2/flange"),
        ("left/r2/flange", "left/r2/tool0"),
        ("left/r2/flange", "left/r2/tcp_0"),
    ]


@pytest.mark.parametrize("robot, group", [(0, 0), (1, 2)])
def test_the_frames_chain_to_the_poses_the_state_carries(robot: int, group: int) -> None:
    cell = two_arm_cell()
    state = state_of(cell, [1, 0, 1])
    placed, flange, tool0, tcp = frames_of(cell).transforms(state)[4 * robot : 4 * robot + 4]
    shown = state.groups[group]
    base = cell.groups[group].base
    assert np.allclose(of(placed), tool_transform([*base.xyz, *base.rpy]))
    assert np.allclose(of(flange) @ of(tool0), of_pose(shown.flange), atol=1e-9)
    assert np.allclose(of(flange) @ of(tcp), of_pose(shown.tcp), atol=1e-9)


def test_the_flange_points_x_out_of_the_face_where_tool0_points_z() -> None:
    cell = two_arm_cell()
    state = state_of(cell, [0, 0, 0])
    flange = frames_of(cell).transforms(state)[1]
    out_of_face = of_pose(state.groups[0].flange)[:3, 2]
    assert np.allclose(of(flange)[:3, 0], out_of_face)


def test_the_turn_to_tool0_undoes_the_turn_to_the_flange() -> None:
    tool0 = frames_of(two_arm_cell()).transforms(state_of(two_arm_cell(), [0, 0, 0]))[2]
    assert tool0.translation == (0.0, 0.0, 0.0)
    x, y, z, w = multiply(tool0.rotation, tool0.rotation)
    assert np.allclose(abs(w), 1.0) and np.allclose([x, y, z], 0.0)


def test_the_tcp_frame_follows_the_selected_tool() -> None:
    cell = two_arm_cell()
    frames = frames_of(cell)
    first = frames.transforms(state_of(cell, [0, 0, 0]))[3]
    then = frames.transforms(state_of(cell, [1, 0, 0]))[3]
    assert (first.child, then.child) == ("r1/tcp_0", "r1/tcp_1")
    assert first.translation == pytest.approx((0.0, 0.0, 0.0))
    assert np.linalg.norm(then.translation) == pytest.approx(np.linalg.norm(TOOL[:3]))
