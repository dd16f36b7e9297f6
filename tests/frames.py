"""Frame trees composed for the tests, with no code of the kinematics they check: a quaternion
turned into a rotation by the textbook formula, frames chained up to a root, and a URDF chain
(joint origins and axes, as a URDF writes them) posed at given joint positions.

Foxglove's messages (``FrameTransforms``, ``PoseInFrame``, primitives' poses) come decoded from
protobuf; ``vector`` and ``rotation`` read their ``Vector3`` and ``Quaternion``."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Step = tuple[str, str, Sequence[float], Sequence[float]]
"""A frame in its parent: (parent, child, translation x, y, z, rotation x, y, z, w)."""


def rotation_matrix(q: Sequence[float] | FloatArray) -> FloatArray:
    """The rotation of a unit quaternion (x, y, z, w): the textbook formula."""
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def pose_matrix(translation: Sequence[float], rotation: Sequence[float]) -> FloatArray:
    """The 4x4 transform of a translation and an x, y, z, w quaternion."""
    result = np.eye(4)
    result[:3, :3] = rotation_matrix(rotation)
    result[:3, 3] = translation
    return result


def axis_rotation(axis: Sequence[float] | FloatArray, angle: float) -> FloatArray:
    """The rotation by ``angle`` about the unit ``axis``: Rodrigues' formula."""
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    rotation: FloatArray = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)
    return rotation


def rpy_matrix(rpy: Sequence[float]) -> FloatArray:
    """URDF's rpy: roll about x, then pitch about y, then yaw about z, all about the parent's
    fixed axes, so R = Rz(yaw) Ry(pitch) Rx(roll)."""
    roll, pitch, yaw = rpy
    return (
        axis_rotation((0.0, 0.0, 1.0), yaw)
        @ axis_rotation((0.0, 1.0, 0.0), pitch)
        @ axis_rotation((1.0, 0.0, 0.0), roll)
    )


class UrdfJoint(NamedTuple):
    """A URDF joint as its file writes it: the child link's origin in the parent link (``xyz``
    in metres, ``rpy`` in radians) and the revolute axis in the child link; no axis for a fixed
    joint."""

    xyz: Sequence[float]
    rpy: Sequence[float]
    axis: Sequence[float] | None = None


def urdf_pose(joints: Sequence[UrdfJoint], positions: Sequence[float]) -> FloatArray:
    """The last link of a URDF chain in the first joint's parent link, at ``positions`` (one
    per joint with an axis, in order): for each joint, its origin, then its turn about its
    axis."""
    if len(positions) != sum(joint.axis is not None for joint in joints):
        raise ValueError("one position per joint with an axis")
    turns = iter(positions)
    result = np.eye(4)
    for joint in joints:
        step = np.eye(4)
        step[:3, :3] = rpy_matrix(joint.rpy)
        step[:3, 3] = joint.xyz
        if joint.axis is not None:
            step[:3, :3] = step[:3, :3] @ axis_rotation(joint.axis, next(turns))
        result = result @ step
    return result


def in_root(steps: Iterable[Step], root: str) -> dict[str, FloatArray]:
    """Every frame of a tree as a 4x4 pose in ``root``, composed up the tree."""
    parents = {child: (parent, pose_matrix(t, r)) for parent, child, t, r in steps}

    def pose(frame: str) -> FloatArray:
        if frame == root:
            return np.eye(4)
        parent, step = parents[frame]
        composed: FloatArray = pose(parent) @ step
        return composed

    return {frame: pose(frame) for frame in [*parents, root]}


def vector(message: Any) -> tuple[float, float, float]:
    """A Foxglove ``Vector3``'s x, y, z."""
    return (message.x, message.y, message.z)


def rotation(message: Any) -> tuple[float, float, float, float]:
    """A Foxglove ``Quaternion``'s x, y, z, w."""
    return (message.x, message.y, message.z, message.w)


def foxglove_steps(frame_transforms: Any) -> list[Step]:
    """The transforms of a Foxglove ``FrameTransforms`` message as steps."""
    return [
        (t.parent_frame_id, t.child_frame_id, vector(t.translation), rotation(t.rotation))
        for t in frame_transforms.transforms
    ]
