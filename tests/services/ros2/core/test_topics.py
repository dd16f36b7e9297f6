"""What the face's topics carry from one state sample: every group's joints in ``joint_states``,
each group's in its ``ctrl_groups`` topic, under the configured names."""

from __future__ import annotations

from msgspec.structs import replace

from motocell.services.ros2.core.topics import (
    ctrl_group_topic,
    group_spans,
    ros_order_names,
    topic_values,
)
from motocell.shared.config import Cell, parse_cell
from tests.services.ros2.scripted import MS, STATUS, face_cell, sample


def names_of(cell: Cell) -> list[tuple[str, ...]]:
    assert cell.ros2 is not None and cell.ros2.joint_names is not None
    return [
        ros_order_names(group, names)
        for group, names in zip(cell.groups, cell.ros2.joint_names, strict=True)
    ]


def test_joint_states_hold_every_group_in_order_and_each_group_its_own() -> None:
    cell = face_cell(groups=3)
    values = topic_values(sample(cell, 8 * MS), cell.groups, 8 * MS, STATUS)
    axes = [group.axes for group in cell.groups]
    assert axes == [6, 7, 1]
    # Every group's axes side by side, not the state's padding past them.
    assert values.positions == (0.25,) * sum(axes)
    assert values.velocities == (0.5,) * sum(axes)
    assert group_spans(cell.groups) == ((0, 6), (6, 13), (13, 14))
    assert (values.sampled_ns, values.status) == (8 * MS, STATUS)


def test_each_groups_values_sit_in_its_span() -> None:
    cell = face_cell(groups=2)
    resting = sample(cell, 0)
    second = replace(resting.groups[1], positions=[float(axis) for axis in range(10)])
    state = replace(resting, groups=[resting.groups[0], second])
    values = topic_values(state, cell.groups, 0, STATUS)
    start, end = group_spans(cell.groups)[1]
    assert values.positions[start:end] == tuple(float(axis) for axis in range(7))
    assert values.positions[:start] == (0.25,) * 6


def test_names_come_from_the_cell_file_and_topics_from_the_group_names() -> None:
    cell = parse_cell(
        {
            "groups": [{"name": "R1", "model": "arm6"}, {"name": "S1", "model": "positioner2"}],
            "ros2": {"joint_names": [[f"r1_{a}" for a in "slurbt"], ["s1_tilt", "s1_turn"]]},
        }
    )
    assert names_of(cell)[1] == ("s1_tilt", "s1_turn")
    assert names_of(cell)[0][:2] == ("r1_s", "r1_l")
    assert [ctrl_group_topic(group) for group in cell.groups] == [
        "ctrl_groups/r1/joint_states",
        "ctrl_groups/s1/joint_states",
    ]


def test_a_seven_axis_arms_elbow_is_published_third_as_motoros2_does() -> None:
    """The cell file lists S L U R B T E (motoros2_config.yaml's order); ROS order is
    S L E U R B T."""
    cell = parse_cell(
        {
            "groups": [{"name": "R1", "model": "arm7"}],
            "ros2": {"joint_names": [["s", "l", "u", "r", "b", "t", "e"]]},
        }
    )
    assert names_of(cell) == [("s", "l", "e", "u", "r", "b", "t")]
