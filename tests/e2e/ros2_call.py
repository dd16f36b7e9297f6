"""A ROS 2 client of a cell's face that calls MotoROS2's services, in a process of its own
(rclpy and DDS stay out of pytest's). It reads commands from stdin, one per line, and answers
each with one line of JSON:

- ``call SERVICE [ARGUMENT...]``: the response (the request's fields in ``FIELDS`` order), as
  [result code, message, success, value] where the response has them;
- ``status FIELD VALUE``: the first ``robot_status`` whose FIELD (a TriState or RobotMode) has
  VALUE, received from now on, or ``null`` at its deadline;
- ``graph NODE [NAMESPACE]``: the topics NODE (in this caller's namespace, or in NAMESPACE)
  publishes, the services it serves, and the action servers, each with its types;
- ``publishers TOPIC``: every publisher of TOPIC (relative to this caller's namespace) as
  [node, type, type hash];
- ``follow SECONDS OFFSET POINTS [CANCEL_AFTER]``: a FollowJointTrajectory goal from where every
  joint is (``joint_states``) to OFFSET further, in SECONDS, POINTS points on a smooth profile,
  cancelled after CANCEL_AFTER seconds if given: [status, error_code, error_string, feedback
  messages, final joint_states positions, the goal's positions];
- ``queue SECONDS OFFSET POINTS [FIRST_OFF]``: the same path sent point by point with
  ``queue_traj_point`` (a BUSY point sent again after 5 ms), its first point FIRST_OFF away
  from where the joints are: [each point's last code, BUSY answers, final joint_states
  positions, the last point's positions]; it stops at the first code that is not SUCCESS.

    python tests/e2e/ros2_call.py DOMAIN NAMESPACE

It needs the environment of the interface packages (``Interfaces.environment``) and prints
``ready`` once the face's services and its ``robot_status`` are there.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from typing import Any

import rclpy
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from industrial_msgs.msg import RobotStatus
from motoros2_interfaces.srv import (
    QueueTrajPoint,
    ReadGroupIO,
    ReadMRegister,
    ReadSingleIO,
    ResetError,
    SelectMotionTool,
    StartPointQueueMode,
    StartTrajMode,
    WriteGroupIO,
    WriteMRegister,
    WriteSingleIO,
)
from rclpy.action.client import ActionClient
from rclpy.action.graph import get_action_server_names_and_types_by_node
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectoryPoint

DEADLINE_S = 30.0
"""For what takes well under a second: a bound for a hang, not a speed."""
SERVICES: dict[str, Any] = {
    "start_traj_mode": StartTrajMode,
    "start_point_queue_mode": StartPointQueueMode,
    "stop_traj_mode": Trigger,
    "reset_error": ResetError,
    "read_single_io": ReadSingleIO,
    "write_single_io": WriteSingleIO,
    "read_group_io": ReadGroupIO,
    "write_group_io": WriteGroupIO,
    "read_mregister": ReadMRegister,
    "write_mregister": WriteMRegister,
    "select_motion_tool": SelectMotionTool,
}
FIELDS = {
    "read_single_io": ("address",),
    "read_group_io": ("address",),
    "read_mregister": ("address",),
    "write_single_io": ("address", "value"),
    "write_group_io": ("address", "value"),
    "write_mregister": ("address", "value"),
    "select_motion_tool": ("group_number", "tool_number"),
}
"""The request fields of the services that take any, in the order a command line gives them."""


def main() -> None:
    domain, namespace = int(sys.argv[1]), sys.argv[2]
    context = Context()
    rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    node = Node("caller", namespace=namespace, context=context, start_parameter_services=False)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    statuses: list[Any] = []
    node.create_subscription(RobotStatus, "robot_status", statuses.append, qos_profile_sensor_data)
    clients = {name: node.create_client(kind, name) for name, kind in SERVICES.items()}
    joints: list[Any] = []
    node.create_subscription(JointState, "joint_states", joints.append, qos_profile_sensor_data)
    action = ActionClient(node, FollowJointTrajectory, "follow_joint_trajectory")
    queue = node.create_client(QueueTrajPoint, "queue_traj_point")

    def spin_until(done: Callable[[], bool]) -> bool:
        deadline = time.monotonic() + DEADLINE_S
        while not done() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        return done()

    assert spin_until(
        lambda: bool(statuses) and all(c.service_is_ready() for c in clients.values())
    )
    print("ready", flush=True)
    for line in sys.stdin:
        words = line.split()
        if words[0] == "call":
            request = SERVICES[words[1]].Request()
            for field, value in zip(FIELDS.get(words[1], ()), words[2:], strict=True):
                setattr(request, field, int(value))
            future = clients[words[1]].call_async(request)
            spin_until(future.done)
            answer: Any = described(future.result())
        elif words[0] == "graph":
            answer = graph(node, words[1], words[2] if len(words) > 2 else namespace)
        elif words[0] == "publishers":
            answer = [
                [info.node_name, info.topic_type, str(info.topic_type_hash)]
                for info in node.get_publishers_info_by_topic(node.resolve_topic_name(words[1]))
            ]
        elif words[0] == "follow":
            answer = follow(action, joints, spin_until, words[1:])
        elif words[0] == "queue":
            answer = queue_points(queue, joints, spin_until, words[1:])
        else:
            field, value = words[1], int(words[2])
            seen = len(statuses)
            found = spin_until(
                lambda: any(getattr(s, field).val == value for s in statuses[seen:])  # noqa: B023
            )
            answer = found
        print(json.dumps(answer), flush=True)
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown(context=context)


def graph(node: Node, name: str, namespace: str) -> dict[str, Any]:
    return {
        "topics": node.get_publisher_names_and_types_by_node(name, namespace),
        "services": node.get_service_names_and_types_by_node(name, namespace),
        "actions": get_action_server_names_and_types_by_node(node, name, namespace),
    }


def described(response: Any) -> list[Any]:
    if not hasattr(response, "result_code"):
        return [response.success, response.message]
    code = response.result_code
    answer = [getattr(code, "value", code), response.message]
    if hasattr(response, "success"):
        answer.append(response.success)
    if hasattr(response, "value"):
        answer.append(response.value)
    return answer


def path(names: list[str], start: list[float], seconds: float, offset: float, count: int) -> Any:
    """A trajectory from ``start`` to ``offset`` further in ``seconds``, ``count`` points."""
    trajectory = FollowJointTrajectory.Goal().trajectory
    trajectory.joint_names = names
    for index in range(count):
        share = index / (count - 1)
        # Smooth start and stop: position 3s^2 - 2s^3 of the way, its velocity zero at both ends.
        along = 3 * share**2 - 2 * share**3
        speed = 6 * share * (1 - share) / seconds
        point = JointTrajectoryPoint()
        point.positions = [p + offset * along for p in start]
        point.velocities = [offset * speed for _ in start]
        at = int(seconds * share * 1e9)
        point.time_from_start = Duration(sec=at // 1_000_000_000, nanosec=at % 1_000_000_000)
        trajectory.points.append(point)
    return trajectory


def queue_points(
    client: Any,
    joints: list[Any],
    spin_until: Callable[[Callable[[], bool]], bool],
    words: list[str],
) -> Any:
    seconds, offset, count = float(words[0]), float(words[1]), int(words[2])
    first_off = float(words[3]) if len(words) > 3 else 0.0
    here = joints[-1]
    trajectory = path(list(here.name), list(here.position), seconds, offset, count)
    trajectory.points[0].positions = [p + first_off for p in trajectory.points[0].positions]
    codes: list[int] = []
    busy = 0
    for point in trajectory.points:
        request = QueueTrajPoint.Request(joint_names=trajectory.joint_names, point=point)
        while True:
            future = client.call_async(request)
            spin_until(future.done)
            code = future.result().result_code.value
            if code != 4:  # BUSY
                break
            busy += 1
            time.sleep(0.005)
        codes.append(code)
        if code != 1:  # SUCCESS
            break
    seen = len(joints)
    spin_until(lambda: len(joints) > seen + 10)
    if codes[-1] == 1:
        resting = [0]

        def arrived() -> bool:
            still = all(abs(v) < 1e-6 for v in joints[-1].velocity)
            resting[0] = resting[0] + 1 if still else 0
            return resting[0] > 20

        spin_until(lambda: len(joints) > seen + 10 and arrived())
    return [codes, busy, list(joints[-1].position), list(trajectory.points[-1].positions)]


def follow(
    action: Any,
    joints: list[Any],
    spin_until: Callable[[Callable[[], bool]], bool],
    words: list[str],
) -> Any:
    seconds, offset, count = float(words[0]), float(words[1]), int(words[2])
    cancel_after = float(words[3]) if len(words) > 3 else None
    here = joints[-1]
    goal = FollowJointTrajectory.Goal()
    goal.trajectory = path(list(here.name), list(here.position), seconds, offset, count)
    feedback: list[Any] = []
    sent = action.send_goal_async(goal, feedback_callback=feedback.append)
    spin_until(sent.done)
    handle = sent.result()
    if cancel_after is not None:
        started = time.monotonic()
        spin_until(lambda: time.monotonic() - started > cancel_after)
        spin_until(handle.cancel_goal_async().done)
    result = handle.get_result_async()
    spin_until(result.done)
    outcome = result.result()
    seen = len(joints)
    spin_until(lambda: len(joints) > seen + 10)
    status = {GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED", GoalStatus.STATUS_ABORTED: "ABORTED"}
    return [
        status.get(
            outcome.status,
            "CANCELED" if outcome.status == GoalStatus.STATUS_CANCELED else str(outcome.status),
        ),
        outcome.result.error_code,
        outcome.result.error_string,
        len(feedback),
        list(joints[-1].position),
        list(goal.trajectory.points[-1].positions),
    ]


if __name__ == "__main__":
    main()
