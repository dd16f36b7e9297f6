"""A cell file's ``[ros2]`` table (the ROS 2 face): MotoROS2's defaults filled in, and every bad
value refused in one line that names it."""

from __future__ import annotations

from typing import Any

import pytest

from motocell.shared.config import ConfigError, parse_cell

TWO_GROUPS = [{"name": "R1", "model": "arm6"}, {"name": "S1", "model": "positioner2"}]


def test_without_the_table_a_cell_has_no_face() -> None:
    assert parse_cell({}).ros2 is None


def test_an_empty_table_takes_motoros2s_defaults() -> None:
    face = parse_cell({"name": "paint-1", "groups": TWO_GROUPS, "ros2": {}}).ros2
    assert face is not None
    assert (face.ros_domain_id, face.node_name, face.node_namespace) == (0, "motoman_paint_1", "")
    assert face.joint_names == [
        [f"group_1/joint_{axis}" for axis in range(1, 7)],
        ["group_2/joint_1", "group_2/joint_2"],
    ]
    assert (face.publish_tf, face.namespace_tf, face.tf_frame_prefix) == (True, True, "")
    periods = face.update_periods
    assert (periods.controller_status_monitor_period, periods.action_feedback_publisher_period) == (
        10,
        20,
    )
    assert face.open_discovery is False


@pytest.mark.parametrize(
    ("table", "says"),
    [
        ({"ros_domain_id": 233}, "ros2.ros_domain_id: must be 0 to 232"),
        ({"node_name": "robot-1"}, "ros2.node_name: 'robot-1' is no ROS 2 node name"),
        ({"node_namespace": "/cell 1"}, "ros2.node_namespace: '/cell 1' is no ROS 2 namespace"),
        ({"joint_names": [["a"] * 6]}, "ros2.joint_names: one list per group"),
        ({"joint_names": [["a"] * 6, ["b", "c"]]}, "every joint needs a name of its own"),
        ({"joint_names": [list("abcdef"), ["b c", "d"]]}, "'b c' is no ROS 2 joint name"),
        (
            {"update_periods": {"controller_status_monitor_period": 0}},
            "controller_status_monitor_period: must be 1 to 1000",
        ),
    ],
)
def test_a_bad_value_is_refused_naming_it(table: dict[str, Any], says: str) -> None:
    with pytest.raises(ConfigError, match=None) as refused:
        parse_cell({"groups": TWO_GROUPS, "ros2": table})
    assert says in str(refused.value)
    assert "\n" not in str(refused.value)


def test_a_group_name_that_cannot_name_its_topic_is_refused() -> None:
    groups = [{"name": "R-1", "model": "arm6"}]
    with pytest.raises(ConfigError, match=r"groups\[0\]\.name: 'R-1' cannot name the face's"):
        parse_cell({"groups": groups, "ros2": {}})
    assert parse_cell({"groups": groups}).ros2 is None  # without the face, any name will do
