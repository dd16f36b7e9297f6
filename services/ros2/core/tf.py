"""MotoROS2's ``tf`` from one state sample (docs/ros2.md, tf). Pure.

Robots only (arm groups; a positioner or a track has no Cartesian pose), numbered ``r1``,
``r2``... among the robots in group order, as MotoROS2 numbers them. Per robot, four transforms
in MotoROS2's order, every frame name behind ``tf_frame_prefix``:

- ``world`` to ``rN/base``: where the robot stands. MotoROS2 sends the robot's calibration
  (its RF frame) here; a simulated cell's is the group's ``base`` in the cell file.
- ``rN/base`` to ``rN/flange``: the flange at the fed-back position, turned as MotoROS2 turns
  it: x out of the flange face, as REP-103 points an end effector. Motoman's flange frame, and
  the DH flange motocell's kinematics give (docs/poses.md), has z out of the face instead.
- ``rN/flange`` to ``rN/tool0``: constant, the turn back: ``tool0`` is Motoman's flange
  frame, z out of the face, as ROS-Industrial's ``tool0``.
- ``rN/flange`` to ``rN/tcp_<tool>``: the selected tool's offset (the cell file's ``tools``),
  seen from the turned flange; the frame is named after the tool number.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from motocell.shared.bus.schemas import State
from motocell.shared.config import Cell, Group, Ros2Face
from motocell.shared.motion.forward_kinematics import FloatArray, pose, tool_transform

Quaternion = tuple[float, float, float, float]
"""x, y, z, w."""
Vector = tuple[float, float, float]

TOOL0_TO_FLANGE = np.array(
    [[0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
"""MotoROS2's flange in tool0: its x is tool0's z (out of the face), its y tool0's -y (a half
turn about the bisector of x and z; its own inverse)."""


@dataclass(frozen=True)
class FrameTransform:
    """``child``'s frame in ``parent``'s: geometry_msgs/TransformStamped without its stamp."""

    parent: str
    child: str
    translation: Vector
    rotation: Quaternion


def _vector(values: Sequence[float]) -> Vector:
    x, y, z = (float(value) for value in values)
    return (x, y, z)


def _quaternion(values: Sequence[float]) -> Quaternion:
    x, y, z, w = (float(value) for value in values)
    return (x, y, z, w)


def _rigid(transform: FloatArray) -> tuple[Vector, Quaternion]:
    position, orientation = pose(transform)
    return _vector(position.tolist()), _quaternion(orientation.tolist())


def multiply(a: Sequence[float], b: Sequence[float]) -> Quaternion:
    """The rotation ``a`` then, in its frame, ``b`` (Hamilton product, x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


_, TURN = _rigid(TOOL0_TO_FLANGE)
ORIGIN: Vector = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class _Robot:
    group: Group
    frame: str
    """``<prefix>rN``."""
    placed: FrameTransform
    """``world`` to ``rN/base``: never changes."""
    tool0: FrameTransform
    """``rN/flange`` to ``rN/tool0``: never changes."""


class Frames:
    """The ``tf`` transforms of a cell's robots for each state sample."""

    def __init__(self, cell: Cell, face: Ros2Face) -> None:
        prefix = face.tf_frame_prefix
        robots = [group for group in cell.groups if group.model.kind == "robot"]
        self._tools = cell.tool
        self._robots = [
            _robot(group, f"{prefix}r{number}", f"{prefix}world")
            for number, group in enumerate(robots, start=1)
        ]
        self._tcp: dict[int, tuple[Vector, Quaternion]] = {}
        """Per tool number, the TCP in the turned flange: computed once each."""

    def transforms(self, state: State) -> tuple[FrameTransform, ...]:
        """Every robot's four transforms at ``state``'s feedback; none for a robot whose
        sample has no flange pose."""
        transforms: list[FrameTransform] = []
        for robot in self._robots:
            shown = state.groups[robot.group.index]
            if shown.flange is None:
                continue
            flange = FrameTransform(
                f"{robot.frame}/base",
                f"{robot.frame}/flange",
                _vector(shown.flange.position),
                multiply(shown.flange.orientation, TURN),
            )
            translation, rotation = self._tcp_of(shown.tool)
            tcp = FrameTransform(
                f"{robot.frame}/flange", f"{robot.frame}/tcp_{shown.tool}", translation, rotation
            )
            transforms += [robot.placed, flange, robot.tool0, tcp]
        return tuple(transforms)

    def _tcp_of(self, tool: int) -> tuple[Vector, Quaternion]:
        if tool not in self._tcp:
            # TOOL0_TO_FLANGE is its own inverse: the flange to tool0, then the tool's offset.
            self._tcp[tool] = _rigid(TOOL0_TO_FLANGE @ tool_transform(self._tools(tool)))
        return self._tcp[tool]


def _robot(group: Group, frame: str, world: str) -> _Robot:
    where, turned = _rigid(tool_transform([*group.base.xyz, *group.base.rpy]))
    return _Robot(
        group,
        frame,
        FrameTransform(world, f"{frame}/base", where, turned),
        FrameTransform(f"{frame}/flange", f"{frame}/tool0", ORIGIN, TURN),
    )
