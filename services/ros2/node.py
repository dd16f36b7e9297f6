"""The face's rclpy node: MotoROS2's names, types and QoS (docs/ros2.md). Only this module
imports ROS 2, and only the face's process loads it: a cell without ``[ros2]`` never does.

The node is a plain one: no parameter services and no ``rosout`` publisher, since MotoROS2 (a
micro-ROS node) offers neither, and a client listing the graph sees MotoROS2's endpoints.
rclpy's own signal handlers are off: the service's stop flag owns SIGINT and SIGTERM.
"""

from __future__ import annotations

import os
import time

import rclpy
from builtin_interfaces.msg import Time as TimeMsg
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from sensor_msgs.msg import JointState

from motocell.services.ros2.core.topics import JointValues, TopicValues, ctrl_group_topic
from motocell.shared.config import Cell, Ros2Face

DISCOVERY_RANGE_ENV = "ROS_AUTOMATIC_DISCOVERY_RANGE"
"""Read by the RMW when rclpy starts: LOCALHOST keeps the face on this host."""


def discovery_range(face: Ros2Face) -> str:
    return "SUBNET" if face.open_discovery else "LOCALHOST"


class FaceNode:
    """``loop.Topics`` over an rclpy node in a context of its own."""

    def __init__(self, cell: Cell, face: Ros2Face) -> None:
        os.environ[DISCOVERY_RANGE_ENV] = discovery_range(face)
        self._context = Context()
        rclpy.init(
            context=self._context,
            domain_id=face.ros_domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )
        self.node = Node(
            face.node_name,
            namespace=face.node_namespace or None,
            context=self._context,
            enable_rosout=False,
            start_parameter_services=False,
        )
        qos = qos_profile_sensor_data  # MotoROS2's default for joint_states
        self._joint_states = self.node.create_publisher(JointState, "joint_states", qos)
        self._groups = [
            self.node.create_publisher(JointState, ctrl_group_topic(group), qos)
            for group in cell.groups
        ]

    def publish(self, values: TopicValues) -> None:
        # The values carry CLOCK_MONOTONIC; ROS stamps are the system clock's.
        stamp = Time(nanoseconds=values.sampled_ns + time.time_ns() - time.monotonic_ns()).to_msg()
        self._joint_states.publish(_joint_state(values.joint_states, stamp))
        for publisher, group in zip(self._groups, values.groups, strict=True):
            publisher.publish(_joint_state(group, stamp))

    def close(self) -> None:
        self.node.destroy_node()
        rclpy.shutdown(context=self._context)


def _joint_state(values: JointValues, stamp: TimeMsg) -> JointState:
    message = JointState()
    message.header.stamp = stamp
    message.name = list(values.names)
    message.position = list(values.positions)
    message.velocity = list(values.velocities)
    return message
