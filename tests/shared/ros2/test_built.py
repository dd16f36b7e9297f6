"""The interface packages as built by ROS 2's rosidl: importable, with the type hashes rosidl
computed, and built once.

These build the cache when it is missing (minutes: ``scripts/setup dev`` builds it first) and
start rclpy in child processes, which load the packages' libraries at their start.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from pathlib import Path

import pytest

from motocell.shared.ros2 import interfaces
from motocell.shared.ros2.interfaces import Interfaces

pytestmark = [
    pytest.mark.cell,
    pytest.mark.skipif(
        interfaces.missing() == interfaces.INSTALL_EXTRA, reason=interfaces.INSTALL_EXTRA
    ),
    # A cache missing here is built here.
    pytest.mark.timeout(1800),
]

IMPORTS = """
from control_msgs.action import FollowJointTrajectory
from industrial_msgs.msg import RobotStatus
from motoros2_interfaces.srv import QueueTrajPoint
from tf2_msgs.msg import TFMessage

goal = FollowJointTrajectory.Goal()
goal.trajectory.joint_names = ["joint_1"]
request = QueueTrajPoint.Request()
print(type(RobotStatus().error_codes).__name__, request.joint_names, TFMessage().transforms)
"""

PUBLISHED_HASH = """
import time
import rclpy
from rclpy.node import Node
from industrial_msgs.msg import RobotStatus

rclpy.init()
node = Node("type_hash_probe")
node.create_publisher(RobotStatus, "robot_status", 1)
deadline = time.monotonic() + 30
while not (infos := node.get_publishers_info_by_topic("/robot_status")):
    assert time.monotonic() < deadline, "the publisher never showed in the graph"
    rclpy.spin_once(node, timeout_sec=0.05)
print(infos[0].topic_type, infos[0].topic_type_hash)
node.destroy_node()
rclpy.shutdown()
"""


@pytest.fixture(scope="module")
def built() -> Interfaces:
    return interfaces.ensure()[0]


def run(program: str, built: Interfaces) -> str:
    env = built.environment()
    # A domain of its own, and no discovery traffic off this host.
    env.update(
        ROS_DOMAIN_ID=str(random.randrange(1, 100)), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
    )
    result = subprocess.run(
        [sys.executable, "-c", program],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_a_process_with_their_environment_imports_them(built: Interfaces) -> None:
    assert run(IMPORTS, built).split(" ", 1)[0] == "array"


def test_a_publisher_reports_the_type_hash_rosidl_wrote(built: Interfaces) -> None:
    description = json.loads(
        (built.prefix / "share/industrial_msgs/msg/RobotStatus.json").read_text()
    )
    (wrote,) = (
        entry["hash_string"]
        for entry in description["type_hashes"]
        if entry["type_name"] == "industrial_msgs/msg/RobotStatus"
    )
    assert run(PUBLISHED_HASH, built).split() == ["industrial_msgs/msg/RobotStatus", wrote]


def test_the_cache_is_built_once(built: Interfaces) -> None:
    before = sorted(os.listdir(built.prefix.parent))
    again, built_again = interfaces.ensure()
    assert (again, built_again) == (built, False)
    assert sorted(os.listdir(built.prefix.parent)) == before


def test_the_command_finds_the_cache_and_says_where(built: Interfaces) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "motocell.shared.ros2.interfaces"],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    assert result.stdout == f"ROS 2 interfaces found in {built.prefix}\n"
    assert Path(built.prefix).is_dir()
