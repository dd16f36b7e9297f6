"""A cell with the face, and the state samples the tests feed it."""

from __future__ import annotations

from motocell.shared.bus.schemas import GroupState, RobotStatusFields, State
from motocell.shared.config import Cell, Ros2Face, parse_cell

MS = 1_000_000
PERIOD_NS = 10 * MS
"""The face's default period (``controller_status_monitor_period``)."""
STATUS = RobotStatusFields(
    drives_powered=1, e_stopped=0, error_code=0, in_error=0, in_motion=0, mode=2, motion_possible=1
)


def face_cell(groups: int = 1) -> Cell:
    models = ["arm6", "arm7", "track1", "positioner2"][:groups]
    names = ["R1", "R2", "B1", "S1"][:groups]
    return parse_cell(
        {
            "name": "face",
            "controller": "YRC1000",
            "groups": [{"name": n, "model": m} for n, m in zip(names, models, strict=True)],
            "ros2": {"ros_domain_id": 7},
        }
    )


def face_of(cell: Cell) -> Ros2Face:
    assert cell.ros2 is not None
    return cell.ros2


def sample(cell: Cell, tick_ns: int, position: float = 0.25) -> State:
    """Every axis at ``position``, moving at 0.5, at the tick of ``tick_ns``."""
    groups = [
        GroupState(
            group.index,
            [position] * group.axes + [0.0] * (10 - group.axes),
            [0.5] * group.axes + [0.0] * (10 - group.axes),
            [position] * group.axes,
        )
        for group in cell.groups
    ]
    return State(seq=1, tick=tick_ns // (4 * MS), tick_ns=tick_ns, groups=groups, status=STATUS)
