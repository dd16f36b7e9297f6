"""Joint order and unit conversions between ROS (radians, ROS joint order) and Motoman
(pulses, Motoman axis order).

ROS order for a 7-axis arm is S-L-E-U-R-B-T; Motoman's pulse order is S-L-U-R-B-T-E
(motoros1 §4.3). For every other group the two orders are the same.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from motocell.shared.config import Group
from motocell.shared.protocol.constants import MAX_AXES

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

# moto[i] = ros[_SEVEN_AXIS_ROS_INDEX[i]]: moto[2..5] = ros[3..6], moto[6] = ros[2].
_SEVEN_AXIS_ROS_INDEX = (0, 1, 3, 4, 5, 6, 2)


class AxisMap:
    """Conversions for one group, precomputed once so the hot paths are array operations."""

    def __init__(self, group: Group) -> None:
        model = group.model
        self.axes = model.axes
        order = _SEVEN_AXIS_ROS_INDEX if model.seven_axis else tuple(range(self.axes))
        self.ros_index_of_moto = np.array(order, dtype=np.intp)
        self.moto_index_of_ros = np.argsort(self.ros_index_of_moto)
        self.pulses_per_unit_moto: FloatArray = np.array(
            [model.pulses_per_unit[i] for i in order], dtype=np.float64
        )
        self.max_speed_ros: FloatArray = np.array(model.max_speed, dtype=np.float64)
        self._ros_from_moto = [
            (int(moto), float(self.pulses_per_unit_moto[moto])) for moto in self.moto_index_of_ros
        ]
        """(Motoman index, pulses per unit) of each ROS joint, for ``ros_values``."""

    def ros_to_pulses(self, ros: FloatArray) -> IntArray:
        """Absolute pulses (Motoman order) for ROS-order positions; works on (n,) or (k, n).

        MotoROS truncates toward zero (``(int)(rad * PtoR)``, motoros1 §4.3); we round to
        nearest, which halves the worst error (0.5 pulse instead of 1) and keeps it unbiased.
        Either way increments are differences of absolute pulses, so no error accumulates.
        """
        moto = ros[..., self.ros_index_of_moto] * self.pulses_per_unit_moto
        return np.rint(moto).astype(np.int64)

    def pulses_to_ros(self, pulses: Sequence[float] | IntArray | FloatArray) -> FloatArray:
        """ROS-order positions (rad or m) for Motoman-order pulses (the first ``axes`` used);
        fractional pulses too (what a servo's feedback moved in a period)."""
        moto = np.asarray(pulses[: self.axes], dtype=np.float64) / self.pulses_per_unit_moto
        result: FloatArray = moto[self.moto_index_of_ros]
        return result

    def ros_values(self, pulses: Sequence[float], scale: float = 1.0) -> list[float]:
        """``pulses_to_ros(pulses) * scale`` as a list, in plain Python: the same arithmetic,
        so the same values, for the state path's few joints at the state rate, where numpy's
        per-call cost would be most of the work."""
        return [pulses[moto] / per_unit * scale for moto, per_unit in self._ros_from_moto]

    def max_increments(self, period_s: float) -> list[int]:
        """Pulses per period each Motoman axis can take: the speed limit MotoROS derives from
        the controller's maximum increment, turned back into pulses; one more for the rounding
        of absolute positions to whole pulses. Unused axes take none."""
        speeds = self.max_speed_ros[self.ros_index_of_moto]
        limits = np.ceil(speeds * self.pulses_per_unit_moto * period_s).astype(np.int64) + 1
        return self.pad_moto(limits)

    def pad_moto(self, pulses: IntArray) -> list[int]:
        """Pulses as the 8-slot Motoman axis list (unused axes 0)."""
        return [*pulses.tolist(), *([0] * (MAX_AXES - self.axes))]
