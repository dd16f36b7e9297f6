"""Forward kinematics from a robot model's DH table: every link's frame, the flange and the
tool centre point (TCP).

Conventions (docs/poses.md):

- The table is the one MOTO_GET_DH_PARAMETERS answers (``RobotModel.dh``), one row
  [theta, d, a, alpha] per link in ROS joint order, read as *standard* (distal) Denavit-Hartenberg:
  link i's frame relative to link i-1's is Rz(theta + q) Tz(d) Tx(a) Rx(alpha) for a rotary axis,
  Rz(theta) Tz(d + q) Tx(a) Rx(alpha) for a linear one. Read so, the arm6 table is a GP7 (flange
  0.560 m in front of the base and 0.815 m above it at all-zero joints) and the arm7 table an
  SIA10 (upright, flange 1.235 m above the base). Read as modified DH, arm6's flange would sit
  0.77 m to the side of the base and 0.04 m above it.
- Because the rows are in ROS order, a 7-axis arm's E axis is the third joint of the chain
  (S-L-E-U-R-B-T), between L and U where it really sits; Motoman's S-L-U-R-B-T-E order is for
  pulses only (``AxisMap``).
- The base frame is DH frame 0: the robot's mounting surface, z along the first axis (up for an
  arm), x forward at S = 0. The flange frame is the last DH frame: z out of the flange face.
- Metres and radians. Orientations are unit quaternions in the order x, y, z, w (as ROS and
  Foxglove write them), with w >= 0.
- A tool is [x, y, z, rx, ry, rz] in the flange frame: the TCP's offset, and its rotation as
  roll-pitch-yaw about the flange's fixed axes (R = Rz(rz) Ry(ry) Rx(rx), as URDF's rpy).
- Poses are defined for every model with a table; whether a group has a tool pose (arms only) is
  the caller's decision. Joints beyond the table's rows do not move any frame.

Everything takes joints as (..., axes) arrays, so the feedback and the commanded position go
through one call.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from motocell.shared.config import RobotModel

FloatArray = npt.NDArray[np.float64]

IDENTITY = np.eye(4)
"""The all-zero tool: the TCP is the flange."""
IDENTITY.setflags(write=False)


class Pose(NamedTuple):
    """A frame in its parent: position (x, y, z) in metres, orientation (x, y, z, w)."""

    position: FloatArray
    orientation: FloatArray


class Chain:
    """One model's kinematic chain, with its constants computed once: a pose costs a few numpy
    operations, whatever the number of links."""

    def __init__(self, model: RobotModel) -> None:
        dh = np.array(model.dh, dtype=np.float64).reshape(-1, 4)
        self.links = len(dh)
        linear = np.array([kind == "linear" for kind in model.axis_types[: self.links]])
        theta, d, a, alpha = dh.T
        ca, sa = np.cos(alpha), np.sin(alpha)
        # Rz(theta) Tz(d) Tx(a) Rx(alpha) = [ct, -st*ca,  st*sa, a*ct]
        #                                   [st,  ct*ca, -ct*sa, a*st]
        #                                   [ 0,     sa,     ca,    d]
        # is linear in cos(theta), sin(theta) and d, the only values a joint moves: a link's
        # frame is fixed + ct * by_cos + st * by_sin + d * by_d, with constants set here.
        self._fixed = np.zeros((self.links, 4, 4))
        self._fixed[:, 2, 1], self._fixed[:, 2, 2], self._fixed[:, 3, 3] = sa, ca, 1.0
        self._by_cos = np.zeros((self.links, 4, 4))
        self._by_cos[:, 0, 0], self._by_cos[:, 1, 1], self._by_cos[:, 0, 3] = 1.0, ca, a
        self._by_cos[:, 1, 2] = -sa
        self._by_sin = np.zeros((self.links, 4, 4))
        self._by_sin[:, 1, 0], self._by_sin[:, 0, 1], self._by_sin[:, 1, 3] = 1.0, -ca, a
        self._by_sin[:, 0, 2] = sa
        self._by_d = np.zeros((self.links, 4, 4))
        self._by_d[:, 2, 3] = 1.0
        self._theta = theta
        self._d = d
        self._rotary = (~linear).astype(np.float64)
        self._linear = linear.astype(np.float64)

    def link_transforms(self, joints: Sequence[float] | FloatArray) -> FloatArray:
        """Each link's frame relative to its parent's (the first's to the base), shape
        (..., links, 4, 4) for joints (..., axes): the frame tree of a 3D view."""
        q = np.asarray(joints, dtype=np.float64)[..., : self.links]
        theta = (self._theta + q * self._rotary)[..., None, None]
        d = (self._d + q * self._linear)[..., None, None]
        frames: FloatArray = (
            self._fixed + np.cos(theta) * self._by_cos + np.sin(theta) * self._by_sin
        ) + d * self._by_d
        return frames

    def flange(self, joints: Sequence[float] | FloatArray) -> FloatArray:
        """The flange's frame in the base frame, (..., 4, 4) for joints (..., axes)."""
        frames = self.link_transforms(joints)
        result = frames[..., 0, :, :]
        for link in range(1, self.links):
            result = result @ frames[..., link, :, :]
        return result

    def tcp(self, joints: Sequence[float] | FloatArray, tool: FloatArray = IDENTITY) -> FloatArray:
        """The tool centre point's frame in the base frame: the flange composed with ``tool``
        (a ``tool_transform``)."""
        result: FloatArray = self.flange(joints) @ tool
        return result


def tool_transform(offset: Sequence[float]) -> FloatArray:
    """The 4x4 transform of a tool [x, y, z, rx, ry, rz] (metres, radians) in the flange
    frame: rotation Rz(rz) Ry(ry) Rx(rx), then the translation."""
    x, y, z, rx, ry, rz = offset
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    return np.array(
        [
            [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx, x],
            [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx, y],
            [-sy, cy * sx, cy * cx, z],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def _shepperd_candidates(m: FloatArray) -> FloatArray:
    """Row k: the quaternion (x, y, z, w) times 4 * its component k, from a rotation matrix;
    entry [k, k] is 4 * (component k) squared."""
    return np.array(
        [
            [
                1 + m[0, 0] - m[1, 1] - m[2, 2],
                m[0, 1] + m[1, 0],
                m[0, 2] + m[2, 0],
                m[2, 1] - m[1, 2],
            ],
            [
                m[0, 1] + m[1, 0],
                1 - m[0, 0] + m[1, 1] - m[2, 2],
                m[1, 2] + m[2, 1],
                m[0, 2] - m[2, 0],
            ],
            [
                m[0, 2] + m[2, 0],
                m[1, 2] + m[2, 1],
                1 - m[0, 0] - m[1, 1] + m[2, 2],
                m[1, 0] - m[0, 1],
            ],
            [
                m[2, 1] - m[1, 2],
                m[0, 2] - m[2, 0],
                m[1, 0] - m[0, 1],
                1 + m[0, 0] + m[1, 1] + m[2, 2],
            ],
        ]
    )


# The candidates are linear in the matrix's 9 entries: constant + entries @ per-entry, one
# matrix product for any number of rotations instead of 16 sums of slices each.
_CANDIDATES_CONSTANT = _shepperd_candidates(np.zeros((3, 3))).reshape(16)
_CANDIDATES_PER_ENTRY = np.array(
    [
        _shepperd_candidates(unit).reshape(16) - _CANDIDATES_CONSTANT
        for unit in np.eye(9).reshape(9, 3, 3)
    ]
)
_DIAGONAL = np.arange(4)


def quaternion(rotation: FloatArray) -> FloatArray:
    """Unit quaternions (..., 4) in x, y, z, w order with w >= 0 for rotation matrices
    (..., 3, 3) (or the top-left of (..., 4, 4) transforms).

    Shepperd's method: of the four ways to take the quaternion from the matrix, each divides by
    one component, so the one with the largest component is used; copying signs from the
    off-diagonal alone would pick inconsistent signs near half-turns."""
    m = rotation[..., :3, :3]
    batch = m.shape[:-2]
    entries = m.reshape(-1, 9)
    candidates = (entries @ _CANDIDATES_PER_ENTRY + _CANDIDATES_CONSTANT).reshape(-1, 4, 4)
    best = np.argmax(candidates[:, _DIAGONAL, _DIAGONAL], axis=-1)
    q = candidates[np.arange(len(best)), best]
    # One division normalises and makes w >= 0.
    q /= np.copysign(np.linalg.norm(q, axis=-1, keepdims=True), q[:, 3:])
    result: FloatArray = q.reshape(*batch, 4)
    return result


def pose(transform: FloatArray) -> Pose:
    """A 4x4 transform (or a stack of them) as position and x, y, z, w quaternion."""
    return Pose(transform[..., :3, 3].copy(), quaternion(transform))


def tool_pose(model: RobotModel, tool: Sequence[float], joints: Sequence[float]) -> Pose:
    """The TCP of ``model`` at ``joints`` (ROS order) with ``tool`` [x, y, z, rx, ry, rz], in
    the base frame. Builds the chain each call: keep a ``Chain`` for repeated poses."""
    return pose(Chain(model).tcp(joints, tool_transform(tool)))
