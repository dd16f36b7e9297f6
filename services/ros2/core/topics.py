"""What MotoROS2's topics carry, from one ``state`` sample of the cell (docs/ros2.md, Topics).

``joint_states`` holds every joint of every group, in group order; ``ctrl_groups/<group>/
joint_states`` one group's (MotoROS2 names the groups r1, r2, b1, s1: here the cell file's group
names in lower case). Joints go in ROS order: the cell file lists a group's names in the
controller's axis order, as motoros2_config.yaml does (a 7-axis arm's elbow E last), and the
face, as MotoROS2, publishes the elbow third (``ros_order_names``). Positions and velocities are
the feedback's, in ROS units, as the state port sends them. MotoROS2 also fills ``effort`` from
the drives' torque feedback; the simulated drives have none, so ``effort`` is empty (a
JointState may leave any array empty).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

from motocell.shared.bus.schemas import RobotStatusFields, State
from motocell.shared.config import Cell, Group, Ros2Face
from motocell.shared.motion.kinematics import AxisMap


@dataclass(frozen=True)
class TopicValues:
    """One publication of the face's topics.

    Kept lean, since the face makes one every period: every group's joints side by side in
    group order (``joint_states``'s arrays), and ``spans`` says where each group's sit (its
    ``ctrl_groups`` topic's); the names never change and are the node's (``names_by_group``)."""

    sampled_ns: int
    """CLOCK_MONOTONIC when the values were measured: the tick's time, or now when the newest
    sample is published again while the robot rests (the shell stamps messages with it)."""
    positions: tuple[float, ...]
    velocities: tuple[float, ...]
    status: RobotStatusFields
    sample: State
    """The sample the values come from: ``tf`` is made from its poses (``core.tf``) only where
    someone reads it."""


def error_codes(status: RobotStatusFields) -> tuple[int, ...]:
    """``robot_status.error_codes``: the active alarm or error, none when there is none (the
    state's status carries the first one, as ROBOT_STATUS does)."""
    return (status.error_code,) if status.error_code else ()


def ctrl_group_topic(group: Group) -> str:
    return f"ctrl_groups/{group.name.lower()}/joint_states"


def ros_order_names(group: Group, names: Sequence[str]) -> tuple[str, ...]:
    """``names``, given in the controller's axis order, in the order the face publishes."""
    return tuple(names[int(moto)] for moto in AxisMap(group).moto_index_of_ros)


def names_by_group(cell: Cell, face: Ros2Face) -> list[tuple[str, ...]]:
    """Every group's joint names as the face publishes and reads them (``ros_order_names``)."""
    return [
        ros_order_names(group, names)
        for group, names in zip(cell.groups, face.joint_names or [], strict=True)
    ]


def group_spans(groups: Sequence[Group]) -> tuple[tuple[int, int], ...]:
    """Where each group's joints sit among every group's (``TopicValues.positions``)."""
    ends = list(itertools.accumulate(group.axes for group in groups))
    return tuple(zip([0, *ends[:-1]], ends, strict=True))


def topic_values(
    state: State, groups: Sequence[Group], sampled_ns: int, status: RobotStatusFields
) -> TopicValues:
    """The feedback of every group's axes (the state's arrays carry padding past them), in
    ROS order as the state carries them."""
    positions: list[float] = []
    velocities: list[float] = []
    for group in groups:
        shown = state.groups[group.index]
        positions += shown.positions[: group.axes]
        velocities += shown.velocities[: group.axes]
    return TopicValues(sampled_ns, tuple(positions), tuple(velocities), status, state)
