"""A ROS 2 client of a cell's face that calls MotoROS2's services, in a process of its own
(rclpy and DDS stay out of pytest's). It reads commands from stdin, one per line, and answers
each with one line of JSON:

- ``call start_traj_mode`` / ``call stop_traj_mode`` / ``call reset_error``: the response;
- ``status FIELD VALUE``: the first ``robot_status`` whose FIELD (a TriState or RobotMode) has
  VALUE, received from now on, or ``null`` at its deadline.

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
from industrial_msgs.msg import RobotStatus
from motoros2_interfaces.srv import ResetError, StartTrajMode
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import Trigger

DEADLINE_S = 30.0
"""For what takes well under a second: a bound for a hang, not a speed."""
SERVICES: dict[str, Any] = {
    "start_traj_mode": StartTrajMode,
    "stop_traj_mode": Trigger,
    "reset_error": ResetError,
}


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
            future = clients[words[1]].call_async(SERVICES[words[1]].Request())
            spin_until(future.done)
            response = future.result()
            if hasattr(response, "result_code"):
                answer: Any = [response.result_code.value, response.message]
            else:
                answer = [response.success, response.message]
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


if __name__ == "__main__":
    main()
