"""MotoROS2's mode and error services and its robot_status, seen by a real ROS 2 client of the
face (rclpy over FastDDS in a process of its own, this test's domain and namespace, this host
only); one motion source with the motion port's client; an E-stop no service clears."""

from __future__ import annotations

import json
import os
import random
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.catalog import Role
from motocell.shared.bus.schemas import CommandRequest
from motocell.shared.bus.session import call
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.ros2.interfaces import ensure
from motocell.testing.running_cell import RunningCell, running_cell
from tests.e2e.ros2_caller import Caller

pytestmark = pytest.mark.cell

DOMAIN = random.randrange(1, 101)
NAMESPACE = f"/s{os.getpid()}"
READY = [1, "Ready"]


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningCell]:
    cell_file = tmp_path_factory.mktemp("services") / "cell.toml"
    cell_file.write_text(
        f'name = "rosservices"\n[ros2]\nros_domain_id = {DOMAIN}\nnode_namespace = "{NAMESPACE}"\n'
    )
    with running_cell(cell_file, attempts=2) as running:
        yield running


@pytest.fixture(scope="module")
def ros(cell: RunningCell) -> Iterator[Caller]:
    """One caller for the module's tests: a ROS 2 process starts in seconds."""
    started = Caller(DOMAIN, NAMESPACE)
    yield started
    started.close()


@pytest.fixture
def caller(ros: Caller) -> Iterator[Caller]:
    """The module's caller, trajectory mode stopped after each test."""
    yield ros
    ros.ask("call", "stop_traj_mode")


def fault(bus: zenoh.Session, cell: RunningCell, kind: str, value: int) -> None:
    reply = call(bus, cell.keys.controller_fault(kind), CommandRequest(value=value))
    assert reply is not None and reply.result == Result.SUCCESS


def test_start_traj_mode_readies_the_robot_and_stop_traj_mode_ends_it(caller: Caller) -> None:
    assert caller.ask("call", "start_traj_mode") == READY
    assert caller.ask("status", "drives_powered", "1") is True
    assert caller.ask("status", "motion_possible", "1") is True
    assert caller.ask("call", "stop_traj_mode") == [True, ""]
    assert caller.ask("call", "reset_error") == READY


def test_while_the_motion_port_holds_trajectory_mode_the_face_is_refused(
    cell: RunningCell, caller: Caller
) -> None:
    with cell.motion() as motion:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        code, words = caller.ask("call", "start_traj_mode")
        assert (code, words) == (
            114,
            "Another trajectory mode is already active. Please call stop_traj_mode service",
        )
        assert caller.ask("call", "stop_traj_mode")[0] is False
        assert motion.command(Command.STOP_TRAJ_MODE).result == Result.SUCCESS
    assert caller.ask("call", "start_traj_mode") == READY


def test_reset_error_cannot_clear_an_e_stop(cell: RunningCell, caller: Caller) -> None:
    bus = cell.session(Role.OPERATOR)
    try:
        fault(bus, cell, "estop", 1)
        assert caller.ask("status", "e_stopped", "1") is True
        caller.ask("call", "reset_error")
        assert caller.ask("call", "start_traj_mode") == [
            NotReadySubcode.ESTOP - 4900,
            "The controller is in E-Stop",
        ]
        assert caller.ask("status", "e_stopped", "1") is True
        fault(bus, cell, "estop", 0)
        assert caller.ask("status", "e_stopped", "0") is True
        assert caller.ask("call", "reset_error") == READY
        assert caller.ask("call", "start_traj_mode") == READY
    finally:
        fault(bus, cell, "estop", 0)
        bus.close()


# -- follow_joint_trajectory ----------------------------------------------------------------


def test_a_goal_is_followed_to_its_end(caller: Caller) -> None:
    assert caller.ask("call", "start_traj_mode") == READY
    status, code, words, feedback, reached, goal = caller.ask("follow", "1.5", "0.2", "8")
    assert (status, code, words) == ("SUCCEEDED", 0, "Trajectory completed successfully!")
    assert feedback > 10, "feedback every 20 ms while it ran"
    assert max(abs(r - g) for r, g in zip(reached, goal, strict=True)) <= 1e-4


def test_a_cancelled_goal_stops_and_says_so(cell: RunningCell, caller: Caller) -> None:
    assert caller.ask("call", "start_traj_mode") == READY
    status, code, words, _, _, _ = caller.ask("follow", "3.0", "-0.2", "12", "0.8")
    assert (status, code, words) == ("CANCELED", -500300, "Goal was cancelled by the user.")
    with cell.state() as state:
        still = state.wait_still()
    # Nothing travels after the cancel: the robot is at rest, short of the goal.
    assert still.status is not None and still.status.in_motion == 0


def test_a_goal_without_trajectory_mode_is_aborted_with_motoros2s_code(caller: Caller) -> None:
    assert caller.ask("call", "stop_traj_mode")[0] is True
    status, code, words, feedback, _, _ = caller.ask("follow", "1.0", "0.1", "4")
    # Not motion-ready: the INIT_ROS job is not running (MotionReadyEnum 108).
    assert (status, code, feedback) == ("ABORTED", -100108, 0)
    assert words.startswith("The INIT_ROS job has not started")


def test_a_goal_of_more_than_200_points_is_aborted(caller: Caller) -> None:
    assert caller.ask("call", "start_traj_mode") == READY
    status, code, words, _, _, _ = caller.ask("follow", "4.0", "0.1", "201")
    assert (status, code) == ("ABORTED", -100202)
    assert words == "Trajectory contains too many points (Not enough memory)."


def test_an_e_stop_mid_goal_aborts_it_with_the_alarm_code(
    cell: RunningCell, caller: Caller
) -> None:
    assert caller.ask("call", "start_traj_mode") == READY
    bus = cell.session(Role.OPERATOR)
    stopper = threading.Timer(0.8, fault, args=(bus, cell, "estop", 1))
    stopper.start()
    try:
        status, code, _, _, _, _ = caller.ask("follow", "3.0", "0.2", "12")
        assert (status, code) == ("ABORTED", -100303)
    finally:
        stopper.join()
        fault(bus, cell, "estop", 0)
        bus.close()
    assert caller.ask("call", "reset_error") == READY


def test_a_goal_while_the_motion_port_holds_trajectory_mode_is_aborted(
    cell: RunningCell, caller: Caller
) -> None:
    assert caller.ask("call", "stop_traj_mode")[0] is True
    with cell.motion() as motion:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        status, code, _, _, _, _ = caller.ask("follow", "1.0", "0.1", "4")
        assert (status, code) == ("ABORTED", -100114), "NOT_READY_OTHER_TRAJ_MODE_ACTIVE"
        assert motion.command(Command.STOP_TRAJ_MODE).result == Result.SUCCESS


# -- point-queue mode ---------------------------------------------------------------------
QUEUED, WRONG_MODE = 1, 2
"""QueueResultEnum's SUCCESS and WRONG_MODE."""


def test_points_queued_one_by_one_move_the_robot_to_the_last(caller: Caller) -> None:
    assert caller.ask("call", "start_point_queue_mode") == READY
    try:
        codes, busy, reached, last = caller.ask("queue", "1.5", "0.2", "8")
        assert codes == [QUEUED] * 8, busy
        assert max(abs(r - g) for r, g in zip(reached, last, strict=True)) <= 1e-4
        # One mode at a time: trajectory mode and its goals are refused meanwhile.
        assert caller.ask("call", "start_traj_mode")[0] == 114
        status, code, _, _, _, _ = caller.ask("follow", "1.0", "0.1", "4")
        assert (status, code) == ("ABORTED", -100209), "INIT_TRAJ_WRONG_MODE"
    finally:
        assert caller.ask("call", "stop_traj_mode")[0] is True


def test_a_first_queued_point_away_from_the_robot_is_a_bad_start(caller: Caller) -> None:
    assert caller.ask("call", "start_point_queue_mode") == READY
    try:
        codes, _, _, _ = caller.ask("queue", "1.0", "0.1", "4", "0.05")
        assert codes == [204], "INIT_TRAJ_INVALID_STARTING_POS"
    finally:
        assert caller.ask("call", "stop_traj_mode")[0] is True


def test_a_queued_point_in_trajectory_mode_is_the_wrong_mode(caller: Caller) -> None:
    assert caller.ask("call", "start_traj_mode") == READY
    codes, _, _, _ = caller.ask("queue", "1.0", "0.1", "4")
    assert codes == [WRONG_MODE]


# -- I/O, M-registers, tools ------------------------------------------------------------------


def test_io_written_is_read_back_and_a_bad_address_says_so(caller: Caller) -> None:
    assert caller.ask("call", "write_single_io", "10010", "1") == [0, "Success", True]
    assert caller.ask("call", "read_single_io", "10010") == [0, "Success", True, 1]
    assert caller.ask("call", "write_group_io", "1001", "165") == [0, "Success", True]
    assert caller.ask("call", "read_group_io", "1001") == [0, "Success", True, 165]
    assert caller.ask("call", "write_mregister", "1000010", "4321")[:3] == [0, "Success", True]
    assert caller.ask("call", "read_mregister", "1000010") == [0, "Success", True, 4321]
    code, words, success, _ = caller.ask("call", "read_single_io", "4294967295")
    assert (code, success) == (1001, False)
    assert words == "Address cannot be read from (out of readable range)"
    assert caller.ask("call", "write_single_io", "9", "1")[:3] == [
        1002,
        "Address cannot be written to (out of writable range)",
        False,
    ]


def test_a_motion_tool_is_selected_by_group_and_number(caller: Caller) -> None:
    assert caller.ask("call", "select_motion_tool", "0", "3") == [0, "", True]
    assert caller.ask("call", "select_motion_tool", "5", "3") == [
        401,
        "Invalid control group",
        False,
    ]
    assert caller.ask("call", "select_motion_tool", "0", "64") == [
        402,
        "Invalid tool selection",
        False,
    ]


# -- the graph ----------------------------------------------------------------------------------

MOTOROS2_GRAPH = {
    "topics": {
        "joint_states": "sensor_msgs/msg/JointState",
        "ctrl_groups/r1/joint_states": "sensor_msgs/msg/JointState",
        "robot_status": "industrial_msgs/msg/RobotStatus",
        "tf": "tf2_msgs/msg/TFMessage",
    },
    "services": {
        "start_traj_mode": "motoros2_interfaces/srv/StartTrajMode",
        "start_point_queue_mode": "motoros2_interfaces/srv/StartPointQueueMode",
        "queue_traj_point": "motoros2_interfaces/srv/QueueTrajPoint",
        "stop_traj_mode": "std_srvs/srv/Trigger",
        "reset_error": "motoros2_interfaces/srv/ResetError",
        "read_single_io": "motoros2_interfaces/srv/ReadSingleIO",
        "write_single_io": "motoros2_interfaces/srv/WriteSingleIO",
        "read_group_io": "motoros2_interfaces/srv/ReadGroupIO",
        "write_group_io": "motoros2_interfaces/srv/WriteGroupIO",
        "read_mregister": "motoros2_interfaces/srv/ReadMRegister",
        "write_mregister": "motoros2_interfaces/srv/WriteMRegister",
        "select_motion_tool": "motoros2_interfaces/srv/SelectMotionTool",
    },
    "actions": {"follow_joint_trajectory": "control_msgs/action/FollowJointTrajectory"},
}
"""What this face has of MotoROS2's API, names relative to the node's namespace."""


ACTION_TOPICS = {
    "follow_joint_trajectory/_action/feedback": (
        "control_msgs/action/FollowJointTrajectory_FeedbackMessage"
    ),
    "follow_joint_trajectory/_action/status": "action_msgs/msg/GoalStatusArray",
}


def rosidl_hash(type_name: str) -> str:
    """The type hash ROS 2 Jazzy's rosidl wrote for ``type_name`` where its package was built:
    the wheels' prefix, or the interface packages motocell builds."""
    package, kind, _ = type_name.split("/")
    interfaces, _ = ensure()
    for share in (interfaces.prefix / "share", Path(sys.prefix) / "share"):
        for described in sorted((share / package / kind).glob("*.json")):
            for entry in json.loads(described.read_text())["type_hashes"]:
                if entry["type_name"] == type_name:
                    return str(entry["hash_string"])
    raise LookupError(type_name)


def test_every_topic_has_the_type_hash_rosidl_computes(caller: Caller) -> None:
    """rclpy reports a hash for each publisher (ROS 2 Jazzy has none for service endpoints):
    the face's topics and its action's, each as rosidl computes it for the definitions."""
    topics = {**MOTOROS2_GRAPH["topics"], **ACTION_TOPICS}
    for topic, type_name in topics.items():
        [(node, found_type, found_hash)] = caller.ask("publishers", topic)
        assert (node, found_type) == ("motoman_rosservices", type_name)
        assert found_hash == rosidl_hash(type_name), topic


def test_the_graph_has_motoros2s_names_and_types(caller: Caller) -> None:
    seen = caller.ask("graph", "motoman_rosservices")
    prefix = NAMESPACE + "/"
    for kind, expected in MOTOROS2_GRAPH.items():
        found = {
            name.removeprefix(prefix): types
            for name, types in seen[kind]
            if name.startswith(prefix) and "/_action/" not in name
        }
        for name, type_name in expected.items():
            assert found.get(name) == [type_name], (kind, name, found.get(name))
