"""A ROS 2 client of a cell's face, in a process of its own (rclpy and DDS stay out of pytest's):
it watches the face's topics and the ROS graph, says ``ready`` once a message of every topic came,
then prints what it saw as one JSON document.

    python tests/e2e/ros2_probe.py DOMAIN NAMESPACE TOPIC... --count N --timeout S

Every topic is a JointState with MotoROS2's QoS for it (sensor data), but ``tf``: a TFMessage
with the default QoS (reliable), as RViz subscribes to it.

Discovery stays on this host (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, set by the test).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

TF = "tf"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("domain", type=int)
    parser.add_argument("namespace")
    parser.add_argument("topics", nargs="+")
    parser.add_argument("--count", type=int, required=True)
    parser.add_argument("--timeout", type=float, required=True)
    args = parser.parse_args()
    context = Context()
    rclpy.init(
        context=context, domain_id=args.domain, signal_handler_options=SignalHandlerOptions.NO
    )
    node = Node("probe", namespace=args.namespace, context=context, start_parameter_services=False)
    seen: dict[str, list[dict[str, Any]]] = {topic: [] for topic in args.topics}

    def keep(topic: str) -> Any:
        def received(message: Any) -> None:
            stamp = message.header.stamp
            seen[topic].append(
                {
                    "received_ns": time.monotonic_ns(),
                    "stamp_ns": stamp.sec * 1_000_000_000 + stamp.nanosec,
                    "name": list(message.name),
                    "position": list(message.position),
                    "velocity": list(message.velocity),
                    "effort": list(message.effort),
                }
            )

        return received

    def keep_tf(message: Any) -> None:
        seen[TF].append(
            {
                "received_ns": time.monotonic_ns(),
                "transforms": [
                    {
                        "parent": one.header.frame_id,
                        "child": one.child_frame_id,
                        "stamp_ns": one.header.stamp.sec * 1_000_000_000 + one.header.stamp.nanosec,
                        "translation": [getattr(one.transform.translation, a) for a in "xyz"],
                        "rotation": [getattr(one.transform.rotation, a) for a in "xyzw"],
                    }
                    for one in message.transforms
                ],
            }
        )

    for topic in args.topics:
        if topic == TF:
            node.create_subscription(TFMessage, topic, keep_tf, 10)
        else:
            node.create_subscription(JointState, topic, keep(topic), qos_profile_sensor_data)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    deadline = time.monotonic() + args.timeout

    def spin_until(done: Callable[[], bool]) -> None:
        while time.monotonic() < deadline and not done():
            executor.spin_once(timeout_sec=0.05)

    spin_until(lambda: all(seen.values()))
    print("ready", flush=True)  # a message of every topic came: the test may go on
    spin_until(lambda: min(len(got) for got in seen.values()) >= args.count)

    # The graph's names arrive apart from the data: wait until every topic's publisher shows
    # with its node's name, and that node is listed.
    def publishers(topic: str) -> list[Any]:
        return list(node.get_publishers_info_by_topic(node.resolve_topic_name(topic)))

    def named() -> bool:
        found = [info for topic in seen for info in publishers(topic)]
        nodes = {tuple(pair) for pair in node.get_node_names_and_namespaces()}
        return len(found) >= len(seen) and all(
            (info.node_name, info.node_namespace) in nodes for info in found
        )

    spin_until(named)
    graph = {
        "nodes": [list(pair) for pair in node.get_node_names_and_namespaces()],
        "publishers": {
            topic: [
                {
                    "node": info.node_name,
                    "namespace": info.node_namespace,
                    "type": info.topic_type,
                    "hash": str(info.topic_type_hash),
                    "reliability": info.qos_profile.reliability.name,
                }
                for info in publishers(topic)
            ]
            for topic in args.topics
        },
    }
    print(json.dumps({"seen": seen, "graph": graph}))
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown(context=context)


if __name__ == "__main__":
    main()
