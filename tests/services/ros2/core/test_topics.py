"""What the face's topics carry from one state sample: every group's joints in ``joint_states``,
each group's in its ``ctrl_groups`` topic, under the configured names."""

from __future__ import annotations

from motocell.services.ros2.core.topics import ctrl_group_topic, topic_values
from motocell.shared.config import parse_cell
from tests.services.ros2.scripted import MS, STATUS, face_cell, sample


def test_joint_states_hold_every_group_in_order_and_each_group_its_own() -> None:
    cell = face_cell(groups=3)
    assert cell.ros2 is not None and cell.ros2.joint_names is not None
    values = topic_values(sample(cell, 8 * MS), cell.groups, cell.ros2.joint_names, 8 * MS)
    axes = [group.axes for group in cell.groups]
    assert [len(group.names) for group in values.groups] == axes == [6, 7, 1]
    assert values.joint_states.names[:2] == ("group_1/joint_1", "group_1/joint_2")
    assert values.joint_states.names[-1] == "group_3/joint_1"
    assert values.joint_states.positions == (0.25,) * sum(axes)
    assert values.joint_states.velocities == (0.5,) * sum(axes)
    assert values.groups[1].positions == (0.25,) * 7  # not the state's padding
    assert (values.sampled_ns, values.status) == (8 * MS, STATUS)


def test_names_come_from_the_cell_file_and_topics_from_the_group_names() -> None:
    cell = parse_cell(
        {
            "groups": [{"name": "R1", "model": "arm6"}, {"name": "S1", "model": "positioner2"}],
            "ros2": {"joint_names": [[f"r1_{a}" for a in "slurbt"], ["s1_tilt", "s1_turn"]]},
        }
    )
    assert cell.ros2 is not None and cell.ros2.joint_names is not None
    values = topic_values(sample(cell, 0), cell.groups, cell.ros2.joint_names, 0)
    assert values.groups[1].names == ("s1_tilt", "s1_turn")
    assert [ctrl_group_topic(group) for group in cell.groups] == [
        "ctrl_groups/r1/joint_states",
        "ctrl_groups/s1/joint_states",
    ]
