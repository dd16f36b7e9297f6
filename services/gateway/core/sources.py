"""One controller, one motion source: which face holds trajectory mode (docs/ros2.md, One motion
source).

A real controller has one motion API. The gateway serves it to two faces: the motion port's
Simple Message client and the ROS 2 face (``gateway/cmd/motion``). Whichever started trajectory
mode holds it alone until it stops it (or disconnects, or the controller's job ends: an E-stop,
a servo off); the other is refused with the code of its own protocol. The holder is taken
before START_TRAJ_MODE asks the controller, so two faces starting at once cannot both win.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from motocell.shared.bus.schemas import MotionHolder
from motocell.shared.protocol.constants import NotReadySubcode


class Source(Enum):
    SIMPLE_MESSAGE = "the motion port's client"
    ROS2 = "the ROS 2 face"


HOLDER = {Source.SIMPLE_MESSAGE: MotionHolder.MOTION_PORT, Source.ROS2: MotionHolder.ROS2_FACE}
"""How the gateway tells the cell who holds trajectory mode (its ``connections`` notice)."""


OTHER_HOLDS_SUBCODE = {
    # Simple Message has no word for it (MotoROS1 has one client): its catch-all.
    Source.SIMPLE_MESSAGE: int(NotReadySubcode.UNSPECIFIED),
    # Only on the face's path: MotoROS2's NOT_READY_OTHER_TRAJ_MODE_ACTIVE (114) in the
    # NOT_READY numbering its other codes share with MotoROS1's (5000 + n <-> 100 + n).
    Source.ROS2: 5014,
}
"""The NOT_READY subcode a face gets while the other holds trajectory mode."""


@dataclass
class MotionSources:
    holder: Source | None = None
    starting: bool = False
    """The holder's START_TRAJ_MODE is still with the controller."""

    def holding(self, operating: bool) -> Source | None:
        """The face that holds trajectory mode now (``operating``: the controller's job runs,
        as its last status says), if one does."""
        return self.holder if self.starting or operating else None

    def held_by_other(self, source: Source, operating: bool) -> bool:
        """Whether the other face holds trajectory mode."""
        holding = self.holding(operating)
        return holding is not None and holding is not source

    def begin_start(self, source: Source) -> None:
        self.holder, self.starting = source, True

    def end_start(self, source: Source, started: bool) -> None:
        if self.holder is source:
            self.starting = False
            if not started:
                self.holder = None

    def release(self, source: Source) -> None:
        if self.holder is source:
            self.holder, self.starting = None, False
