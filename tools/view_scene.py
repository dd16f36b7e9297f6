"""The 3D scene of ``motocell view`` and ``motocell record``: every group of a cell as a tree of
frames along its links, with simple geometry fixed to those frames, placed in the cell.

Frames, for cell ``c`` and group ``g`` (the group's name in the cell file):

- ``c``: the cell's own frame (z up), the root of its tree; each cell has its own, so several
  cells never draw over each other.
- ``c/g/base``: the group's mounting, placed in ``c`` by the cell file's ``base`` (``xyz`` in
  metres, ``rpy`` in radians, as URDF's origin).
- ``c/g/link1`` ... ``c/g/linkN``: the model's DH frames (``forward_kinematics.Chain``), each
  relative to the one before, moved by the joints of each state.
- ``c/g/flange``: the last DH frame, named for what it is.
- ``c/g/tcp``: an arm's tool centre point in ``c/g/base``, as the state carries it (the
  broadcaster's kinematics with the selected tool); ``view_channels`` adds it.

The geometry is made once per cell and never moves in its frame (Foxglove's ``frame_locked``):
only the transforms travel with each state. A DH link ``Rz(theta + q) Tz(d) Tx(a) Rx(alpha)``
is drawn as its two segments: ``d`` along the parent's z (fixed in the parent frame: a turn about
z leaves the z axis where it is) and ``a`` along the link's own x, ending at its origin (fixed in
the link's frame). Each rotary joint is a short cylinder about its axis, each linear axis a rail
over its travel; a station gets a table on its last frame.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from motocell.shared.config import Cell, Group
from motocell.shared.motion.forward_kinematics import (
    Chain,
    FloatArray,
    quaternion,
    tool_transform,
)

LINK_RADIUS_M = 0.045
JOINT_RADIUS_M = 0.065
JOINT_LENGTH_M = 0.13
RAIL_WIDTH_M = 0.20
FLANGE_RADIUS_M = 0.045
FLANGE_THICKNESS_M = 0.015
TABLE_RADIUS_M = 0.35
TABLE_THICKNESS_M = 0.04
SHORTEST_SEGMENT_M = 1e-6
"""A DH length below this is no segment (the positioner's are all 0)."""

RGBA = tuple[float, float, float, float]
LINK_COLOUR: RGBA = (0.86, 0.88, 0.90, 1.0)
JOINT_COLOUR: RGBA = (0.05, 0.33, 0.65, 1.0)
"""Yaskawa's blue on white links, as the real arms are painted."""
STATION_COLOUR: RGBA = (0.35, 0.36, 0.38, 1.0)


@dataclass(frozen=True)
class Shape:
    """One primitive in its frame: a cylinder (its axis is its own z) or a box."""

    kind: str
    """``cylinder`` or ``cube``, as Foxglove names its primitives."""
    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    """x, y, z, w."""
    size: tuple[float, float, float]
    colour: RGBA


@dataclass(frozen=True)
class Transform:
    """``child`` in ``parent``: a translation (metres) and an x, y, z, w quaternion."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]


UPRIGHT = (0.0, 0.0, 0.0, 1.0)
ALONG_X = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))
"""Turns a cylinder's axis (z) onto x: a quarter turn about y."""


def cell_frame(cell: str) -> str:
    return cell


def base_frame(cell: str, group: str) -> str:
    return f"{cell}/{group}/base"


def link_frame(cell: str, group: str, link: int) -> str:
    """Link ``link`` (1-based) of ``group``; 0 is the base."""
    return base_frame(cell, group) if link == 0 else f"{cell}/{group}/link{link}"


def flange_frame(cell: str, group: str) -> str:
    return f"{cell}/{group}/flange"


def tcp_frame(cell: str, group: str) -> str:
    """The tool centre point, placed from the state's own pose (``GroupState.tcp``)."""
    return f"{cell}/{group}/tcp"


class GroupScene:
    """One group's frames and geometry; ``transforms`` turns its joints into frames."""

    def __init__(self, cell: str, group: Group) -> None:
        self.cell = cell
        self.group = group
        self.chain = Chain(group.model)
        placement = tool_transform([*group.base.xyz, *group.base.rpy])
        self._placement = _transform(cell_frame(cell), base_frame(cell, group.name), placement)

    def frames(self) -> list[str]:
        """Every frame of the group, root side first."""
        name = self.group.name
        links = [link_frame(self.cell, name, link) for link in range(self.chain.links + 1)]
        return [*links, flange_frame(self.cell, name)]

    def transforms(self, joints: Sequence[float]) -> list[Transform]:
        """The group's frames at ``joints`` (ROS order, radians or metres): its placement in
        the cell, each link in the one before, the flange."""
        name = self.group.name
        links = self.chain.link_transforms(np.asarray(joints, dtype=np.float64))
        rotations = quaternion(links).tolist()  # every link at once: one numpy pass
        translations = links[:, :3, 3].tolist()
        moved = [
            Transform(
                link_frame(self.cell, name, i),
                link_frame(self.cell, name, i + 1),
                (x, y, z),
                (qx, qy, qz, qw),
            )
            for i, ((x, y, z), (qx, qy, qz, qw)) in enumerate(
                zip(translations, rotations, strict=True)
            )
        ]
        last = link_frame(self.cell, name, self.chain.links)
        flange = Transform(last, flange_frame(self.cell, name), (0.0, 0.0, 0.0), UPRIGHT)
        return [self._placement, *moved, flange]

    def shapes(self) -> dict[str, list[Shape]]:
        """The group's geometry by the frame it is fixed to."""
        name = self.group.name
        drawn: dict[str, list[Shape]] = {frame: [] for frame in self.frames()}
        dh = self.group.model.dh
        for index, (_theta, d, a, _alpha) in enumerate(dh):
            parent = link_frame(self.cell, name, index)
            child = link_frame(self.cell, name, index + 1)
            if self.group.model.axis_types[index] == "linear":
                lower, upper = self.group.joint_limits[index]
                drawn[parent].append(_rail(d + lower, d + upper))
                drawn[child].append(_box((0.0, 0.0, 0.0), (0.4, 0.4, 0.08), JOINT_COLOUR))
            else:
                drawn[parent].append(_joint())
                drawn[parent].extend(_along_z(d))
            drawn[child].extend(_along_x(a))
        if self.group.model.kind == "station":
            drawn[flange_frame(self.cell, name)].append(_table())
        else:
            drawn[flange_frame(self.cell, name)].append(_flange())
        return {frame: shapes for frame, shapes in drawn.items() if shapes}


class CellScene:
    """Every group of one cell."""

    def __init__(self, cell: Cell) -> None:
        self.name = cell.name
        self.groups = {group.index: GroupScene(cell.name, group) for group in cell.groups}

    def transforms(self, joints: Mapping[int, Sequence[float]]) -> list[Transform]:
        """The frames of the groups in ``joints`` (group index -> positions); a group the cell
        does not have, or with another number of axes (a ``--config`` file that is not the
        running cell's), is left out rather than stopping the view."""
        return [
            transform
            for index, positions in joints.items()
            if index in self.groups and len(positions) == self.groups[index].group.axes
            for transform in self.groups[index].transforms(positions)
        ]

    def shapes(self) -> dict[str, list[Shape]]:
        return {
            frame: shapes
            for group in self.groups.values()
            for frame, shapes in group.shapes().items()
        }


def _transform(parent: str, child: str, matrix: FloatArray) -> Transform:
    x, y, z = (float(v) for v in matrix[:3, 3])
    qx, qy, qz, qw = (float(v) for v in quaternion(matrix))
    return Transform(parent, child, (x, y, z), (qx, qy, qz, qw))


def _cylinder(
    centre: tuple[float, float, float],
    orientation: tuple[float, float, float, float],
    diameter: float,
    length: float,
    colour: RGBA,
) -> Shape:
    return Shape("cylinder", centre, orientation, (diameter, diameter, length), colour)


def _box(
    centre: tuple[float, float, float], size: tuple[float, float, float], colour: RGBA
) -> Shape:
    return Shape("cube", centre, UPRIGHT, size, colour)


def _joint() -> Shape:
    return _cylinder((0.0, 0.0, 0.0), UPRIGHT, 2 * JOINT_RADIUS_M, JOINT_LENGTH_M, JOINT_COLOUR)


def _along_z(d: float) -> list[Shape]:
    """The ``d`` part of a link: from the parent's origin along its z."""
    if abs(d) < SHORTEST_SEGMENT_M:
        return []
    return [_cylinder((0.0, 0.0, d / 2), UPRIGHT, 2 * LINK_RADIUS_M, abs(d), LINK_COLOUR)]


def _along_x(a: float) -> list[Shape]:
    """The ``a`` part of a link: along the link's own x, ending at its origin."""
    if abs(a) < SHORTEST_SEGMENT_M:
        return []
    return [_cylinder((-a / 2, 0.0, 0.0), ALONG_X, 2 * LINK_RADIUS_M, abs(a), LINK_COLOUR)]


def _rail(start: float, end: float) -> Shape:
    """A linear axis's travel, along the parent's z."""
    length = max(abs(end - start), SHORTEST_SEGMENT_M)
    size = (RAIL_WIDTH_M, RAIL_WIDTH_M / 2, length)
    return _box((0.0, 0.0, (start + end) / 2), size, STATION_COLOUR)


def _flange() -> Shape:
    """The tool flange's face, on the flange frame."""
    centre = (0.0, 0.0, -FLANGE_THICKNESS_M / 2)
    return _cylinder(centre, UPRIGHT, 2 * FLANGE_RADIUS_M, FLANGE_THICKNESS_M, JOINT_COLOUR)


def _table() -> Shape:
    """A positioner's face plate, on its last frame."""
    centre = (0.0, 0.0, -TABLE_THICKNESS_M / 2)
    return _cylinder(centre, UPRIGHT, 2 * TABLE_RADIUS_M, TABLE_THICKNESS_M, STATION_COLOUR)
